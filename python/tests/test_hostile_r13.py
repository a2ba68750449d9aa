"""Round 13 of hostile input to the Python package.

- r13-4: a number whose derived quantity overflows is refused by its own
  value and range: ``plan(freq=1e-320)`` said "period inf s", ``plan(step=
  1e-320)`` "gives inf steps", ``simulate(plane_step=1e-320)`` "inf × inf =
  inf points", ``plan(radius=1e-300)`` named a circumference of "0.000 mm",
  and ``simulate(density=1e-320)`` returned a force of inf N.
- r13-8: an intensity above 0 that rounds to level 0 of 255 is refused,
  not planned as silence (``plan(intensity=0.001)``).
- r13-11 (Python's own): every argument of the package's own classes (a
  ``Scene``, a ``Plan``), a path or a yes-or-no given as another kind of
  value is a ``ValueError`` saying what the argument must be; pyo3's conversion
  raised ``TypeError`` "'bytes' object cannot be converted to 'PyString'"
  or "... to 'PyBool'", naming a Rust type, not what to give.
- r13-13 (Python's own): a ``Session`` argument that goes into a control
  line is checked by kind and length in its own words before the line is
  built; ``present(stimulus="x" * 5000)`` said "bad command: longer than
  4096 bytes", naming the line's limit, not the argument, and a token
  file read was unbounded.
"""

import math

import pytest

import lmhost

# -- r13-4. A derived quantity never overflows into the message -------------

FREQ_RANGE = "allowed 0.000232831..=1000 Hz"


@pytest.mark.parametrize("freq", [1e-320, 5e-324, 1e-300, 1e-10, 0.0002328], ids=repr)
def test_a_frequency_below_the_wires_period_is_refused_by_its_own_value(freq):
    with pytest.raises(ValueError) as e:
        lmhost.plan(freq=freq)
    msg = str(e.value)
    assert msg.startswith("frequency ") and msg.endswith(f"Hz is out of range: {FREQ_RANGE}"), msg
    assert "inf" not in msg and "period" not in msg, msg


def test_the_lowest_frequency_still_plans():
    p = lmhost.plan(freq=0.00024, steps=1)
    assert p.freq_hz == pytest.approx(0.00024, rel=1e-3)


@pytest.mark.parametrize("step", [1e-320, 1e-300, 1e-6], ids=repr)
def test_a_step_too_fine_is_refused_by_its_own_range(step):
    with pytest.raises(ValueError) as e:
        lmhost.plan(step=step)
    msg = str(e.value)
    assert msg.startswith("step ") and "mm is out of range: allowed 0.000287626..=18.8496 mm" in msg, msg
    assert "inf" not in msg, msg


@pytest.mark.parametrize("radius", [1e-320, 1e-300], ids=repr)
def test_a_tiny_radius_names_the_circumference_it_gives(radius):
    with pytest.raises(ValueError) as e:
        lmhost.plan(radius=radius)
    msg = str(e.value)
    assert "wider than the circumference 2πA = 6.283e-" in msg and "0.000 mm" not in msg, msg


@pytest.mark.parametrize("plane_step", [1e-320, 1e-300], ids=repr)
def test_a_plane_step_too_fine_names_the_finest_it_takes(plane_step):
    with pytest.raises(ValueError) as e:
        lmhost.simulate(lmhost.plan(), plane_step=plane_step)
    msg = str(e.value)
    assert "give a step of at least 0.010005 mm" in msg and "inf" not in msg, msg


@pytest.mark.parametrize("density", [1e-320, 1e-300, 1e-4], ids=repr)
def test_a_density_that_would_make_the_force_overflow_is_refused(density):
    with pytest.raises(ValueError, match=r"^--density .* kg/m³ is out of range: allowed 0\.001\.\.=100 kg/m³$"):
        lmhost.simulate(lmhost.plan(), plane_size=2, plane_step=1, density=density)


def test_the_lowest_density_still_gives_a_finite_force():
    f = lmhost.simulate(lmhost.plan(), plane_size=2, plane_step=1, density=0.001)
    assert math.isfinite(f.force_n) and f.force_n > 0


