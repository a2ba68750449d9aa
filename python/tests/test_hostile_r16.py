"""Round 16 of hostile input to the Python package.

- r16-1: a value a Python-side message repeats is shown as the
  extension's messages show it (``_lmhost.shown``: its repr on one line,
  cut at 40 characters). The tracker's intrinsics dict (a key, a value),
  ``Study``'s ``answer`` and a session's ``repeat`` put ``repr()`` in the
  message whole: a 2-D numpy array spread the exception over several
  lines, a 3000-element list made it 16 kB.
- r16-2: a message of the extension's own holds one line whatever the
  value it repeats: ``plan(target="lm\\nautd3")`` raised a two-line
  ValueError (the line break escaped now, ``\\n``, as the library's echoes
  do).
- r16-3: an integer beyond a TOML integer (i64) in the intrinsics dict was
  refused by the TOML reader in its words ("invalid type: integer,
  expected a number", "integer number overflowed"), never the field's
  range; it is now the number it is, judged by that range, and one too
  large for any float refused as out of range naming its key.
- r16-6: a number of the intrinsics dict meets the rule every float
  argument meets (``_lmhost.float_arg``): a ``Decimal`` was refused there
  as "must be a number" while ``plan(radius=Decimal("3.5"))`` planned 3.5
  mm; a NaN or an infinity is refused as not finite, naming the key.
- r16-7: ``Session.command`` sent a field of any other kind as it was: a
  list or a dict went to the session, a ``Path``, a numpy array of floats
  or a list holding a NaN failed in the JSON encoder ("present: cannot
  send Object of type PosixPath ..."), naming no field. No field of the
  protocol is a list or an object: refused by name before sending.
- r16-4: negative zero is zero: ``plan(radius=-0.0)`` planned a static
  focus and reported ``radius_mm`` -0.0, a centre (-0.0, 0, 200) came back
  as -0.0; every number the extension takes is now +0.0 there.
- r16-5: ``Tracker.process`` refused a uint16 frame in the other byte order
  (``>u2``: a big-endian ``.npy``) as "must be a numpy uint16 array"; it
  is one, and is now tracked as the same frame in the machine's order.
"""

import math
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import lmhost
from lmhost import _args, _lmhost

ROOT = Path(__file__).resolve().parents[2]
INTR = dict(width=64, height=48, fx=40.0, fy=40.0, ppx=32.0, ppy=24.0, depth_scale=0.001)
ARRAY_2D = np.zeros((3, 3))
LONG_LIST = list(range(3000))


def one_line(e) -> str:
    msg = str(e.value)
    assert "\n" not in msg and "\r" not in msg, msg
    assert len(msg) < 300, msg
    return msg


@pytest.fixture(scope="module")
def scene():
    return lmhost.Scene.load(ROOT / "scenes" / "paper.toml")


def test_shown_is_one_line_and_cut():
    assert _lmhost.shown(ARRAY_2D) == "array([[0., 0., 0.], [0., 0., 0.], [0., … (49 characters)"
    assert _lmhost.shown("x") == "'x'"
    assert _args.shown is _lmhost.shown


@pytest.mark.parametrize("value", [ARRAY_2D, LONG_LIST, {"a": [1] * 500}], ids=["2d", "list", "dict"])
def test_an_intrinsics_value_is_shown_on_one_line(scene, value):
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, dict(INTR, fx=value))
    msg = one_line(e)
    assert msg.startswith("intrinsics dict: `fx` must be a number, got "), msg
    assert msg.endswith(_lmhost.shown(value)), msg


@pytest.mark.parametrize("key", ["#" + "a" * 3000, ("a",) * 300, "a\nb"], ids=["long", "tuple", "newline"])
def test_an_intrinsics_key_is_shown_on_one_line(scene, key):
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, {key: 1, **INTR})
    msg = one_line(e)
    assert msg.startswith(f"intrinsics dict: key {_lmhost.shown(key)} is not a field name"), msg


