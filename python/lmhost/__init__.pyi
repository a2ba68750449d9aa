"""Type stubs of `lmhost` (the binding of the lmhost Rust library)."""

import os
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike[str]]

DEFAULTS: Dict[str, Any]
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

# Defaults marked `...` are DEFAULTS' (the Rust library's).
def plan(
    radius: float = ...,
    foci: int = ...,
    spacing: float = ...,
    freq: float = ...,
    step: float = ...,
    steps: Optional[int] = None,
    center: Optional[Sequence[float]] = None,
    scene: Optional[Scene] = None,
    intensity: float = ...,
    target: str = ...,
) -> Plan: ...
def simulate(
    plan: Plan,
    plane_size: Union[float, Tuple[float, float]] = ...,
    plane_step: float = ...,
    plane_center: Optional[Sequence[float]] = None,
    plane_axes: Optional[Sequence[float]] = None,
    alpha: float = ...,
    density: float = ...,
    disk: float = ...,
    calibration: Optional[float] = None,
    reference: bool = False,
) -> Field: ...

class TrackResult:
    t_s: float
    points: int
    present: bool
    centroid_mm: Optional[Tuple[float, float, float]]
    gated: bool

class Tracker:
    def __init__(
        self,
        scene: Scene,
        intrinsics: Union[Dict[str, Any], PathLike],
        enter_frames: int = ...,
        leave_frames: int = ...,
    ) -> None: ...
    @property
    def shape(self) -> Tuple[int, int]: ...
    def process(self, depth: npt.NDArray[np.uint16], t: Optional[float] = None) -> TrackResult: ...

class Device:
    def __init__(self, port: str, scene: Optional[Scene] = None) -> None: ...
    @property
    def port(self) -> str: ...
    def info(self) -> Dict[str, Any]: ...
    def status(self) -> Dict[str, Any]: ...
    def upload(
        self, plan: Plan, slot: Optional[int] = None, play: bool = True, untracked: bool = False
    ) -> Dict[str, Any]: ...
    def play(self, slot: int, untracked: bool = False) -> None: ...
    def stop(self) -> None: ...
    def centroid(self, x: float, y: float, z: float, present: bool = True) -> str: ...
    def tick(self) -> None: ...
    def close(self) -> None: ...
    def __enter__(self) -> Device: ...
    def __exit__(self, *exc: Any) -> None: ...

def find_binary() -> str: ...

class Session:
    ready: Optional[Dict[str, Any]]
    def __init__(
        self,
        library: Optional[PathLike] = None,
        port: Optional[str] = None,
        scene: Optional[PathLike] = None,
        socket_path: Optional[PathLike] = None,
        synthetic: bool = False,
        args: Sequence[str] = (),
        timeout: float = 30.0,
        tcp_port: Optional[int] = None,
        token: Optional[str] = None,
        token_file: Optional[PathLike] = None,
    ) -> None: ...
    def command(self, cmd: str, **fields: Any) -> Dict[str, Any]: ...
    def present(
        self,
        stimulus: str,
        gate: Optional[str] = None,
        on_s: Optional[float] = None,
        off_s: Optional[float] = None,
        repeat: Optional[int] = None,
    ) -> Dict[str, Any]: ...
    def prepare(self, stimulus: str) -> int: ...
    def stop(self) -> None: ...
    def status(self) -> Dict[str, Any]: ...
    def library(self) -> List[Dict[str, Any]]: ...
    def events(self, timeout: Optional[float] = None) -> Iterator[Dict[str, Any]]: ...
    def wait_for(self, event: str, timeout: float = 30.0, **match: Any) -> Dict[str, Any]: ...
    def close(self) -> None: ...
    def __enter__(self) -> Session: ...
    def __exit__(self, *exc: Any) -> None: ...

class Study:
    def __init__(
        self,
        protocol: PathLike,
        participant: str,
        out: PathLike,
        port: str,
        answer: Callable[[Dict[str, Any]], Any],
        scene: Optional[PathLike] = None,
        seed: Optional[int] = None,
        index: Optional[int] = None,
        finger: Optional[str] = None,
        time_scale: float = 1.0,
        resume: bool = False,
    ) -> None: ...
    def __iter__(self) -> Iterator[Dict[str, str]]: ...
    def __next__(self) -> Dict[str, str]: ...
    def run(self) -> List[Dict[str, str]]: ...
    @property
    def report(self) -> Optional[Dict[str, Any]]: ...
