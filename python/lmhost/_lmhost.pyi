"""Type stubs of `lmhost._lmhost`, the extension module (Rust, pyo3).

The package `lmhost` (`__init__.py`) wraps it with keyword defaults and
checks; its own annotations are its types, so only the extension needs
stubs here."""

import os
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike[str]]

DEFAULTS: Dict[str, Any]
CONTROL_LIMITS: Dict[str, int]
"""The keyword defaults, from the Rust library: radius, foci, spacing,
freq, step, intensity, target (plan); plane_size, plane_step, alpha,
density, disk (simulate); enter_frames, leave_frames (Tracker); lease_s."""

class DeviceError(OSError):
    """A device or I/O fault (the CLI's exit code 1)."""

class Scene:
    @staticmethod
    def load(path: PathLike) -> Scene: ...
    @staticmethod
    def flat() -> Scene: ...
    @property
    def name(self) -> str: ...
    @property
    def center_mm(self) -> Tuple[float, float, float]: ...
    @property
    def transducers(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Positions (N, 3) in mm and unit normals (N, 3)."""

class Plan:
    @property
    def phases(self) -> npt.NDArray[np.uint8]:
        """Shape (steps, transducers)."""
    @property
    def steps(self) -> int: ...
    @property
    def dwell_us(self) -> float: ...
    @property
    def freq_hz(self) -> float: ...
    @property
    def step_mm(self) -> float: ...
    @property
    def index_offset(self) -> int: ...
    @property
    def radius_mm(self) -> float: ...
    @property
    def center_mm(self) -> Tuple[float, float, float]: ...
    @property
    def target(self) -> str: ...
    @property
    def transducers(self) -> int: ...
    @property
    def crc32(self) -> int: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def timing(self) -> Dict[str, Any]: ...
    @property
    def foci_mm(self) -> npt.NDArray[np.float64]:
        """Shape (steps, foci, 3), mm."""
    def save(self, path: PathLike) -> None:
        """The files `lmhost plan --out PATH` writes (.json, .npy, raw)."""
    def summary(self, phases: bool = False) -> Dict[str, Any]:
        """What `lmhost plan --json` prints."""

class Field:
    mean_pressure: npt.NDArray[np.float64]
    lm_power: npt.NDArray[np.float64]
    pressure: npt.NDArray[np.float64]
    amplitude: npt.NDArray[np.float64]
    max_pressure: npt.NDArray[np.float64]
    u_mm: npt.NDArray[np.float64]
    v_mm: npt.NDArray[np.float64]
    force_n: float
    summary: Dict[str, Any]

def plan(
    radius: Any,
    foci: Any,
    spacing: Any,
    freq: Any,
    step: Any,
    steps: Any,
    center: Optional[Sequence[float]],
    scene: Optional[Scene],
    intensity: Any,
    target: str,
) -> Plan: ...
def simulate(
    plan: Plan,
    plane_size: Any,
    plane_step: Any,
    plane_center: Optional[Sequence[float]],
    plane_axes: Optional[Sequence[float]],
    alpha: Any,
    density: Any,
    disk: Any,
    calibration: Optional[float],
    reference: bool,
) -> Field: ...
def int_arg(name: str, value: Any, lo: int, hi: int) -> int: ...
def float_arg(name: str, value: Any) -> float: ...
def bool_arg(name: str, value: Any) -> bool: ...
def repeat_arg(value: Any) -> int: ...
def shown(value: Any) -> str: ...

class Tracker:
    def __init__(
        self,
        scene: Scene,
        intrinsics_toml: Optional[str],
        origin: str,
        enter_frames: Optional[int] = None,
        leave_frames: Optional[int] = None,
        intrinsics_path: Optional[str] = None,
    ) -> None: ...
    @property
    def shape(self) -> Tuple[int, int]: ...
    @property
    def min_points(self) -> int: ...
    def process(
        self, depth: npt.NDArray[np.uint16], t: Optional[float] = None
    ) -> Tuple[float, int, bool, Optional[Tuple[float, float, float]], bool]: ...

class Device:
    def __init__(self, port: str, scene: Optional[Scene] = None) -> None: ...
    @property
    def port(self) -> str: ...
    def info(self) -> Dict[str, Any]: ...
    def status(self) -> Dict[str, Any]: ...
    def upload(self, plan: Plan, slot: Optional[int], play: bool, untracked: bool) -> str:
        """The `lmhost upload --json` report, as JSON text."""
    def play(self, slot: int, untracked: bool = False) -> None: ...
    def stop(self) -> None: ...
    def centroid(self, x: float, y: float, z: float, present: bool = True) -> str: ...
    def tick(self) -> None: ...
    def close(self) -> None: ...

class Study:
    def __init__(
        self,
        protocol: str,
        participant: str,
        out: str,
        port: str,
        answer: Callable[[Dict[str, Any]], Any],
        scene: Optional[str] = None,
        seed: Optional[int] = None,
        index: Optional[int] = None,
        finger: Optional[str] = None,
        time_scale: float = 1.0,
        resume: bool = False,
    ) -> None: ...
    def __iter__(self) -> Iterator[Dict[str, str]]: ...
    def __next__(self) -> Dict[str, str]: ...
    @property
    def report(self) -> Optional[Dict[str, Any]]: ...

def _bench_rust(scene: Scene, intrinsics_toml: str, depth: npt.NDArray[np.uint16], repeats: int) -> Tuple[float, float]: ...
def _panic_for_test() -> None: ...
