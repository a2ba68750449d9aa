"""Round 15a of hostile input to the Python package.

- r15a-9: ``Session.command(..., field=None)`` leaves the field out of the
  line, as a None of :meth:`Session.present` and :func:`lmhost.plan` is
  their default; its documentation did not say so, and a None could read
  as a value sent. Now said, and the same for every field: a None is
  absent, never sent as JSON ``null`` and never refused.
- r15a-7 (a control line's ``off_s``): the refusal states the real range,
  0 (no pause) in it, through ``present()`` as through the CLI.
"""

import pytest

import lmhost

LIBRARY = "studies/paper-library.toml"


@pytest.fixture(scope="module")
def session(lmhost_bin, root):
    with lmhost.Session(library=root / LIBRARY, port="autd3:emulator", synthetic=True) as s:
        yield s


def test_commands_none_is_documented_as_absent():
    doc = lmhost.Session.command.__doc__
    assert "A field given as None is absent" in doc, doc
    assert "as a None of :meth:`present`" in doc, doc


def test_a_none_field_is_absent_as_presents_none(session):
    # `on_s=None` plays until stopped, as `present(on_s=None)` does; a
    # None `off_s` beside no repeat is absent, not an `off_s` to refuse.
    r = session.command("present", stimulus="lms-5hz-a2", gate="untracked", on_s=None, off_s=None)
    assert r["ok"] is True
    assert session.status()["state"] != "idle"
    session.stop()
    r = session.present("lms-5hz-a2", gate="untracked", on_s=None, off_s=None)
    assert r["ok"] is True
    session.stop()
    # A None stimulus is absent too: the session names what is missing.
    with pytest.raises(ValueError, match="stimulus"):
        session.command("present", stimulus=None)


@pytest.mark.parametrize(
    "off_s, want",
    [
        (-1, "off_s -1 s is out of range: give 0 (no pause) or a number from 1e-9 to 3600 s"),
        (
            1e-300,
            "off_s 1e-300 s rounds to no time (a duration holds whole nanoseconds): "
            "give 0 (no pause) or at least 1e-9 s",
        ),
    ],
)
def test_off_s_refusal_states_zero_is_allowed(session, off_s, want):
    with pytest.raises(ValueError) as e:
        session.present("lms-5hz-a2", gate="untracked", on_s=0.05, off_s=off_s, repeat=2)
    assert str(e.value) == want
    r = session.present("lms-5hz-a2", gate="untracked", on_s=0.05, off_s=0, repeat=2)
    assert r["ok"] is True
    session.stop()