def test_a_studys_answer_and_a_repeat_are_shown_on_one_line(tmp_path):
    with pytest.raises(ValueError) as e:
        lmhost.Study(ROOT / "studies" / "paper-exp1.toml", "p1", tmp_path / "out", "autd3:emulator", answer=ARRAY_2D)
    assert one_line(e) == f"answer must be callable, got {_lmhost.shown(ARRAY_2D)}"
    assert not (tmp_path / "out").exists()
    # A session command's integer field, checked before its line is built.
    with pytest.raises(ValueError) as e:
        _args.whole("repeat", ARRAY_2D)
    assert one_line(e) == f"repeat must be an integer, got {_lmhost.shown(ARRAY_2D)}"


@pytest.mark.parametrize("target", ["lm\nautd3", "lm\rx", "x" * 5000])
def test_a_value_with_a_line_break_or_a_long_one_stays_on_one_line(target):
    with pytest.raises(ValueError) as e:
        lmhost.plan(target=target)
    msg = one_line(e)
    assert msg.endswith("is not a target: give lm or autd3"), msg
    if "\n" in target:
        assert "`lm\\nautd3`" in msg, msg


@pytest.mark.parametrize(
    "key, value, want",
    [
        ("fx", 2**70, "intrinsics dict: `fx` must be a focal length of 1..=100000 pixels, got 1.18059e21"),
        ("fx", -(2**70), "intrinsics dict: `fx` must be a focal length of 1..=100000 pixels, got -1.18059e21"),
        ("depth_scale", 2**64, "intrinsics dict: `depth_scale` must be 1e-6..=1 metres per unit, got 1.84467e19"),
        ("width", 2**63, "intrinsics dict: line 1, field `width`: 9.22337e18 is out of range: allowed 1..=8192"),
        ("fx", np.uint64(2**63 + 5), "intrinsics dict: `fx` must be a focal length of 1..=100000 pixels, got 9.22337e18"),
    ],
)
def test_an_intrinsics_integer_beyond_toml_is_judged_by_its_fields_range(scene, key, value, want):
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, dict(INTR, **{key: value}))
    assert one_line(e) == want


@pytest.mark.parametrize("key", ["width", "fx", "depth_scale"])
def test_an_intrinsics_integer_beyond_any_float_is_out_of_range(scene, key):
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, dict(INTR, **{key: 10**400}))
    msg = one_line(e)
    assert msg.startswith(f"intrinsics dict: `{key}` 1000000000"), msg
    assert msg.endswith("(401 characters) is out of range: give a finite number"), msg


def test_the_largest_toml_integer_is_still_written_as_one(scene):
    # 2**63 - 1 is a TOML integer: the field's own whole-number rule.
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, dict(INTR, width=2**63 - 1))
    assert one_line(e) == "intrinsics dict: line 1, field `width`: 9.22337e18 is out of range: allowed 1..=8192"


@pytest.mark.parametrize(
    "value", [Decimal("40.5"), Fraction(81, 2), np.float32(40.5), np.int16(40)], ids=repr
)
def test_an_intrinsics_number_is_any_number_a_float_argument_is(scene, value):
    want = lmhost.Tracker(scene, dict(INTR, fx=float(value))).process(np.zeros((48, 64), np.uint16), 1.0)
    got = lmhost.Tracker(scene, dict(INTR, fx=value)).process(np.zeros((48, 64), np.uint16), 1.0)
    assert (got.points, got.present) == (want.points, want.present)
    # And the radius of a plan, by the same rule.
    assert lmhost.plan(radius=Decimal("3.5")).radius_mm == 3.5


@pytest.mark.parametrize(
    "value, want",
    [
        (float("nan"), "intrinsics dict: `fx` must be a finite number, got NaN"),
        (Decimal("-Infinity"), "intrinsics dict: `fx` must be a finite number, got -inf"),
        (np.float64("inf"), "intrinsics dict: `fx` must be a finite number, got inf"),
        (np.True_, "intrinsics dict: `fx` must be a number, got np.True_"),
        (1 + 2j, "intrinsics dict: `fx` must be a number, got (1+2j)"),
        ("40", "intrinsics dict: `fx` must be a number, got '40'"),
    ],
    ids=repr,
)
def test_an_intrinsics_value_is_refused_by_the_one_float_rule(scene, value, want):
    with pytest.raises(ValueError) as e:
        lmhost.Tracker(scene, dict(INTR, fx=value))
    assert one_line(e) == want
    with pytest.raises(ValueError) as e:
        _lmhost.float_arg("fx", value)
    assert f"intrinsics dict: `fx`{str(e.value)[2:]}" == want


