"""`lmhost.Study`: a protocol run in process with answers from a callable,
rows yielded as they are written (the same files as `lmhost study run`)."""

import csv

import pytest

import lmhost

PROTOCOL = """name = "two"
library = "{library}"
sets = 2
stimulus = "{{type}}-a3"

[timeline]
on_s = 0.3
iti_s = 0.1
gate = "untracked"

[[factor]]
name = "type"
levels = ["lms-5hz", "lms-25hz"]

[[question]]
id = "vibration"
kind = "likert"
points = 7
low = "not at all"
high = "very"
text = "How intense?"

[[question]]
id = "where"
kind = "choice"
options = ["left", "right"]
text = "Where?"
"""


@pytest.fixture
def protocol(tmp_path, root):
    p = tmp_path / "two.toml"
    p.write_text(PROTOCOL.format(library=(root / "studies" / "paper-library.toml").as_posix()))
    return p


def test_rows_come_as_written_and_answers_from_the_callback(tmp_path, protocol):
    asked = []

    def answer(q):
        asked.append(q)
        if q["kind"] == "likert":
            return len(asked) % 7 + 1
        return q["accepts"]["labels"][1]

    out = tmp_path / "out"
    study = lmhost.Study(protocol, "p01", out, "autd3:emulator", answer, seed=7, time_scale=0.5)
    seen = []
    for row in study:
        # The row is on disk before it is yielded.
        with open(out / "p01" / "trials.csv", newline="") as f:
            on_disk = list(csv.DictReader(f))
        assert on_disk[-1] == row
        seen.append(row)
    assert len(seen) == 4
    assert [q["column"] for q in asked] == ["vibration", "where"] * 4
    assert asked[0]["accepts"] == {"points": 7}
    assert asked[1]["kind"] == "choice" and asked[1]["accepts"]["labels"] == ["left", "right"]
    assert [r["vibration"] for r in seen] == [str(i % 7 + 1) for i in (1, 3, 5, 7)]
    assert {r["where"] for r in seen} == {"right"}
    assert sorted(r["stimulus"] for r in seen) == ["lms-25hz-a3"] * 2 + ["lms-5hz-a3"] * 2
    assert study.report["ran"] == 4 and study.report["seed"] == 7


def test_a_callback_that_raises_ends_the_run_resumable(tmp_path, protocol):
    n = []

    class Quit(Exception):
        pass

    def answer(q):
        n.append(q)
        if len(n) == 3:  # the second trial's first question
            raise Quit("the participant left")
        return 1 if q["kind"] == "likert" else "left"

    out = tmp_path / "out"
    rows = []
    with pytest.raises(Quit):
        for row in lmhost.Study(protocol, "p02", out, "autd3:emulator", answer, seed=3):
            rows.append(row)
    assert len(rows) == 1
    # The rest, resumed: the first trial is not asked again.
    n.clear()
    again = lmhost.Study(
        protocol, "p02", out, "autd3:emulator", lambda q: 2 if q["kind"] == "likert" else 1, resume=True
    )
    rest = again.run()
    assert len(rest) == 3 and again.report["first"] == 2
    with open(out / "p02" / "trials.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == 4


def test_a_bad_answer_or_argument_is_one_value_error(tmp_path, protocol):
    with pytest.raises(ValueError, match="answer callback's answer to `vibration`"):
        lmhost.Study(protocol, "p03", tmp_path / "o", "autd3:emulator", lambda q: "9").run()
    with pytest.raises(ValueError, match="answer must be callable"):
        lmhost.Study(protocol, "p04", tmp_path / "o", "autd3:emulator", "3")
    with pytest.raises(ValueError, match="finger"):
        lmhost.Study(protocol, "p05", tmp_path / "o", "autd3:emulator", print, finger="camera")
    with pytest.raises(ValueError, match="time_scale"):
        lmhost.Study(protocol, "p06", tmp_path / "o", "autd3:emulator", print, time_scale=float("nan"))
    with pytest.raises(ValueError, match="participant"):
        lmhost.Study(protocol, "../x", tmp_path / "o", "autd3:emulator", print).run()
