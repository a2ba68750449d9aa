"""Round 12 of hostile input to the Python package: an argument that must
be text or a path is refused by name when it is anything else, never
turned into text with ``str()`` and so taken as something it never was
(``participant=None`` ran a study for the participant "None" and wrote
its folder; ``Device(None)`` tried to open the serial port ``None``;
``args="--view"`` passed its characters as flags)."""

import pathlib

import pytest

import lmhost

PROTOCOL = "studies/paper-exp1.toml"
LIBRARY = "studies/paper-library.toml"

# -- r12-1. Text and paths are taken as given, never stringified ------------


@pytest.mark.parametrize("port", [None, 3, b"autd3:emulator", True], ids=repr)
def test_a_port_that_is_not_text_is_refused_by_name(port):
    with pytest.raises(ValueError, match=r"^port must be a --port name \(a string\), got \w+$"):
        lmhost.Device(port)


@pytest.mark.parametrize(
    "kw, needle",
    [
        (dict(participant=None), "participant must be a participant's name (a string), got None"),
        (dict(participant=3), "participant must be a participant's name (a string), got int"),
        (dict(participant=True), "participant must be a participant's name (a string), got bool"),
        (dict(port=None), "port must be a --port name (a string), got None"),
        (dict(protocol=3), "protocol must be a path (a str or pathlib.Path), got int"),
        (dict(protocol=PROTOCOL.encode()), "protocol must be a path (a str or pathlib.Path), got bytes"),
        (dict(out=None), "out must be a path (a str or pathlib.Path), got None"),
        (dict(scene=3), "scene must be a path (a str or pathlib.Path), got int"),
        (dict(finger=True), "finger must be None or \"synthetic\" (a string), got bool"),
    ],
    ids=repr,
)
def test_a_study_argument_that_is_not_text_is_refused_before_anything_is_written(tmp_path, root, kw, needle):
    args = dict(
        protocol=root / PROTOCOL, participant="p01", out=tmp_path / "o", port="autd3:emulator",
        answer=lambda q: 3, finger="synthetic", time_scale=0.02,
    )
    args.update(kw)
    with pytest.raises(ValueError) as e:
        next(iter(lmhost.Study(**args)))
    assert str(e.value) == needle
    # Nothing ran: no participant folder (before, "None" and "3" were made).
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_a_study_still_takes_a_pathlib_path(tmp_path, root):
    s = lmhost.Study(
        pathlib.Path(root / PROTOCOL), "p01", pathlib.Path(tmp_path / "o"), "autd3:emulator",
        lambda q: 3, finger="synthetic", time_scale=0.02,
    )
    row = next(iter(s))
    assert row and (tmp_path / "o" / "p01" / "trials.csv").exists()


@pytest.mark.parametrize(
    "kw, needle",
    [
        (dict(library=3), "library must be a path (a str or pathlib.Path), got int"),
        (dict(library=LIBRARY, port=3), "port must be a --port name (a string), got int"),
        (dict(library=LIBRARY, scene=b"scenes/paper.toml"), "scene must be a path (a str or pathlib.Path), got bytes"),
        # A string alone was split into its characters: `-`, `-`, `v`, ...
        (dict(library=LIBRARY, args="--view"), "args must be a list of strings, got str"),
        (dict(library=LIBRARY, args=["--view", 0]), "args[1] must be a string, got int"),
        (dict(socket_path=3), "socket_path must be a path (a str or pathlib.Path), got int"),
        (dict(tcp_port=9, token_file=3), "token_file must be a path (a str or pathlib.Path), got int"),
    ],
    ids=repr,
)
def test_a_session_argument_that_is_not_text_is_refused_before_a_session_starts(kw, needle):
    with pytest.raises(ValueError) as e:
        lmhost.Session(**kw)
    assert str(e.value) == needle


@pytest.mark.parametrize("path", [3, None, b"x.toml"], ids=repr)
def test_an_intrinsics_path_that_is_not_text_is_refused_by_name(root, path):
    scene = lmhost.Scene.load(root / "scenes" / "paper.toml")
    with pytest.raises(ValueError, match=r"^intrinsics must be a path \(a str or pathlib.Path\), got \w+$"):
        lmhost.Tracker(scene, path)


# -- r12-2. An empty path is refused as the CLI refuses an empty path flag ---


def test_a_study_with_an_empty_out_writes_nothing_in_the_working_directory(tmp_path, root, monkeypatch):
    # `lmhost study run --out ""` is refused; Python ran the study and
    # wrote ./p01/trials.csv wherever it was started.
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError) as e:
        s = lmhost.Study(
            root / PROTOCOL, "p01", "", "autd3:emulator", lambda q: 3, finger="synthetic", time_scale=0.02
        )
        next(iter(s))
    assert str(e.value) == "out must be a path, got an empty string"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "call, needle",
    [
        (lambda root: lmhost.Scene.load(""), "path must be a path, got an empty string"),
        # A DeviceError ("cannot write : invalid input parameter") before.
        (lambda root: lmhost.plan().save(""), "path must be a path, got an empty string"),
        # Read as the folder "." before ("cannot read intrinsics .").
        (
            lambda root: lmhost.Tracker(lmhost.Scene.load(root / "scenes" / "paper.toml"), ""),
            "intrinsics must be a path, got an empty string",
        ),
        (lambda root: lmhost.Study("", "p01", "o", "autd3:emulator", lambda q: 3), "protocol must be a path, got an empty string"),
        (lambda root: lmhost.Session(library=""), "library must be a path, got an empty string"),
        # Waited the whole timeout for a session on "" before.
        (lambda root: lmhost.Session(socket_path=""), "socket_path must be a path, got an empty string"),
    ],
    ids=["Scene.load", "Plan.save", "Tracker", "Study.protocol", "Session.library", "Session.socket_path"],
)
def test_an_empty_path_is_refused_by_name(root, call, needle):
    with pytest.raises(ValueError) as e:
        call(root)
    assert str(e.value) == needle


