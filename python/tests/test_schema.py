"""The committed JSON Schemas of the protocol and library files
(docs/schema/, generated from the Rust types) checked by an independent
implementation: every shipped protocol and library, read by Python's own
TOML parser, validates; files broken in the ways authors break them do
not; each shipped file's `#:schema` line names its schema."""

import copy
import json
import tomllib

import pytest
from jsonschema import Draft202012Validator

from conftest import ROOT

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


def _broken(name, change):
    doc = copy.deepcopy(_load(ROOT / "studies" / name))
    change(doc)
    return doc


def _set(path, value):
    def change(doc):
        *parents, key = path
        for p in parents:
            doc = doc[p]
        doc[key] = value

    return change


def _drop(*path):
    def change(doc):
        *parents, key = path
        for p in parents:
            doc = doc[p]
        del doc[key]

    return change


PROTOCOL_BREAKS = [
    ("unknown key", _set(["colour"], "red"), "Additional properties"),
    ("unknown timeline key", _set(["timeline", "on_ms"], 500), "Additional properties"),
    ("wrong type", _set(["sets"], "2"), "is not of type 'integer'"),
    ("sets out of range", _set(["sets"], 101), "is greater than the maximum"),
    ("zero sets", _set(["sets"], 0), "is less than the minimum"),
    ("on_s of zero", _set(["timeline", "on_s"], 0.0), "less than or equal to the minimum"),
    ("unknown order", _set(["order"], "shuffled"), "is not valid under any of the given schemas"),
    ("bad name", _set(["name"], "exp 1"), "does not match"),
    ("no timeline", _drop("timeline"), "'timeline' is a required property"),
    ("no factors", _set(["factor"], []), "should be non-empty"),
    ("points out of range", _set(["question", 0, "points"], 12), "is greater than the maximum"),
    ("blank label", _set(["question", 0, "low"], "  "), "does not match"),
]


@pytest.mark.parametrize("what,change,needle", PROTOCOL_BREAKS, ids=[b[0] for b in PROTOCOL_BREAKS])
def test_a_broken_protocol_is_refused(what, change, needle):
    errors = _errors("protocol", _broken("paper-exp1.toml", change))
    assert any(needle in e for e in errors), (what, errors)


def test_broken_answer_labels_are_refused():
    for label in ["3", " yes", "yes|no", "", "a\tb"]:
        doc = _broken("staircase-detection.toml", _set(["staircase", "yes"], label))
        assert _errors("protocol", doc) != [], repr(label)
    doc = _broken("staircase-detection.toml", _set(["staircase", "yes"], "felt it"))
    assert _errors("protocol", doc) == []


LIBRARY_BREAKS = [
    ("unknown key", _set(["stimulus", 0, "colour"], 1), "Additional properties"),
    ("wrong type", _set(["stimulus", 0, "radius"], "3"), "is not of type 'number'"),
    ("radius out of range", _set(["stimulus", 0, "radius"], 101.0), "is greater than the maximum"),
    ("intensity out of range", _set(["stimulus", 0, "intensity"], -0.5), "is less than the minimum"),
    ("no foci", _set(["stimulus", 0, "foci"], 0), "is less than the minimum"),
    ("centre out of range", _set(["stimulus", 0, "center"], [0, 0, 1e9]), "is greater than the maximum"),
    ("centre of two", _set(["stimulus", 0, "center"], [0, 0]), "is too short"),
    ("bad id", _set(["stimulus", 0, "id"], "a b"), "does not match"),
    ("no id", _drop("stimulus", 0, "id"), "'id' is a required property"),
    ("unknown shape", _set(["stimulus", 0, "path"], {"shape": "star"}), "is not one of"),
    ("am without freq", _set(["stimulus", 0, "am"], {"shape": "sine"}), "'freq' is a required property"),
    ("am too fast", _set(["stimulus", 0, "am"], {"shape": "sine", "freq": 1000}), "greater than the maximum"),
    ("no stimuli", _set(["stimulus"], []), "should be non-empty"),
    ("empty file", lambda doc: doc.clear(), "'stimulus' is a required property"),
]


@pytest.mark.parametrize("what,change,needle", LIBRARY_BREAKS, ids=[b[0] for b in LIBRARY_BREAKS])
def test_a_broken_library_is_refused(what, change, needle):
    errors = _errors("library", _broken("paper-library.toml", change))
    assert any(needle in e for e in errors), (what, errors)