def positive_zero(x: float) -> bool:
    return x == 0 and math.copysign(1.0, x) == 1.0


def test_negative_zero_is_taken_as_zero():
    p = lmhost.plan(radius=-0.0, center=(-0.0, -0.0, 200.0), target="lm")
    assert positive_zero(p.radius_mm), p.radius_mm
    assert all(positive_zero(c) for c in p.center_mm[:2]), p.center_mm
    s = p.summary()
    assert "-0.0" not in repr(s), s
    assert _lmhost.float_arg("on_s", -0.0) == 0.0
    assert positive_zero(_lmhost.float_arg("on_s", -0.0))
    assert positive_zero(_lmhost.float_arg("x", np.float32(-0.0)))
    # Where 0 is refused, -0.0 is refused as 0 is: never passed as a
    # value "above 0".
    with pytest.raises(ValueError) as zero:
        lmhost.simulate(p, plane_step=0.0)
    with pytest.raises(ValueError) as neg:
        lmhost.simulate(p, plane_step=-0.0)
    assert str(neg.value) == str(zero.value)


def test_a_uint16_frame_in_the_other_byte_order_is_the_same_frame(scene):
    # A flat surface 250 mm from the camera crosses the detection box: a
    # contact; its bytes swapped (64000 mm) would be none.
    intr = dict(width=320, height=240, fx=300.0, fy=300.0, ppx=160.0, ppy=120.0, depth_scale=0.001)
    frame = np.full((240, 320), 250, np.uint16)
    swapped = frame.astype(">u2" if np.little_endian else "<u2")
    assert not swapped.dtype.isnative and (swapped == frame).all()
    a = lmhost.Tracker(scene, intr)
    b = lmhost.Tracker(scene, intr)
    ra = a.process(frame, 1.0)
    rb = b.process(swapped, 1.0)
    assert ra.points > 0 and ra.present
    assert (ra.points, ra.present, ra.centroid_mm) == (rb.points, rb.present, rb.centroid_mm)
    # A non-contiguous, other-order view of the same frame too.
    wide = np.zeros((240, 640), dtype=swapped.dtype)
    wide[:, ::2] = frame
    rc = lmhost.Tracker(scene, intr).process(wide[:, ::2], 1.0)
    assert (rc.points, rc.centroid_mm) == (ra.points, ra.centroid_mm)
    # Not uint16 stays refused, in the other byte order too.
    for bad in (frame.astype(">i2"), frame.astype(">u4"), frame.astype(np.float64)):
        with pytest.raises(ValueError, match=r"^depth frame must be a numpy uint16 array of shape \(240, 320\)$"):
            a.process(bad, 2.0)


LIBRARY = "studies/paper-library.toml"


@pytest.fixture(scope="module")
def session(lmhost_bin):
    with lmhost.Session(library=ROOT / LIBRARY, port="autd3:emulator", synthetic=True) as s:
        yield s


@pytest.mark.parametrize(
    "value",
    [[0.5], (0.5,), {"s": 0.5}, [float("nan")], Path("0.5"), b"0.5", {0.5}],
    ids=repr,
)
def test_a_command_field_of_another_kind_is_refused_by_name(session, value):
    sid = session.library()[0]["id"]
    with pytest.raises(ValueError) as e:
        session.command("present", stimulus=sid, gate="untracked", on_s=value)
    want = f"on_s must be a string, a number, True, False or None, got {_lmhost.shown(value)}"
    assert one_line(e) == want
    # Nothing was sent: the session is idle and answers.
    assert session.status()["state"] == "idle"

