"""lmhost from Python: lateral-modulation (LM) ultrasound haptics.

The same library as the ``lmhost`` command line, called from Python:

* :func:`plan` plans a stimulus (``lmhost plan``), :class:`Plan` holds it;
* :func:`simulate` computes its acoustic field (``lmhost simulate``);
* :class:`Tracker` finds the finger's contact area in depth frames
  (``lmhost track``);
* :class:`Device` opens a device by any ``--port`` form and uploads
  (``lmhost upload``);
* :class:`Session` drives a running ``lmhost session`` over its control
  socket (the JSON-line protocol in ``host/src/lab/session/PROTOCOL.md``);
* :class:`Study` runs a study protocol (``lmhost study run``) with answers
  from a Python callable, yielding the rows as they are written.

Bad input raises :class:`ValueError` with the line the CLI prints; device
and I/O faults raise :class:`DeviceError` (an :class:`OSError`). Every
number is checked before anything is planned or sent: an integer
parameter takes an int (not a float, not a bool) in range, a float
parameter a finite number, else :class:`ValueError` naming it. A name
(a port, a participant) takes a ``str`` and a path a ``str`` or
``pathlib.Path``; anything else is a :class:`ValueError` naming it.
Units are in the names: ``_mm``, ``_us``, ``_hz``. The keyword defaults
are the library's (:data:`DEFAULTS`, the values ``lmhost plan`` and
``lmhost simulate`` use without flags).
"""

from __future__ import annotations

import json
import operator
import os
import re
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _args, _lmhost
from ._lmhost import DeviceError, Scene
from ._session import Session, find_binary

__all__ = [
    "DEFAULTS",
    "DeviceError",
    "Device",
    "Field",
    "Plan",
    "Scene",
    "Session",
    "Study",
    "TrackResult",
    "Tracker",
    "find_binary",
    "plan",
    "simulate",
]

Plan = _lmhost.Plan
Field = _lmhost.Field
PathLike = Union[str, "os.PathLike[str]"]

#: The keyword API's defaults, read from the Rust library's constants.
DEFAULTS: Dict[str, Any] = dict(_lmhost.DEFAULTS)
_D = DEFAULTS


def plan(
    radius: Optional[float] = None,
    foci: Optional[int] = None,
    spacing: Optional[float] = None,
    freq: Optional[float] = None,
    step: Optional[float] = None,
    steps: Optional[int] = None,
    center: Optional[Sequence[float]] = None,
    scene: Optional[Scene] = None,
    intensity: Optional[float] = None,
    target: str = _D["target"],
) -> Plan:
    """Plan an LM stimulus, as ``lmhost plan`` does.

    radius: circle radius A in mm (0 = a static focus). foci: foci per step
    (1 = LM-S, more = LM-M). spacing: distance between neighbouring foci
    (mm, LM-M only). freq: LM frequency (Hz). step: step width d_LM (mm),
    or give ``steps`` (N) instead. center: LM centre (x, y, z) in mm,
    default the scene's. scene: default the flat 2 x 2 AUTD3. intensity:
    0..1 of full. target: ``"lm"`` (the LM firmware's timing) or
    ``"autd3"`` (AUTD3's 25 us dwell grid). A value left None is the
    library's default (:data:`DEFAULTS`), as a flag not given is: one that
    cannot apply (spacing with one focus, step beside steps) is refused.
    """
    # Passed as given: the extension checks every number (no int() here,
    # which would make steps=3.7 a silent 3).
    if not isinstance(target, str):
        # str() would make any object a "target" named by its repr.
        raise ValueError(f"target must be 'lm' or 'autd3', got {type(target).__name__}")
    return _lmhost.plan(radius, foci, spacing, freq, step, steps, center, scene, intensity, target)


def simulate(
    plan: Plan,
    plane_size: Union[float, Tuple[float, float]] = _D["plane_size"],
    plane_step: float = _D["plane_step"],
    plane_center: Optional[Sequence[float]] = None,
    plane_axes: Optional[Sequence[float]] = None,
    alpha: float = _D["alpha"],
    density: float = _D["density"],
    disk: float = _D["disk"],
    calibration: Optional[float] = None,
    reference: bool = False,
) -> Field:
    """Simulate the plan's acoustic field on the LM plane (``lmhost simulate``).

    Returns a :class:`Field`: ``mean_pressure`` (Pa) and ``lm_power`` (Pa^2)
    maps (rows along v, columns along u), ``pressure``, ``amplitude`` and
    ``max_pressure``, the axes ``u_mm`` / ``v_mm``, ``force_n`` and
    ``summary`` (the dict ``lmhost simulate`` writes as summary.json).
    Defaults equal the CLI's. ``calibration=None`` applies the scene's
    ``[calibration]`` (if any); a number replaces it.
    """
    return _lmhost.simulate(
        plan,
        plane_size,
        plane_step,
        plane_center,
        plane_axes,
        alpha,
        density,
        disk,
        calibration,
        _lmhost.bool_arg("reference", reference),
    )