@pytest.mark.parametrize("intensity", [0.001, 1e-300, 0.0019], ids=repr)
def test_an_intensity_that_rounds_to_silence_is_refused(intensity):
    # r13-8: level 0 of 255 was planned and played, a stimulus nobody feels.
    with pytest.raises(ValueError, match=r"rounds to level 0 of 255, silence: give 0 for silence or at least 0\.00197"):
        lmhost.plan(intensity=intensity)
    assert lmhost.plan(intensity=0.00197).summary()["header"]["intensity"] == 1
    assert lmhost.plan(intensity=0).summary()["header"]["intensity"] == 0


# -- r13-11. Every argument error says what the argument must be -------------

SCENE = "a Scene (lmhost.Scene.load(path) or lmhost.Scene.flat())"
PLAN = "a Plan (from lmhost.plan())"
PATH = "a path (a str or pathlib.Path)"


def _calls(root):
    plan = lmhost.plan()
    paper = lmhost.Scene.load(root / "scenes" / "paper.toml")
    cam = {"width": 4, "height": 4, "fx": 2.0, "fy": 2.0, "ppx": 1.5, "ppy": 1.5, "depth_scale": 0.001}
    return [
        ("plan scene=3", lambda: lmhost.plan(scene=3), f"scene must be {SCENE}, got int"),
        ("plan scene='paper.toml'", lambda: lmhost.plan(scene="scenes/paper.toml"), f"scene must be {SCENE}, got str"),
        ("simulate plan=None", lambda: lmhost.simulate(None), f"plan must be {PLAN}, got None"),
        ("simulate plan=scene", lambda: lmhost.simulate(paper), f"plan must be {PLAN}, got Scene"),
        ("Tracker scene=None", lambda: lmhost.Tracker(None, cam), f"scene must be {SCENE}, got None"),
        ("Device scene='x'", lambda: lmhost.Device("autd3:emulator", scene="x"), f"scene must be {SCENE}, got str"),
        ("Scene.load bytes", lambda: lmhost.Scene.load(b"scenes/paper.toml"), f"path must be {PATH}, got bytes"),
        ("Scene.load int", lambda: lmhost.Scene.load(3), f"path must be {PATH}, got int"),
        ("Plan.save None", lambda: plan.save(None), f"path must be {PATH}, got None"),
        ("Plan.save bytes", lambda: plan.save(b"p.npy"), f"path must be {PATH}, got bytes"),
        ("Plan.summary phases=1", lambda: plan.summary(phases=1), "phases must be True or False, got 1"),
        ("Plan.summary phases='yes'", lambda: plan.summary(phases="yes"), "phases must be True or False, got 'yes'"),
    ]


@pytest.mark.parametrize("i", range(12))
def test_an_argument_of_the_wrong_kind_says_what_it_must_be(root, i):
    name, call, needle = _calls(root)[i]
    with pytest.raises(ValueError) as e:
        call()
    assert not isinstance(e.value, TypeError)
    assert str(e.value) == needle, name


def test_the_extension_says_so_itself(root):
    # The private functions too: the rule is the extension's, not only the
    # wrapper's.
    from lmhost import _lmhost

    with pytest.raises(ValueError, match=r"^target must be 'lm' or 'autd3', got int$"):
        _lmhost.plan(None, None, None, None, None, None, None, None, None, 3)
    with pytest.raises(ValueError, match=r"^port must be a --port name \(a string\), got None$"):
        _lmhost.Device(None)
    with pytest.raises(ValueError, match=r"^reference must be True or False, got 'no'$"):
        _lmhost.simulate(lmhost.plan(), 2, 1, None, None, 2, 1.2, 15, None, "no")


def test_a_device_upload_names_its_plan_and_flags(root):
    with lmhost.Device("autd3:emulator") as d:
        with pytest.raises(ValueError) as e:
            d.upload("lms-5hz")
        assert str(e.value) == f"plan must be {PLAN}, got str"


def test_the_right_kinds_still_work(root, tmp_path):
    import pathlib

    s = lmhost.Scene.load(pathlib.Path(root / "scenes" / "paper.toml"))
    p = lmhost.plan(scene=s)
    p.save(tmp_path / "p.npy")
    assert (tmp_path / "p.npy").stat().st_size > 0
    assert "phases" in p.summary(phases=True) and "phases" not in p.summary()


