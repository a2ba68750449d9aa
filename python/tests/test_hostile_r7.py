"""Round 7b of hostile input to the Python package: every public function
and class argument given None, NaN, inf, negative, huge, wrong types and
numpy arrays. Each class below is one the sweep found: a value taken for
what it is not, a wait that overflowed or never waited, a message longer
or taller than one line."""

import math

import numpy as np
import pytest

import lmhost

LIBRARY = "studies/paper-library.toml"

# -- 1. A yes-or-no argument is a bool, never the truth of another value ----

NOT_BOOLS = [None, "no", "", 0, 1, math.nan, [1], np.array([True, False])]


@pytest.fixture
def emulator():
    with lmhost.Device("autd3:emulator") as dev:
        yield dev


@pytest.mark.parametrize("v", NOT_BOOLS, ids=repr)
def test_a_centroid_is_present_or_absent_by_a_bool(emulator, v):
    # present=None was False: an absent finger sent for a value not given.
    with pytest.raises(ValueError, match="present must be True or False"):
        emulator.centroid(0.0, 0.0, 200.0, present=v)


@pytest.mark.parametrize("v", NOT_BOOLS, ids=repr)
def test_play_and_untracked_are_bools(emulator, v):
    p = lmhost.plan(steps=8, target="autd3")
    with pytest.raises(ValueError, match="play must be True or False"):
        emulator.upload(p, play=v)
    with pytest.raises(ValueError, match="untracked must be True or False"):
        emulator.upload(p, untracked=v)
    with pytest.raises(ValueError, match="untracked must be True or False"):
        emulator.play(0, untracked=v)
    assert emulator.status()["state"] not in ("Playing", "playing")


def test_numpy_bools_are_bools(emulator):
    assert emulator.centroid(0.0, 0.0, 200.0, present=np.bool_(True)) in (
        "applied",
        "out_of_range",
    )


@pytest.mark.parametrize("v", ["yes", None, 2], ids=repr)
def test_reference_and_synthetic_are_bools(tmp_path, v):
    with pytest.raises(ValueError, match="reference must be True or False"):
        lmhost.simulate(lmhost.plan(steps=8), plane_size=2.0, plane_step=1.0, reference=v)
    with pytest.raises(ValueError, match="synthetic must be True or False"):
        lmhost.Session(library=LIBRARY, port="autd3:emulator", synthetic=v)


# -- 2. A timeout is a finite number of seconds, checked once ---------------

BAD_TIMEOUTS = [0, -1, 1e300, 10**30, 2**64, math.inf, True, "1"]


@pytest.mark.parametrize("v", BAD_TIMEOUTS, ids=repr)
def test_a_session_timeout_is_checked_before_anything_starts(tmp_path, v):
    # 1e300 was an OverflowError from the socket, after the child started.
    with pytest.raises(ValueError, match="timeout"):
        lmhost.Session(socket_path=tmp_path / "none.sock", timeout=v)


@pytest.fixture(scope="module")
def session():
    with lmhost.Session(library=LIBRARY, port="autd3:emulator") as s:
        yield s


@pytest.mark.parametrize("v", BAD_TIMEOUTS, ids=repr)
def test_event_waits_take_the_same_timeouts(session, v):
    # timeout=0 was a BlockingIOError, a huge one an OverflowError, True 1 s.
    with pytest.raises(ValueError, match="timeout"):
        list(session.events(timeout=v))
    with pytest.raises(ValueError, match="timeout"):
        session.wait_for("onset", timeout=v)
    assert session.status()["state"] in ("idle", "stopped")


@pytest.mark.parametrize("kw", [dict(token="0" * 32), dict(token_file="/tmp/x.token")])
def test_a_token_without_tcp_is_refused_not_ignored(tmp_path, kw):
    with pytest.raises(ValueError, match="tcp_port"):
        lmhost.Session(socket_path=tmp_path / "none.sock", **kw)


# -- 3. A message is one short line ------------------------------------------


def _one_short_line(e, longest=1500):
    msg = str(e.value)
    assert "\n" not in msg and len(msg) <= longest, f"{len(msg)} characters: {msg[:200]}"
    return msg


def test_a_tiny_number_is_not_three_hundred_digits():
    with pytest.raises(ValueError) as e:
        lmhost.plan(step=1e-300)
    assert "1e-300" in _one_short_line(e, 300)


@pytest.mark.parametrize("call", [
    lambda v: lmhost.plan(target=v),
    lambda v: lmhost.Scene.load(v),
    lambda v: lmhost.Device(v),
], ids=["plan-target", "scene", "device-port"])
def test_a_long_value_is_cut_as_the_cli_cuts_it(call):
    with pytest.raises((ValueError, lmhost.DeviceError)) as e:
        call("q" * 100_000)
    assert "characters" in _one_short_line(e)


@pytest.mark.parametrize("call", [
    lambda a: lmhost.plan(radius=a),
    lambda a: lmhost.plan(center=a),
    lambda a: lmhost.plan(target=a),
], ids=["radius", "center", "target"])
def test_an_array_named_in_a_message_takes_one_line(call):
    with pytest.raises(ValueError) as e:
        call(np.zeros((3, 3)))
    _one_short_line(e, 200)


def test_a_command_name_is_a_string(session):
    with pytest.raises(ValueError, match="cmd must be") as e:
        session.command(np.zeros((2, 2)))
    _one_short_line(e, 200)
