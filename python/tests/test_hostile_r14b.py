"""Round 14b of hostile input to the Python package.

- r14b-1: a numpy scalar is judged as the Python value it stands for. A
  numpy bool (``np.True_``: no ``bool`` subclass) was a number through its
  ``__float__``, so ``plan(radius=np.True_)`` planned a 1 mm circle and
  ``Session.present(on_s=np.True_)`` sent ``on_s`` 1; a numpy complex
  number lost its imaginary part the same way (``np.complex128(1+2j)`` was
  1.0, with only a ``ComplexWarning``). Both are refused as Python's
  ``True`` and ``1+2j`` are. The other way round, the tracker's intrinsics
  dict refused a numpy number as "must be a number, got np.int64(64)":
  an int or a real number of numpy's is taken there as everywhere else.
- r14b-4 (Python's own): ``Tracker.process(depth, t)`` takes the time
  stamps a recording's frames may have (0 to 1e10 s, never before the
  frame before's), in the same words: it took ``t=-1``, ``t=1e300`` and a
  ``t`` going backwards, and returned them as the frames' times.
"""

import numpy as np
import pytest

import lmhost
from lmhost import _lmhost

BOOLS = [np.True_, np.False_, np.bool_(True)]
COMPLEX = [np.complex128(1 + 2j), np.complex64(3), 1 + 0j]


@pytest.mark.parametrize("v", BOOLS, ids=repr)
def test_a_numpy_bool_is_no_number(v):
    with pytest.raises(ValueError) as e:
        lmhost.plan(radius=v)
    assert str(e.value) == f"radius must be a number, got {v!r}"
    with pytest.raises(ValueError, match=r"^radius must be a number, got np\."):
        lmhost.plan(radius=v)
    with pytest.raises(ValueError, match=r"^center\[2\] must be a number, got np\."):
        lmhost.plan(center=(0.0, 0.0, v))
    # The Session's check of a float field (on_s, off_s, any other).
    with pytest.raises(ValueError, match=r"^on_s must be a number, got np\."):
        _lmhost.float_arg("on_s", v)


@pytest.mark.parametrize("v", BOOLS, ids=repr)
def test_a_numpy_bool_is_no_integer(v):
    with pytest.raises(ValueError, match=r"^foci must be an integer, got np\."):
        lmhost.plan(foci=v)
    with pytest.raises(ValueError, match=r"^repeat must be an integer, got np\."):
        _lmhost.repeat_arg(v)


@pytest.mark.parametrize("v", COMPLEX, ids=repr)
def test_a_complex_number_is_refused_not_cut_to_its_real_part(v):
    with pytest.raises(ValueError, match=r"^radius must be a number, got "):
        lmhost.plan(radius=v)
    with pytest.raises(ValueError, match=r"^off_s must be a number, got "):
        _lmhost.float_arg("off_s", v)


def test_numpy_numbers_are_still_numbers_and_numpy_bools_still_yes_or_no():
    assert lmhost.plan(radius=np.float32(2.0), foci=np.int64(1)).radius_mm == pytest.approx(2.0)
    assert _lmhost.float_arg("x", np.float16(0.5)) == 0.5
    assert _lmhost.bool_arg("present", np.True_) is True


SCENE = "scenes/paper.toml"
INTRINSICS = dict(width=64, height=48, fx=60.0, fy=60.0, ppx=32.0, ppy=24.0, depth_scale=0.001)


@pytest.mark.parametrize(
    "key,value",
    [("width", np.int64(64)), ("height", np.uint16(48)), ("fx", np.float32(60.0)), ("ppy", np.float64(24.0))],
    ids=repr,
)
def test_the_intrinsics_dict_takes_numpy_numbers(root, key, value):
    t = lmhost.Tracker(lmhost.Scene.load(root / SCENE), {**INTRINSICS, key: value})
    assert t.shape == (48, 64)


@pytest.mark.parametrize("value", [np.True_, True, 1 + 2j, np.complex64(60), "60", None], ids=repr)
def test_the_intrinsics_dict_refuses_what_is_no_number(root, value):
    with pytest.raises(ValueError, match=r"^intrinsics dict: `fx` must be a number, got "):
        lmhost.Tracker(lmhost.Scene.load(root / SCENE), {**INTRINSICS, "fx": value})


# -- r14b-4. A depth frame's time stamp obeys the recording's rule -------------


def _tracker(root):
    return lmhost.Tracker(lmhost.Scene.load(root / SCENE), INTRINSICS)


FRAME = np.full((48, 64), 200, np.uint16)


@pytest.mark.parametrize(
    "t,shown", [(-1.0, "-1"), (-5e-324, "-5e-324"), (1e300, "1e300"), (1e10 + 1, "1.0000000001e10")], ids=repr
)
def test_a_frame_time_outside_0_to_1e10_is_refused(root, t, shown):
    tr = _tracker(root)
    with pytest.raises(ValueError) as e:
        tr.process(FRAME, t)
    assert str(e.value) == f"t: frame 0 has time stamp {shown} s, out of range: give 0 to 1e10 s"


def test_a_frame_time_before_the_last_is_refused_and_changes_nothing(root):
    tr = _tracker(root)
    assert tr.process(FRAME, 5.0).t_s == 5.0
    assert tr.process(FRAME, 5.0).t_s == 5.0, "the same stamp twice is a frame"
    with pytest.raises(ValueError) as e:
        tr.process(FRAME, 4.5)
    assert str(e.value) == "t: frame 2 has time stamp 4.5 s, before the previous one's 5 s"
    # The refused frame took nothing: the next frame is frame 2.
    assert tr.process(FRAME, 6.0).t_s == 6.0
    with pytest.raises(ValueError, match=r"^t: frame 3 has time stamp .* before the previous one's 6 s$"):
        tr.process(FRAME)  # the default clock started near 0


def test_the_default_time_runs_forward(root):
    tr = _tracker(root)
    a, b = tr.process(FRAME), tr.process(FRAME)
    assert 0 <= a.t_s <= b.t_s