def test_the_extension_refuses_an_empty_path_itself(tmp_path, root):
    # The private constructor as well as the wrapper: the rule is Rust's.
    from lmhost import _lmhost

    with pytest.raises(ValueError, match="^out must be a path, got an empty string$"):
        _lmhost.Study(str(root / PROTOCOL), "p01", "", "autd3:emulator", lambda q: 3)


# -- r12-3. A session's whole number is judged by the session's rule ---------


@pytest.fixture(scope="module")
def session(lmhost_bin, root):
    with lmhost.Session(library=root / LIBRARY, port="autd3:emulator", synthetic=True) as s:
        yield s


@pytest.mark.parametrize(
    "repeat, needle",
    [
        # Named the range of an i64 it was checked against on the way.
        (2**70, "repeat 1.18059e21 is out of range: allowed 1..=10000"),
        (10**400, "repeat 1000000000000000000000000000000000000000… (401 characters) is out of range: allowed 1..=10000"),
        # The session named the range of its u32.
        (-1, "repeat -1 is out of range: allowed 1..=10000"),
        (2**32, "repeat 4294967296 is out of range: allowed 1..=10000"),
        (0, "repeat 0 is out of range: allowed 1..=10000"),
    ],
    ids=lambda v: repr(v)[:20],
)
def test_a_repeat_out_of_range_names_the_sessions_range(session, repeat, needle):
    # present() refuses it before sending, by the session's own rule and
    # in its words (the same Rust check); a line sent says the same.
    sid = session.library()[0]["id"]
    with pytest.raises(ValueError) as e:
        session.present(sid, on_s=0.5, repeat=repeat, gate="untracked")
    assert str(e.value) == needle
    if repeat < 2**64:
        with pytest.raises(ValueError) as e:
            session.command("present", stimulus=sid, on_s=0.5, repeat=repeat, gate="untracked")
        assert str(e.value) == "bad command: " + needle


@pytest.mark.parametrize("repeat", [2.5, True, "3", None.__class__], ids=repr)
def test_a_repeat_that_is_no_integer_is_refused_by_name(session, repeat):
    sid = session.library()[0]["id"]
    with pytest.raises(ValueError, match=r"^repeat must be an integer, got "):
        session.present(sid, on_s=0.5, repeat=repeat)


def test_numpy_numbers_reach_the_session_as_numbers(session):
    np = pytest.importorskip("numpy")
    sid = session.library()[0]["id"]
    # A numpy int was "cannot send Object of type int64" through command().
    r = session.command(
        "present", stimulus=sid, on_s=np.float32(0.5), off_s=0.1, repeat=np.int64(2), gate="untracked"
    )
    assert r["ok"] is True
    session.stop()
    with pytest.raises(ValueError, match=r"^bad command: repeat 2.5 is not a whole number: allowed 1..=10000$"):
        session.command("present", stimulus=sid, on_s=0.5, repeat=2.5)


# -- r12-4. A closed Session says so, as a closed Device does ----------------


def test_a_closed_session_says_it_is_closed(lmhost_bin, root):
    s = lmhost.Session(library=root / LIBRARY, port="autd3:emulator", synthetic=True)
    s.close()
    # "[Errno 9] Bad file descriptor" (a bare OSError) before.
    for call in (s.status, lambda: s.present("lms-5hz-a2"), lambda: list(s.events(timeout=0.1))):
        with pytest.raises(lmhost.DeviceError) as e:
            call()
        assert str(e.value) == "this Session is closed"
    s.close()  # closing twice is quiet


# -- r12-5. A port name longer than any is refused, not echoed whole ---------


def test_a_port_longer_than_any_is_refused_with_its_length():
    # "opening serial port a b a b …" repeated all 40 000 characters.
    with pytest.raises(ValueError) as e:
        lmhost.Device("a b " * 10_000)
    msg = str(e.value)
    assert msg.endswith("40000 bytes is longer than any port name (at most 4095)") and len(msg) < 400, msg


# -- r12-6. An intrinsics dict's key is a field name, never TOML text --------


@pytest.mark.parametrize("key", ["#fx", "fx = 5 #", "fx\n#", '"fx"', 3, "a.b", ""], ids=repr)
def test_an_intrinsics_key_that_is_no_field_name_is_refused(root, key):
    # "#fx" became a TOML comment and was dropped without a word.
    intr = dict(width=64, height=48, fx=50.0, fy=50.0, ppx=32.0, ppy=24.0, depth_scale=0.001)
    intr[key] = 5
    scene = lmhost.Scene.load(root / "scenes" / "paper.toml")
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, intr)
    assert str(e.value) == (
        f"intrinsics dict: key {key!r} is not a field name (width, height, fx, fy, ppx, ppy, depth_scale)"
    )


def test_an_unknown_bare_key_is_refused_by_the_library(root):
    intr = dict(width=64, height=48, fx=50.0, fy=50.0, ppx=32.0, ppy=24.0, depth_scale=0.001, fxx=1)
    scene = lmhost.Scene.load(root / "scenes" / "paper.toml")
    with pytest.raises(ValueError, match="unknown field `fxx`, expected one of `width`"):
        lmhost.Tracker(scene, intr)
