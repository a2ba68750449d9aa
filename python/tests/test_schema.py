"""The committed JSON Schemas of the protocol and library files
(docs/schema/, generated from the Rust types) checked by an independent
implementation: every shipped protocol and library, read by Python's own
TOML parser, validates; files broken in the ways authors break them do
not, and `lmhost study check` (the Rust loader) refuses them too; each
shipped file's `#:schema` line names its schema."""

import json
import tomllib

import pytest
from jsonschema import Draft202012Validator

from conftest import ROOT, cli

SCHEMAS = ROOT / "docs" / "schema"
SHIPPED = sorted((ROOT / "studies").glob("*.toml"))


def _validator(kind):
    schema = json.loads((SCHEMAS / f"{kind}.schema.json").read_text())
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def _kind(doc):
    # A protocol has a timeline; a library is only its [[stimulus]] tables.
    return "protocol" if "timeline" in doc else "library"


def _load(path):
    return tomllib.loads(path.read_text())


def _errors(kind, doc):
    return [e.message for e in _validator(kind).iter_errors(doc)]


def test_the_shipped_files_are_protocols_and_libraries():
    kinds = [_kind(_load(p)) for p in SHIPPED]
    assert kinds.count("protocol") >= 4 and kinds.count("library") >= 2, kinds


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_file_validates_against_its_schema(path):
    doc = _load(path)
    kind = _kind(doc)
    assert _errors(kind, doc) == [], path.name
    # The other schema refuses it: the check above is not vacuous.
    other = "library" if kind == "protocol" else "protocol"
    assert _errors(other, doc) != [], path.name


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_file_names_its_schema_for_editors(path):
    first = path.read_text().splitlines()[0]
    kind = _kind(_load(path))
    assert first == f"#:schema ../docs/schema/{kind}.schema.json", path.name
    assert (path.parent / first.split()[1]).resolve() == SCHEMAS / f"{kind}.schema.json"


def _broken(name, old, new):
    text = (ROOT / "studies" / name).read_text()
    assert old in text, (name, old)
    return text.replace(old, new, 1)


def _refused_by_lmhost(lmhost_bin, tmp_path, protocol, library=None):
    """Whether `lmhost study check` (the Rust loader) refuses it as bad input."""
    studies = ROOT / "studies"
    (tmp_path / "p.toml").write_text(protocol)
    lib = library if library is not None else (studies / "paper-library.toml").read_text()
    (tmp_path / "paper-library.toml").write_text(lib)
    r = cli(lmhost_bin, "study", "check", tmp_path / "p.toml", check=False)
    return r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr


# (what, old text, new text, the validator's words)
PROTOCOL_BREAKS = [
    ("unknown key", "sets = 2", 'sets = 2\ncolour = "red"', "Additional properties"),
    ("unknown timeline key", "iti_s = 1.0", "iti_s = 1.0\non_ms = 500", "Additional properties"),
    ("wrong type", "sets = 2", 'sets = "2"', "is not of type 'integer'"),
    ("sets out of range", "sets = 2", "sets = 101", "is greater than the maximum"),
    ("zero sets", "sets = 2", "sets = 0", "is less than the minimum"),
    ("on_s of zero", "iti_s = 1.0", "iti_s = 1.0\non_s = 0", "less than or equal to the minimum"),
    ("iti_s too long", "iti_s = 1.0", "iti_s = 3601", "is greater than the maximum"),
    ("unknown order", "sets = 2", 'sets = 2\norder = "shuffled"', "is not valid under any of"),
    ("unknown gate", 'gate = "tracked"', 'gate = "loose"', "is not valid under any of"),
    ("bad name", 'name = "paper-exp1"', 'name = "exp 1"', "does not match"),
    ("no library", 'library = "paper-library.toml"', "", "'library' is a required property"),
    ("points out of range", "points = 7", "points = 12", "is greater than the maximum"),
    ("blank label", 'low = "not at all"', 'low = "  "', "does not match"),
    ("unknown kind", 'kind = "likert"', 'kind = "slider"', "is not valid under any of"),
]


