"""Round 8 of hostile input to the Python package: an argument that cannot
apply is refused, as the flag it stands for is, never passed on as its
default and so silently taken (the keyword defaults were always passed,
so the library could not tell a value given from one left alone)."""

import socket

import pytest

import lmhost

LIBRARY = "studies/paper-library.toml"

# -- r8-1. A plan argument left alone is not given --------------------------


@pytest.mark.parametrize("kw", [dict(spacing=3.0), dict(foci=1, spacing=3.0)], ids=repr)
def test_a_spacing_with_one_focus_is_refused_as_the_flag_is(kw):
    # `lmhost plan --spacing 3` says so since round 6; Python planned LM-S.
    with pytest.raises(ValueError, match="--spacing applies to LM-M only: give --foci 2 or more"):
        lmhost.plan(**kw)


def test_a_step_width_beside_a_step_count_is_refused():
    # The count won and the width was dropped without a word.
    with pytest.raises(ValueError, match="give --step or --steps, not both"):
        lmhost.plan(step=0.5, steps=10)


def test_what_is_left_alone_is_the_librarys_default():
    # None is not given: the plan is the CLI's without flags.
    assert lmhost.plan().summary() == lmhost.plan(radius=None, foci=None, step=None).summary()
    assert lmhost.plan(foci=2, spacing=3.0).summary()["foci_per_step"] == 2
    # A wrong type is still named, None or not.
    with pytest.raises(ValueError, match="spacing"):
        lmhost.plan(foci=2, spacing="3")


def test_untracked_without_a_play_is_refused():
    with lmhost.Device("autd3:emulator") as dev:
        with pytest.raises(ValueError, match="untracked=True applies to a play: not with play=False"):
            dev.upload(lmhost.plan(steps=8, target="autd3"), play=False, untracked=True)
        assert dev.status()["state"] not in ("Playing", "playing")


@pytest.mark.parametrize(
    "kw, needle",
    [
        (dict(port="autd3:emulator"), "port= apply to a session started here: give library= too"),
        (dict(scene="scenes/paper.toml"), "scene= apply to a session started here"),
        (dict(synthetic=True), "synthetic= apply to a session started here"),
        (dict(args=["--view", "0"]), "args= apply to a session started here"),
        (dict(library=LIBRARY), "give library= or socket_path=, not both"),
    ],
    ids=repr,
)
def test_a_session_joined_takes_no_argument_that_starts_one(tmp_path, kw, needle):
    # Each was dropped unseen when joining a running session by its socket.
    path = tmp_path / "c.sock"
    srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    srv.bind(str(path))
    srv.listen(1)
    try:
        with pytest.raises(ValueError, match=needle):
            lmhost.Session(socket_path=path, **kw)
    finally:
        srv.close()


def test_an_index_that_orders_nothing_is_refused(tmp_path, root):
    # paper-exp1 orders at random by the seed: --index changed no trial
    # and was recorded as if it had chosen the order.
    protocol = root / "studies" / "paper-exp1.toml"
    s = lmhost.Study(
        protocol, "p01", tmp_path / "o", "autd3:emulator", lambda q: 3,
        finger="synthetic", index=2, time_scale=0.02,
    )
    with pytest.raises(ValueError, match="picks a row of a latin-square order, and this protocol has none"):
        s.run()
    assert not (tmp_path / "o" / "p01" / "trials.csv").exists()