class TrackResult:
    """One frame's contact area.

    present: at least ``min_points`` depth points in the box (this frame
    alone); centroid_mm: their centroid (mm, scene) when present, else None;
    points: depth points in the box; gated: presence after hysteresis (the
    device gate); t_s: the frame time (s).
    """

    __slots__ = ("t_s", "points", "present", "centroid_mm", "gated")

    def __init__(self, t_s, points, present, centroid_mm, gated):
        self.t_s = t_s
        self.points = points
        self.present = present
        self.centroid_mm = None if centroid_mm is None else tuple(centroid_mm)
        self.gated = gated

    def __repr__(self) -> str:
        return (
            f"TrackResult(t_s={self.t_s:.4f}, points={self.points}, "
            f"present={self.present}, centroid_mm={self.centroid_mm}, gated={self.gated})"
        )


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


#: The integers a TOML file holds (i64): a larger one is written as the
#: number it is, a float, and judged by its field's range.
_TOML_INT = range(-(2**63), 2**63)


def _toml_number(key: str, v: Any) -> str:
    """A number of the intrinsics dict as TOML: an int (numpy's too, as
    ``shape`` gives) within TOML's integers as what it is; any other
    number by the one rule every float argument meets
    (``_lmhost.float_arg``: a real number of any kind, numpy's, a
    ``Decimal`` or a ``Fraction`` too, finite; a bool, numpy's too, or a
    complex number refused), in its words, naming the key."""
    if not isinstance(v, bool) and type(v).__module__ + "." + type(v).__name__ not in (
        "numpy.bool",
        "numpy.bool_",
    ):
        try:
            n = operator.index(v)
        except TypeError:
            pass
        else:
            # Beyond a TOML integer the file would not parse ("integer
            # number overflowed", "invalid type: integer"): the number as
            # a float, refused by the field's own range.
            if n in _TOML_INT:
                return str(n)
    try:
        return repr(_lmhost.float_arg(key, v))
    except ValueError as e:
        # "fx must be a number, got '5'" as "intrinsics dict: `fx` must be …"
        raise ValueError(f"intrinsics dict: `{key}`{str(e)[len(key):]}") from None


def _intrinsics_toml(intrinsics: Union[Dict[str, Any], PathLike]) -> Tuple[Optional[str], str]:
    """TOML text of a dict, or (None, the path): a file is read by the Rust
    core as ``lmhost track --intrinsics`` reads it (a byte-order mark and
    CRLF skipped, UTF-16 refused), never in the platform's encoding."""
    if isinstance(intrinsics, dict):
        lines = []
        for k, v in intrinsics.items():
            # A key is written into the TOML as it is: one that is not a
            # bare name ("#fx" made the line a comment, dropped unseen;
            # "fx = 5 #" set fx) is refused, a bare unknown one by Rust.
            if not isinstance(k, str) or not _BARE_KEY.fullmatch(k):
                raise ValueError(
                    f"intrinsics dict: key {_args.shown(k)} is not a field name "
                    "(width, height, fx, fy, ppx, ppy, depth_scale)"
                )
            lines.append(f"{k} = {_toml_number(k, v)}")
        return "\n".join(lines) + "\n", "dict"
    return None, _args.path("intrinsics", intrinsics)


class Tracker:
    """The paper's contact-area tracker (``lmhost track``'s per-frame work).

    scene: a :class:`Scene` with ``[camera]`` and ``[tracking]``.
    intrinsics: a dict (width, height, fx, fy, ppx, ppy, depth_scale) or the
    path of an intrinsics TOML (``lmhost track --record`` writes one beside
    the recording).
    """

    def __init__(
        self,
        scene: Scene,
        intrinsics: Union[Dict[str, Any], PathLike],
        enter_frames: int = _D["enter_frames"],
        leave_frames: int = _D["leave_frames"],
    ) -> None:
        text, origin = _intrinsics_toml(intrinsics)
        path = origin if text is None else None
        self._t = _lmhost.Tracker(scene, text, origin, enter_frames, leave_frames, path)

    @property
    def shape(self) -> Tuple[int, int]:
        """Frame shape (height, width) the intrinsics describe."""
        return self._t.shape

    def process(self, depth: np.ndarray, t: Optional[float] = None) -> TrackResult:
        """Track one depth frame (numpy uint16, shape (H, W)) taken at ``t`` s
        (default: seconds since the tracker was made): 0 to 1e10 s and not
        before the previous frame's, as a recording's frames must be."""
        if isinstance(depth, np.ndarray) and depth.dtype.kind == "u" and depth.dtype.itemsize == 2:
            # uint16 in the other byte order (a big-endian ``.npy``, a
            # camera's raw buffer viewed as ``>u2``) is uint16 all the
            # same: the same numbers in the machine's order, exactly.
            depth = depth.astype(np.uint16, copy=False)
        return TrackResult(*self._t.process(depth, t))