@pytest.mark.parametrize("what,old,new,needle", PROTOCOL_BREAKS, ids=[b[0] for b in PROTOCOL_BREAKS])
def test_a_broken_protocol_is_refused_by_the_schema_and_by_lmhost(
    lmhost_bin, tmp_path, what, old, new, needle
):
    text = _broken("paper-exp1.toml", old, new)
    errors = _errors("protocol", tomllib.loads(text))
    assert any(needle in e for e in errors), (what, errors)
    refused, stderr = _refused_by_lmhost(lmhost_bin, tmp_path, text)
    assert refused, (what, stderr)


def test_the_unbroken_copy_passes_both(lmhost_bin, tmp_path):
    # The harness above refuses for the break, not for the copying.
    text = _broken("paper-exp1.toml", "sets = 2", "sets = 3")
    assert _errors("protocol", tomllib.loads(text)) == []
    refused, stderr = _refused_by_lmhost(lmhost_bin, tmp_path, text)
    assert not refused, stderr


@pytest.mark.parametrize("label", ["3", "+2", " yes", "yes|no", "", "a\tb"])
def test_an_answer_label_that_could_not_be_typed_back_is_refused(lmhost_bin, tmp_path, label):
    text = _broken("staircase-detection.toml", 'yes = "yes"', f"yes = {json.dumps(label)}")
    assert _errors("protocol", tomllib.loads(text)) != [], repr(label)
    lib = (ROOT / "studies" / "staircase-library.toml").read_text()
    text = text.replace("staircase-library", "paper-library")
    refused, stderr = _refused_by_lmhost(lmhost_bin, tmp_path, text, lib)
    assert refused, (label, stderr)


def test_a_fair_answer_label_passes():
    text = _broken("staircase-detection.toml", 'yes = "yes"', 'yes = "felt it"')
    assert _errors("protocol", tomllib.loads(text)) == []


# (what, a line added to the first entry or (old, new), the validator's
# words, whether loading refuses it: the rest, such as a radius, is refused
# when the entry is planned for a device)
LIBRARY_BREAKS = [
    ("unknown key", "colour = 1", "Additional properties", True),
    ("wrong type", ("radius = 2.0", 'radius = "2"'), "is not of type 'number'", True),
    ("radius out of range", ("radius = 2.0", "radius = 101.0"), "greater than the maximum", False),
    ("intensity out of range", "intensity = -0.5", "is less than the minimum", True),
    ("no foci", ("foci = 1", "foci = 0"), "is less than the minimum", False),
    ("centre out of range", "center = [0, 0, 1e9]", "is greater than the maximum", True),
    ("centre of two", "center = [0, 0]", "is too short", True),
    ("bad id", ('id = "lms-5hz-a2"', 'id = "lms 5hz"'), "does not match", True),
    ("no id", ('id = "lms-5hz-a2"\n', ""), "'id' is a required property", True),
    ("unknown shape", 'path = { shape = "star" }', "is not one of", True),
    ("am without freq", 'am = { shape = "sine" }', "'freq' is a required property", True),
    ("am too fast", 'am = { shape = "sine", freq = 1000 }', "greater than the maximum", True),
]


@pytest.mark.parametrize("what,edit,needle,at_load", LIBRARY_BREAKS, ids=[b[0] for b in LIBRARY_BREAKS])
def test_a_broken_library_is_refused(lmhost_bin, tmp_path, what, edit, needle, at_load):
    old, new = edit if isinstance(edit, tuple) else ("step = 0.23", f"step = 0.23\n{edit}")
    text = _broken("paper-library.toml", old, new)
    errors = _errors("library", tomllib.loads(text))
    assert any(needle in e for e in errors), (what, errors)
    if at_load:
        protocol = (ROOT / "studies" / "paper-exp1.toml").read_text()
        refused, stderr = _refused_by_lmhost(lmhost_bin, tmp_path, protocol, text)
        assert refused, (what, stderr)


def test_a_library_without_stimuli_is_refused():
    assert any("'stimulus' is a required property" in e for e in _errors("library", {}))
    assert any("should be non-empty" in e for e in _errors("library", {"stimulus": []}))
