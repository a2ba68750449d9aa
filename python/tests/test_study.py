"""`lmhost.Study`: a protocol run in process with answers from a callable,
rows yielded as they are written (the same files as `lmhost study run`)."""

import csv

import pytest

import lmhost

@pytest.fixture
def protocol(root):
    """Experiment 1 (30 trials; vibration, movement and three shape items
    after each), played with a synthetic finger."""
    return root / "studies" / "paper-exp1.toml"


def run(protocol, participant, out, answer, **kw):
    kw.setdefault("time_scale", 0.02)
    return lmhost.Study(
        protocol, participant, out, "autd3:emulator", answer, finger="synthetic", **kw
    )


def test_rows_come_as_written_and_answers_from_the_callback(tmp_path, protocol):
    asked = []

    def answer(q):
        asked.append(q)
        return "na" if len(asked) % 11 == 0 else len(asked) % 7 + 1

    out = tmp_path / "out"
    study = run(protocol, "p01", out, answer, seed=7)
    seen = []
    for row in study:
        # The row is on disk before it is yielded.
        with open(out / "p01" / "trials.csv", newline="") as f:
            on_disk = list(csv.DictReader(f))
        assert on_disk[-1] == row
        seen.append(row)
    assert len(seen) == 30
    assert [q["column"] for q in asked[:2]] == ["vibration", "movement"]
    assert sorted(q["column"] for q in asked[2:5]) == ["shape_concave", "shape_convex", "shape_flat"]
    assert len(asked) == 150
    assert asked[0]["kind"] == "likert" and asked[0]["accepts"] == {"points": 7}
    assert asked[0]["not_perceived"] == "could not perceive the stimulus"
    # The answers land in the rows in the order asked, `na` included.
    for k, row in enumerate(seen):
        n = 5 * k + 1
        want = "na" if n % 11 == 0 else str(n % 7 + 1)
        assert row["vibration"] == want, (k, row)
    assert len({r["stimulus"] for r in seen}) == 15
    assert study.report["ran"] == 30 and study.report["seed"] == 7


def test_a_callback_that_raises_ends_the_run_resumable(tmp_path, protocol):
    n = []

    class Quit(Exception):
        pass

    def answer(q):
        n.append(q)
        if len(n) == 6:  # the second trial's first question
            raise Quit("the participant left")
        return 1

    out = tmp_path / "out"
    rows = []
    with pytest.raises(Quit):
        for row in run(protocol, "p02", out, answer, seed=3):
            rows.append(row)
    assert len(rows) == 1
    # The rest, resumed: the first trial is not asked again.
    again = run(protocol, "p02", out, lambda q: 2, resume=True)
    rest = again.run()
    assert len(rest) == 29 and again.report["first"] == 2
    with open(out / "p02" / "trials.csv", newline="") as f:
        assert [r["vibration"] for r in csv.DictReader(f)] == ["1"] + ["2"] * 29


def test_a_bad_answer_or_argument_is_one_value_error(tmp_path, protocol):
    with pytest.raises(ValueError, match="answer callback's answer to `vibration`"):
        run(protocol, "p03", tmp_path / "o", lambda q: "9").run()
    with pytest.raises(ValueError, match="answer must be callable"):
        lmhost.Study(protocol, "p04", tmp_path / "o", "autd3:emulator", "3")
    with pytest.raises(ValueError, match="finger"):
        lmhost.Study(protocol, "p05", tmp_path / "o", "autd3:emulator", print, finger="camera")
    with pytest.raises(ValueError, match="time_scale"):
        lmhost.Study(protocol, "p06", tmp_path / "o", "autd3:emulator", print, time_scale=float("nan"))
    with pytest.raises(ValueError, match="participant"):
        run(protocol, "../x", tmp_path / "o", print).run()
    # Experiment 1 waits for the finger: without one, refused before it starts.
    with pytest.raises(ValueError, match="waits for the finger"):
        lmhost.Study(protocol, "p07", tmp_path / "o", "autd3:emulator", print).run()