class Device:
    """A device by its ``--port`` name: a serial/pty path, ``tcp:HOST:PORT``,
    or an AUTD3 (``autd3:emulator``, ``autd3:soem[:IF]``, ...).

    Use it as a context manager; closing an AUTD3 leaves it silent. Any
    thread may call it (the device lives on a thread of its own; calls
    from several threads run one at a time).
    """

    def __init__(self, port: str, scene: Optional[Scene] = None) -> None:
        self._d = _lmhost.Device(_args.text("port", port, "a --port name"), scene)

    @property
    def port(self) -> str:
        return self._d.port

    def info(self) -> Dict[str, Any]:
        """Identity and capabilities (``lmhost info``)."""
        return self._d.info()

    def status(self) -> Dict[str, Any]:
        """The device's status (``lmhost status``)."""
        return self._d.status()

    def upload(
        self,
        plan: Plan,
        slot: Optional[int] = None,
        play: bool = True,
        untracked: bool = False,
    ) -> Dict[str, Any]:
        """Upload ``plan`` (planned for this device kind) into ``slot``
        (default: a free one), play it unless ``play=False``; returns the
        report ``lmhost upload --json`` prints, the same keys (``hold_s`` is
        None: what plays lasts while this object holds it, see :meth:`tick`)."""
        report = json.loads(self._d.upload(
                plan,
                slot,
                _lmhost.bool_arg("play", play),
                _lmhost.bool_arg("untracked", untracked),
            ))
        report["hold_s"] = None
        return report

    def play(self, slot: int, untracked: bool = False) -> None:
        """Play ``slot`` (tracked unless ``untracked``)."""
        self._d.play(slot, _lmhost.bool_arg("untracked", untracked))

    def stop(self) -> None:
        """Stop: the array is silent."""
        self._d.stop()

    def centroid(self, x: float, y: float, z: float, present: bool = True) -> str:
        """Send a finger centroid (mm, finger space): ``"applied"`` or
        ``"out_of_range"``."""
        return self._d.centroid(x, y, z, _lmhost.bool_arg("present", present))

    def tick(self) -> None:
        """Keep what plays going: an AUTD3's host-driven link (it falls
        silent one lease, 1 s, after the last renewal), the LM firmware's
        host lease (it stops by itself a lease after the last request it
        heard; centroids renew it too; ``DEFAULTS["lease_s"]``). Call it at
        least every 10 ms while playing."""
        self._d.tick()

    def close(self) -> None:
        self._d.close()

    def __enter__(self) -> "Device":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class Study:
    """A study protocol run in this process, as ``lmhost study run`` runs it
    (``studies/*.toml``; see ``docs/`` for the format): the same order,
    files (``OUT/PARTICIPANT/trials.csv``, ``session.json``,
    ``events.jsonl``) and resume.

    ``answer(question)`` is called for every question, on the thread that
    iterates (so a PsychoPy window or a button box may answer), with a dict:
    ``column``, ``prompt``, ``kind`` (``likert``, ``choice``, ``number``),
    ``accepts`` (``points``; ``labels``; ``min``/``max``), ``not_perceived``
    (its label, answered as ``"na"``, or None) and ``level`` (the level a
    procedure asks about, or None). It returns the answer as typed at the
    terminal (``3``, a label or its number, a number). Iterating yields each
    trial's row as a dict (``trials.csv``'s columns, as strings) once it is
    on disk. A callback that raises, or Ctrl-C, ends the run with the array
    silent and its exception propagating; run again with ``resume=True``.

    ``port``: any ``--port`` form (a serial/pty path such as ``lmhost sim``
    prints, ``tcp:HOST:PORT``, ``autd3:emulator``, ``autd3:soem``).
    ``finger``: None (the protocol must not wait for a finger) or
    ``"synthetic"`` (a finger that touches for each trial).
    """

    def __init__(
        self,
        protocol: PathLike,
        participant: str,
        out: PathLike,
        port: str,
        answer: Any,
        scene: Optional[PathLike] = None,
        seed: Optional[int] = None,
        index: Optional[int] = None,
        finger: Optional[str] = None,
        time_scale: float = 1.0,
        resume: bool = False,
    ) -> None:
        if not callable(answer):
            raise ValueError(f"answer must be callable, got {_args.shown(answer)}")
        if seed is not None:
            seed = _lmhost.int_arg("seed", seed, 0, 2**63 - 1)
        if index is not None:
            index = _lmhost.int_arg("index", index, 1, 2**31 - 1)
        self._s = _lmhost.Study(
            _args.path("protocol", protocol),
            _args.text("participant", participant, "a participant's name"),
            _args.path("out", out),
            _args.text("port", port, "a --port name"),
            answer,
            scene=_args.opt_path("scene", scene),
            seed=seed,
            index=index,
            finger=_args.opt_text("finger", finger, 'None or "synthetic"'),
            time_scale=_lmhost.float_arg("time_scale", time_scale),
            resume=_lmhost.bool_arg("resume", resume),
        )

    def __iter__(self) -> Iterator[Dict[str, str]]:
        return self

    def __next__(self) -> Dict[str, str]:
        return next(self._s)

    def run(self) -> List[Dict[str, str]]:
        """Runs to the end; the rows this run wrote."""
        return list(self)

    @property
    def report(self) -> Optional[Dict[str, Any]]:
        """What the run did once it has ended (``dir``, ``trials``, ``first``,
        ``ran``, ``seed``, ``uploads``), else None."""
        return self._s.report
