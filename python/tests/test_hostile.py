"""Hostile but fair input to the Python package, one class per section
(issue 30 item 13, issue 31 item 4): a dead owner's session, a Device from
another thread, integers out of range, non-finite floats, the defaults."""

import inspect
import json
import math
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import lmhost
from conftest import cli

LIBRARY = "studies/paper-library.toml"


def _poll(what, cond, bound_s=20.0):
    """Waits for `cond()` up to `bound_s` (the bound, not a sleep, is what
    the test asserts)."""
    deadline = time.monotonic() + bound_s
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"{what}: not within {bound_s} s")
        time.sleep(0.05)


# -- 1. A session's child ends with its owner, however the owner ends --------


@pytest.fixture
def sim(lmhost_bin):
    p = subprocess.Popen([str(lmhost_bin), "sim"], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True)
    try:
        port = p.stdout.readline().strip()
        assert port.startswith("/dev/"), port
        yield port
    finally:
        p.kill()
        p.wait()


def _gone(pid):
    """Exited: no such process, or a zombie nobody has reaped yet."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def _device_state(lmhost_bin, port):
    r = cli(lmhost_bin, "status", "--port", port, "--json", check=False)
    return json.loads(r.stdout)["state"] if r.returncode == 0 else None


OWNER = textwrap.dedent("""
    import os, signal, sys, threading, time
    import lmhost
    # As an interactive script has it, whatever this test was started
    # under (a shell's background job inherits SIGINT ignored).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    lib, port, how = sys.argv[1:4]
    box = {}
    def start():
        box["s"] = lmhost.Session(library=lib, port=port)
        box["s"].present("lms-5hz-a3", gate="untracked")
        box["s"].wait_for("onset")
    if how == "thread":
        # The thread that started the child ends first: the child must
        # stay (a parent-death signal tied to that thread would end it).
        t = threading.Thread(target=start); t.start(); t.join()
    else:
        start()
    print(box["s"]._proc.pid, flush=True)
    if how == "exit":
        os._exit(3)  # no close, no finalisers
    time.sleep(600)