# -- r13-13. A control line's value is refused by its own limit --------------

LIBRARY = "studies/paper-library.toml"
ID_CHARS = lmhost._lmhost.CONTROL_LIMITS["id_chars"]


@pytest.fixture(scope="module")
def session(lmhost_bin, root):
    with lmhost.Session(library=root / LIBRARY, port="autd3:emulator", synthetic=True) as s:
        yield s


ID_MSG = f"characters, more than {ID_CHARS}: a library entry's id is at most {ID_CHARS} characters"


@pytest.mark.parametrize("n", [ID_CHARS + 1, 5000, 100_000])
@pytest.mark.parametrize(
    "call",
    [
        lambda s, v: s.present(v),
        lambda s, v: s.prepare(v),
        lambda s, v: s.command("present", stimulus=v),
        lambda s, v: s.command("prepare", stimulus=v),
    ],
    ids=["present", "prepare", "command-present", "command-prepare"],
)
def test_a_stimulus_longer_than_an_id_is_refused_by_its_own_limit(session, call, n):
    with pytest.raises(ValueError) as e:
        call(session, "x" * n)
    msg = str(e.value)
    assert msg.startswith(f"stimulus: {n} {ID_MSG}"), msg
    assert "\n" not in msg and "bad command" not in msg and "4096" not in msg, msg
    # The session still answers: nothing half-sent.
    assert session.status() is not None


def test_an_id_of_the_longest_length_reaches_the_session(session):
    with pytest.raises(ValueError, match=rf"^no stimulus `x{{{ID_CHARS}}}` in the library"):
        session.present("x" * ID_CHARS)
    assert session.status() is not None


@pytest.mark.parametrize("stimulus", [None, 3, b"lms", ["a"]], ids=repr)
def test_a_stimulus_that_is_no_string_is_refused_by_name(session, stimulus):
    with pytest.raises(ValueError, match=r"^stimulus must be a library entry's id \(a string\), got "):
        session.present(stimulus)


def _np_gate():
    np = pytest.importorskip("numpy")
    return np.array(["tracked"])


@pytest.mark.parametrize("gate", ["x" * 5000, "Tracked", "", 1, True, b"tracked"], ids=lambda v: repr(v)[:12])
def test_a_gate_is_tracked_or_untracked(session, gate):
    sid = session.library()[0]["id"]
    for call in (lambda: session.present(sid, gate=gate), lambda: session.command("present", stimulus=sid, gate=gate)):
        with pytest.raises(ValueError) as e:
            call()
        msg = str(e.value)
        assert msg.startswith('gate must be "tracked" or "untracked", got '), msg
        assert len(msg) < 120, msg


@pytest.mark.parametrize(
    "kw, needle",
    [
        (dict(cmd="x" * 5000), "cmd: 5000 characters, more than 32: a command's name"),
        (dict(cmd="status", **{"y" * 300: 1}), "field name: 300 characters, more than 32"),
        (dict(cmd="present", stimulus="a", note="\x01" * 2000), "present: its values make a line of"),
    ],
    ids=["cmd", "field", "escapes"],
)
def test_any_other_command_value_is_refused_before_the_line_is_built(session, kw, needle):
    with pytest.raises(ValueError) as e:
        session.command(**kw)
    assert str(e.value).startswith(needle), str(e.value)
    assert "bad command" not in str(e.value)
    assert session.status() is not None


@pytest.mark.parametrize("token", ["f" * 5000, 7], ids=lambda v: repr(v)[:8])
def test_a_token_is_checked_before_a_connection(token):
    with pytest.raises(ValueError) as e:
        lmhost.Session(tcp_port=9, token=token)
    msg = str(e.value)
    assert msg.startswith("token: 5000 characters, more than 32: a session's token") or msg.startswith(
        "token must be a session's token (a string), got int"
    ), msg


def test_a_gate_of_an_array_is_refused_by_kind(session):
    sid = session.library()[0]["id"]
    with pytest.raises(ValueError, match=r'^gate must be "tracked" or "untracked", got ndarray$'):
        session.present(sid, gate=_np_gate())