""")

# How the owner goes: the signal sent to it, or what it does itself.
ENDINGS = [
    ("SIGKILL", signal.SIGKILL),
    ("SIGTERM", signal.SIGTERM),
    ("SIGINT", signal.SIGINT),
    ("SIGSEGV", signal.SIGSEGV),
    ("thread-then-SIGKILL", signal.SIGKILL),
    ("os._exit", None),
]


@pytest.mark.parametrize("name,sig", ENDINGS, ids=[e[0] for e in ENDINGS])
def test_the_session_child_ends_with_its_owner_and_leaves_the_array_silent(
        lmhost_bin, root, sim, name, sig, tmp_path):
    how = "thread" if name.startswith("thread") else ("exit" if sig is None else "sleep")
    # An owner that dies runs no finalisers: the folder its Session made
    # for the control socket stays, here in the test's own folder.
    env = dict(os.environ, LMHOST_BIN=str(lmhost_bin), TMPDIR=str(tmp_path))
    orphans = []
    owner = subprocess.Popen(
        [sys.executable, "-c", OWNER, str(root / LIBRARY), sim, how],
        stdout=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True, env=env)
    try:
        line = owner.stdout.readline()
        assert line.strip().isdigit(), f"the owner did not start its session: {line!r}"
        child = int(line)
        orphans.append(child)
        if sig is not None:
            # While the owner lives, its session lives and plays.
            time.sleep(0.3)
            assert not _gone(child), "the session ended under a living owner"
            os.kill(owner.pid, sig)
        owner.wait(timeout=20)
        _poll("the session child exits", lambda: _gone(child))
        _poll("the device reports stopped",
              lambda: _device_state(lmhost_bin, sim) in ("Stopped", "Idle"))
    finally:
        if owner.poll() is None:
            owner.kill()
            owner.wait()
        for pid in orphans:  # a failed case leaves no session behind
            if not _gone(pid):
                os.kill(pid, signal.SIGTERM)


def test_exit_with_stdin_refuses_to_share_stdin(lmhost_bin, root):
    for extra in (["--control", "-"], ["--stream", "-"]):
        r = cli(lmhost_bin, "session", "--library", root / LIBRARY, "--port", "autd3:emulator",
                "--exit-with-stdin", *extra, check=False)
        assert r.returncode == 2, r.stderr
        assert r.stderr.count("\n") == 1 and "--exit-with-stdin" in r.stderr


# -- 2. A Device from any thread ---------------------------------------------


def _in_thread(fn):
    out = {}

    def body():
        try:
            out["value"] = fn()
        except BaseException as e:  # noqa: BLE001 - carried to the test's thread
            out["error"] = e

    t = threading.Thread(target=body)
    t.start()
    t.join(60)
    assert not t.is_alive(), "the call did not return"
    if "error" in out:
        raise out["error"]
    return out.get("value")


THREAD_CALLS = {
    "info": lambda d: d.info()["backend"] == "autd3",
    "status": lambda d: "state" in d.status(),
    "upload": lambda d: d.upload(lmhost.plan(target="autd3"), untracked=True)["playing"],
    "play-stop": lambda d: (d.upload(lmhost.plan(target="autd3"), play=False),
                            d.play(0, untracked=True), d.stop()) is not None,
    "centroid": lambda d: d.centroid(0.0, 0.0, 200.0) in ("applied", "out_of_range"),
    "tick": lambda d: d.tick() is None,
    "port": lambda d: d.port == "autd3:emulator",
    "close": lambda d: d.close() is None,
}


@pytest.mark.parametrize("call", list(THREAD_CALLS))
def test_a_device_opened_here_works_from_another_thread(call):
    dev = lmhost.Device("autd3:emulator")
    try:
        assert _in_thread(lambda: THREAD_CALLS[call](dev)) is True
    finally:
        dev.close()


def test_a_device_opened_in_a_thread_works_here_and_closes_twice():
    dev = _in_thread(lambda: lmhost.Device("autd3:emulator"))
    assert dev.info()["backend"] == "autd3"
    dev.upload(lmhost.plan(target="autd3"), untracked=True)
    dev.close()
    dev.close()
    with pytest.raises(lmhost.DeviceError, match="closed"):
        dev.status()


def test_concurrent_calls_from_many_threads_run_one_at_a_time():
    with lmhost.Device("autd3:emulator") as dev:
        dev.upload(lmhost.plan(target="autd3"), untracked=True)
        errors = []

        def hammer():
            try:
                for _ in range(25):
                    dev.status()
                    dev.centroid(0.0, 0.0, 200.0)
                    dev.tick()
            except BaseException as e:  # noqa: BLE001
                errors.append(e)

        ts = [threading.Thread(target=hammer) for _ in range(4)]
        for t in ts:
            t.start()
        for t in ts:
            t.join(120)
        assert not errors, errors
        assert dev.status()["state"] in ("Playing", "playing")


def test_a_closed_device_from_another_thread_is_a_device_error():
    dev = lmhost.Device("autd3:emulator")
    dev.close()
    with pytest.raises(lmhost.DeviceError):
        _in_thread(dev.info)


# -- 3. Integers: ValueError naming the parameter, never OverflowError ------

TRACKER_INTR = dict(width=64, height=48, fx=40.0, fy=40.0, ppx=32.0, ppy=24.0, depth_scale=0.001)

BAD_INTS = [
    ("foci", lambda v: lmhost.plan(foci=v)),
    ("steps", lambda v: lmhost.plan(steps=v)),
]
INT_VALUES = [2**64, 2**63, -(2**63) - 1, 10**400, -1, 3.7, 4.0, math.nan, math.inf, True, "4",
              np.float64(4.0), 2**31]


@pytest.mark.parametrize("v", INT_VALUES, ids=repr)
@pytest.mark.parametrize("name,call", BAD_INTS, ids=[b[0] for b in BAD_INTS])
def test_a_bad_plan_integer_is_a_value_error_naming_it(name, call, v):
    with pytest.raises(ValueError, match=name) as e:
        call(v)
    assert not isinstance(e.value, OverflowError)
    assert len(str(e.value)) < 200, "a huge value is echoed whole"


def test_steps_3_7_is_refused_not_truncated():
    with pytest.raises(ValueError, match="steps must be an integer, got 3.7"):
        lmhost.plan(steps=3.7)


@pytest.mark.parametrize("name", ["enter_frames", "leave_frames"])
@pytest.mark.parametrize("v", [0, -1, 91, 2**32, 2**70, 1.5, 2.0, [2], "2"], ids=repr)
def test_bad_tracker_frames_are_value_errors(root, name, v):
    with pytest.raises(ValueError, match=name):
        lmhost.Tracker(lmhost.Scene.load(root / "scenes/paper.toml"), TRACKER_INTR, **{name: v})


@pytest.fixture(scope="module")
def emulator():
    with lmhost.Device("autd3:emulator") as dev:
        yield dev


@pytest.mark.parametrize("v", [256, -1, 2**64, 10**100, 1.0, 0.5, True, "0", math.nan],
                         ids=repr)
def test_a_bad_slot_is_a_value_error_and_nothing_plays(emulator, v):
    with pytest.raises(ValueError, match="slot"):
        emulator.play(v)
    with pytest.raises(ValueError, match="slot"):
        emulator.upload(lmhost.plan(target="autd3"), slot=v)
    assert emulator.status()["state"] not in ("Playing", "playing")


@pytest.mark.parametrize("kw,name", [
    (dict(tcp_port=70000), "tcp_port"),
    (dict(tcp_port=0), "tcp_port"),
    (dict(tcp_port=8080.5), "tcp_port"),
    (dict(tcp_port=-1), "tcp_port"),
    (dict(tcp_port=2**80), "tcp_port"),
    (dict(timeout=math.nan), "timeout"),
    (dict(timeout=-1), "timeout"),
    (dict(timeout=math.inf), "timeout"),
])
def test_bad_session_arguments_are_value_errors_before_connecting(tmp_path, kw, name):
    with pytest.raises(ValueError, match=name):
        lmhost.Session(socket_path=tmp_path / "none.sock", **kw)


def test_numpy_integers_are_integers():
    p = lmhost.plan(foci=np.int64(4), steps=np.uint16(40))
    assert (p.steps, p.foci_mm.shape[1]) == (40, 4)


# -- 4. Non-finite floats never reach the library or the wire ---------------

NONFINITE = [math.nan, math.inf, -math.inf, 10**400, np.float64("nan")]


@pytest.mark.parametrize("v", NONFINITE, ids=repr)
@pytest.mark.parametrize("name", ["radius", "spacing", "freq", "step", "intensity"])
def test_a_non_finite_plan_number_names_its_field(name, v):
    with pytest.raises(ValueError, match=name):
        lmhost.plan(**{name: v})


@pytest.mark.parametrize("i", [0, 1, 2])
@pytest.mark.parametrize("v", NONFINITE[:3], ids=repr)
def test_a_non_finite_center_names_its_coordinate(i, v):
    c = [0.0, 0.0, 200.0]
    c[i] = v
    with pytest.raises(ValueError, match=rf"center\[{i}\]"):
        lmhost.plan(center=c)


@pytest.fixture(scope="module")
def a_plan():
    return lmhost.plan()


SIM_BAD = [
    ("plane_size", math.nan), ("plane_size", (5.0, math.inf)), ("plane_size", (math.nan, 5)),
    ("plane_step", math.inf), ("plane_step", math.nan), ("plane_center", (0, 0, math.nan)),
    ("plane_axes", (1, 0, 0, 0, 1, math.inf)), ("alpha", math.nan), ("density", math.inf),
    ("disk", -math.inf), ("calibration", math.nan), ("calibration", math.inf),
    ("plane_size", (1.0, 2.0, 3.0)), ("plane_axes", (1, 0, 0)),
]


@pytest.mark.parametrize("name,v", SIM_BAD, ids=lambda x: repr(x))
def test_a_non_finite_simulate_number_names_its_field(a_plan, name, v):
    with pytest.raises(ValueError, match=name):
        lmhost.simulate(a_plan, **{name: v})


@pytest.mark.parametrize("axis", ["x", "y", "z"])
@pytest.mark.parametrize("v", NONFINITE, ids=repr)
def test_a_non_finite_centroid_names_its_axis(emulator, axis, v):
    kw = dict(x=0.0, y=0.0, z=200.0)
    kw[axis] = v
    with pytest.raises(ValueError, match=rf"\b{axis}\b"):
        emulator.centroid(**kw)


@pytest.mark.parametrize("v", NONFINITE, ids=repr)
def test_a_non_finite_frame_time_is_refused(root, v):
    tr = lmhost.Tracker(lmhost.Scene.load(root / "scenes/paper.toml"), TRACKER_INTR)
    with pytest.raises(ValueError, match=r"\bt\b"):
        tr.process(np.zeros((48, 64), np.uint16), t=v)


class FakeSession:
    """A control socket that says ok to everything and keeps every line,
    to see what the client would have sent."""

    def __init__(self, path):
        self.lines = []
        self.srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.srv.bind(str(path))
        self.srv.listen(1)
        self.t = threading.Thread(target=self._serve, daemon=True)
        self.t.start()

    def _serve(self):
        c, _ = self.srv.accept()
        with c, c.makefile("rwb") as f:
            for line in f:
                self.lines.append(json.loads(line))
                f.write(b'{"ok":true,"slot":0,"status":{},"stimuli":[]}\n')
                f.flush()


@pytest.mark.parametrize("kw", [
    dict(on_s=math.nan), dict(on_s=math.inf), dict(off_s=-math.inf), dict(off_s=math.nan),
    dict(repeat=2.5), dict(repeat=10**30), dict(repeat=True), dict(on_s="1"),
], ids=repr)
def test_a_bad_present_never_reaches_the_session(tmp_path, kw):
    fake = FakeSession(tmp_path / "c.sock")
    with lmhost.Session(socket_path=tmp_path / "c.sock") as s:
        with pytest.raises(ValueError, match=next(iter(kw))):
            s.present("lms-5hz-a3", gate="untracked", **kw)
        with pytest.raises(ValueError, match="x_s"):
            s.command("present", stimulus="lms-5hz-a3", x_s=math.nan)
        s.present("lms-5hz-a3", on_s=1.5, repeat=2)  # a good one still goes
    sent = [m for m in fake.lines if m["cmd"] == "present"]
    assert sent == [{"cmd": "present", "stimulus": "lms-5hz-a3", "on_s": 1.5, "repeat": 2}]


# -- 5. Python's defaults are the library's ---------------------------------


def test_defaults_come_from_the_library(lmhost_bin):
    d = lmhost.DEFAULTS
    j = json.loads(cli(lmhost_bin, "plan", "--json").stdout)
    assert d["foci"] == j["foci_per_step"]
    assert d["freq"] == j["timing"]["requested_freq_hz"]
    assert d["step"] == j["timing"]["requested_step_mm"]
    assert d["target"] == j["target"]
    assert j["header"]["intensity"] == round(255 * d["intensity"])
    # The whole default plan (radius and spacing included) is the CLI's.
    assert lmhost.plan().summary() == j
    assert lmhost.DEFAULTS is not lmhost._lmhost.DEFAULTS  # a copy: editing it changes nothing


@pytest.mark.parametrize("fn,params", [
    # plan's numbers default to None, the library's (what the test above
    # compares with the CLI), so one that cannot apply is refused.
    (lmhost.plan, ["target"]),
    (lmhost.simulate, ["plane_size", "plane_step", "alpha", "density", "disk"]),
    (lmhost.Tracker.__init__, ["enter_frames", "leave_frames"]),
])
def test_every_keyword_default_is_the_librarys(fn, params):
    sig = inspect.signature(fn)
    for name in params:
        assert sig.parameters[name].default == lmhost._lmhost.DEFAULTS[name], name


def test_the_extension_stubs_declare_everything_it_exports(root):
    import ast

    tree = ast.parse((root / "python/lmhost/_lmhost.pyi").read_text())
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            declared.add(node.target.id)
    exported = {n for n in dir(lmhost._lmhost) if not n.startswith("__")}
    assert exported <= declared, exported - declared
    assert declared <= exported, declared - exported
    # The package's own annotations are its stubs (no second copy).
    assert not (root / "python/lmhost/__init__.pyi").exists()
    sig = inspect.signature(lmhost.Session.__init__)
    for arg in ["tcp_port", "token", "token_file"]:
        assert "Optional" in str(sig.parameters[arg].annotation), arg
