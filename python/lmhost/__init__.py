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
parameter a finite number, else :class:`ValueError` naming it.
Units are in the names: ``_mm``, ``_us``, ``_hz``. The keyword defaults
are the library's (:data:`DEFAULTS`, the values ``lmhost plan`` and
``lmhost simulate`` use without flags).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lmhost
from ._lmhost import DeviceError, Scene

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

# The widest integer the checks take where the receiver judges the range.
_I64 = (-(2**63), 2**63 - 1)

#: The longest wait a timeout may ask for (s): longer is a hang, and the
#: socket's own conversion overflows (OverflowError) near 1e10 s.
_MAX_TIMEOUT_S = 86_400.0


def _timeout_s(name: str, value: Any) -> float:
    """A timeout in seconds: a finite number above 0 and at most a day."""
    t = _lmhost.float_arg(name, value)
    if not 0 < t <= _MAX_TIMEOUT_S:
        raise ValueError(
            f"{name} {t} s is out of range: give a number above 0 and at most {_MAX_TIMEOUT_S:g} s"
        )
    return t


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


def _intrinsics_toml(intrinsics: Union[Dict[str, Any], PathLike]) -> Tuple[Optional[str], str]:
    """TOML text of a dict, or (None, the path): a file is read by the Rust
    core as ``lmhost track --intrinsics`` reads it (a byte-order mark and
    CRLF skipped, UTF-16 refused), never in the platform's encoding."""
    if isinstance(intrinsics, dict):
        lines = []
        for k, v in intrinsics.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f"intrinsics dict: `{k}` must be a number, got {v!r}")
            lines.append(f"{k} = {v}")
        return "\n".join(lines) + "\n", "dict"
    return None, str(Path(intrinsics))


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
        (default: seconds since the tracker was made)."""
        return TrackResult(*self._t.process(depth, t))


class Device:
    """A device by its ``--port`` name: a serial/pty path, ``tcp:HOST:PORT``,
    or an AUTD3 (``autd3:emulator``, ``autd3:soem[:IF]``, ...).

    Use it as a context manager; closing an AUTD3 leaves it silent. Any
    thread may call it (the device lives on a thread of its own; calls
    from several threads run one at a time).
    """

    def __init__(self, port: str, scene: Optional[Scene] = None) -> None:
        self._d = _lmhost.Device(str(port), scene)

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


def find_binary() -> str:
    """The ``lmhost`` binary: ``$LMHOST_BIN``, else ``lmhost`` on ``PATH``."""
    env = os.environ.get("LMHOST_BIN")
    if env:
        if not os.access(env, os.X_OK):
            raise DeviceError(f"LMHOST_BIN={env} is not an executable")
        return env
    found = shutil.which("lmhost")
    if found is None:
        raise DeviceError(
            "cannot find the lmhost binary: set LMHOST_BIN or put lmhost on PATH "
            "(`cargo build --release -p lmhost` builds target/release/lmhost)"
        )
    return found


class Session:
    """A client of ``lmhost session``'s control socket (JSON lines).

    Either connect to a running session (``socket_path=``, or
    ``tcp_port=`` for one started with ``--tcp``), or start one:
    ``Session(library="studies/paper-library.toml", port="autd3:emulator",
    synthetic=True)`` runs ``lmhost session`` (found by :func:`find_binary`)
    with a private control socket and quits it on :meth:`close`; if this
    process dies first, however (``kill -9`` too), that session ends with
    it and leaves the array silent (``lmhost session --exit-with-stdin``).
    Over TCP the client first sends the session's token: ``token=``, or
    read from ``token_file=`` (default: ``SOCKET.token`` beside
    ``socket_path``, a file only the session's user can read).
    Every command returns the reply dict; a refused one raises ValueError.
    """

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
    ) -> None:
        self._proc: Optional[subprocess.Popen] = None
        self._tmp: Optional[tempfile.TemporaryDirectory] = None
        self._events: list = []
        self._buf = b""
        self._sock: Optional[socket.socket] = None
        self.ready: Optional[Dict[str, Any]] = None
        timeout = _timeout_s("timeout", timeout)
        # What starts a session applies only when one is started (library=
        # without socket_path=): never dropped unseen on a session joined.
        starts = library is not None and socket_path is None
        if library is not None and socket_path is not None:
            raise ValueError(
                "library= starts a session on a socket of its own: give library= or socket_path=, not both"
            )
        given = [n for n, v in (("port", port), ("scene", scene)) if v is not None]
        given += ["synthetic"] if _lmhost.bool_arg("synthetic", synthetic) else []
        given += ["args"] if len(args) else []
        if given and not starts:
            raise ValueError(
                f"{'= and '.join(given)}= apply to a session started here: give library= too"
            )
        if tcp_port is not None:
            tcp_port = _lmhost.int_arg("tcp_port", tcp_port, 1, 65535)
        elif token is not None or token_file is not None:
            # Only a TCP client sends a token: not a value to drop unseen.
            raise ValueError("token= and token_file= are for a TCP session: give tcp_port= too")
        if token is not None and not isinstance(token, str):
            raise ValueError(f"token must be a string, got {type(token).__name__}")
        if socket_path is None and library is None and tcp_port is None:
            raise ValueError("Session needs library= (to start one), socket_path= or tcp_port=")
        if socket_path is None and library is not None:
            self._tmp = tempfile.TemporaryDirectory(prefix="lmhost-session-")
            socket_path = os.path.join(self._tmp.name, "control.sock")
            # --exit-with-stdin and a pipe on its stdin that only this
            # process holds (non-inheritable, never written): when this
            # process dies, however (kill -9 too), the kernel closes it,
            # the session sees the end and stops, leaving the array silent.
            # PR_SET_PDEATHSIG would need a pre-exec hook (unsafe beside
            # threads), is Linux-only, and fires when the starting *thread*
            # ends, which would end a Session made in a worker thread.
            cmd = [
                find_binary(),
                "session",
                "--library",
                str(library),
                "--control",
                str(socket_path),
                "--exit-with-stdin",
            ]
            if port is not None:
                cmd += ["--port", str(port)]
            if scene is not None:
                cmd += ["--scene", str(scene)]
            if _lmhost.bool_arg("synthetic", synthetic):
                cmd.append("--synthetic")
            if tcp_port is not None:
                cmd += ["--tcp", str(tcp_port)]
            cmd += list(args)
            self._stderr = tempfile.TemporaryFile()
            self._proc = subprocess.Popen(
                cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._stderr
            )
        try:
            self._open(socket_path, timeout, tcp_port, token, token_file)
        except BaseException:
            if self._sock is not None:
                self._sock.close()
            self._end_child()
            raise

    def _open(self, socket_path, timeout, tcp_port, token, token_file) -> None:
        if tcp_port is None:
            self._sock = self._connect(str(socket_path), timeout)
            self._sock.settimeout(timeout)
        else:
            if token_file is None and token is None:
                if socket_path is None:
                    raise ValueError("Session over TCP needs token=, token_file= or socket_path=")
                token_file = str(socket_path) + ".token"
            self._sock = self._connect_tcp(tcp_port, timeout)
            self._sock.settimeout(timeout)
            if token is None:
                token = self._read_token(str(token_file), timeout)
            self.command("auth", token=token)
        self.command("subscribe")

    def _connect(self, path: str, timeout: float) -> socket.socket:
        deadline = time.monotonic() + timeout
        while True:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                s.connect(path)
                return s
            except OSError:
                s.close()
                if self._proc is not None and self._proc.poll() is not None:
                    raise self._died() from None
                if time.monotonic() > deadline:
                    raise DeviceError(f"no lmhost session answers on {path}") from None
                time.sleep(0.05)

    def _connect_tcp(self, port: int, timeout: float) -> socket.socket:
        deadline = time.monotonic() + timeout
        while True:
            try:
                return socket.create_connection(("127.0.0.1", port), timeout=timeout)
            except OSError:
                if self._proc is not None and self._proc.poll() is not None:
                    raise self._died() from None
                if time.monotonic() > deadline:
                    raise DeviceError(f"no lmhost session answers on 127.0.0.1:{port}") from None
                time.sleep(0.05)

    def _read_token(self, path: str, timeout: float) -> str:
        # A session that is starting writes it before it listens.
        deadline = time.monotonic() + timeout
        while True:
            try:
                return Path(path).read_text().strip()
            except FileNotFoundError:
                if time.monotonic() > deadline:
                    raise DeviceError(f"no session token in {path}") from None
                time.sleep(0.05)

    def _died(self) -> Exception:
        assert self._proc is not None
        self._stderr.seek(0)
        err = self._stderr.read().decode(errors="replace").strip().splitlines()
        line = err[-1] if err else f"exit code {self._proc.returncode}"
        if line.startswith("error: "):
            line = line[len("error: "):]
        return (ValueError if self._proc.returncode == 2 else DeviceError)(line)

    def _line(self) -> Dict[str, Any]:
        while b"\n" not in self._buf:
            try:
                chunk = self._sock.recv(65536)
            except socket.timeout:
                raise DeviceError("the lmhost session did not answer in time") from None
            if not chunk:
                if self._proc is not None and self._proc.poll() is not None:
                    raise self._died()
                raise DeviceError("the lmhost session closed the connection")
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return json.loads(line)

    def command(self, cmd: str, **fields: Any) -> Dict[str, Any]:
        """Send one command; events that arrive meanwhile are kept for
        :meth:`events`. Returns the reply; ``ok: false`` raises ValueError."""
        if not isinstance(cmd, str):
            raise ValueError(f"cmd must be a command's name (a string), got {type(cmd).__name__}")
        msg: Dict[str, Any] = {"cmd": cmd}
        for k, v in fields.items():
            if v is None or isinstance(v, (bool, str)):
                pass
            elif isinstance(v, float):
                v = _lmhost.float_arg(k, v)  # no NaN or infinity on the wire
            elif isinstance(v, int):
                v = _lmhost.int_arg(k, v, *_I64)
            if v is not None:
                msg[k] = v
        try:
            line = json.dumps(msg, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{cmd}: cannot send {e}") from None
        self._sock.sendall((line + "\n").encode())
        while True:
            v = self._line()
            if "event" in v:
                self._note(v)
                continue
            if not v.get("ok"):
                raise ValueError(v.get("error", "refused"))
            return v

    def _note(self, ev: Dict[str, Any]) -> None:
        if ev.get("event") == "ready":
            self.ready = ev
        self._events.append(ev)

    def present(
        self,
        stimulus: str,
        gate: Optional[str] = None,
        on_s: Optional[float] = None,
        off_s: Optional[float] = None,
        repeat: Optional[int] = None,
    ) -> Dict[str, Any]:
        """Present a library entry (``gate``: "tracked" or "untracked")."""
        return self.command(
            "present",
            stimulus=stimulus,
            gate=gate,
            on_s=None if on_s is None else _lmhost.float_arg("on_s", on_s),
            off_s=None if off_s is None else _lmhost.float_arg("off_s", off_s),
            repeat=None if repeat is None else _lmhost.int_arg("repeat", repeat, *_I64),
        )

    def prepare(self, stimulus: str) -> int:
        """Load an entry into an idle slot; returns the slot."""
        return self.command("prepare", stimulus=stimulus)["slot"]

    def stop(self) -> None:
        """Stop what plays or waits: the array is silent."""
        self.command("stop")

    def status(self) -> Dict[str, Any]:
        """The session's and the device's state."""
        return self.command("status")["status"]

    def library(self) -> list:
        """The entries as planned for this device."""
        return self.command("library")["stimuli"]

    def events(self, timeout: Optional[float] = None) -> Iterator[Dict[str, Any]]:
        """Events as they come (the ones already received first); ends after
        ``timeout`` seconds without one, or at ``closed``."""
        if timeout is not None:
            timeout = _timeout_s("timeout", timeout)
        while True:
            while self._events:
                ev = self._events.pop(0)
                yield ev
                if ev.get("event") == "closed":
                    return
            old = self._sock.gettimeout()
            self._sock.settimeout(timeout)
            try:
                v = self._line()
            except DeviceError:
                return
            finally:
                self._sock.settimeout(old)
            if "event" in v:
                self._note(v)

    def wait_for(self, event: str, timeout: float = 30.0, **match: Any) -> Dict[str, Any]:
        """The next event named ``event`` (with fields equal to ``match``)."""
        timeout = _timeout_s("timeout", timeout)
        deadline = time.monotonic() + timeout
        for ev in self.events(timeout=timeout):
            if ev.get("event") == event and all(ev.get(k) == v for k, v in match.items()):
                return ev
            if time.monotonic() > deadline:
                break
        raise DeviceError(f"no `{event}` event within {timeout} s")

    def close(self) -> None:
        """Quit a session this object started (the array is left silent);
        just disconnect from one it did not."""
        try:
            if self._proc is not None and self._proc.poll() is None:
                try:
                    self.command("quit")
                except (OSError, ValueError):
                    pass
        finally:
            self._sock.close()
            self._end_child()

    def _end_child(self) -> None:
        """Ends the session this object started, if any: its stdin closed
        (it ends at that), then waited for; SIGTERM (it still ends silent)
        if it does not."""
        if self._proc is not None:
            if self._proc.stdin is not None:
                self._proc.stdin.close()
            try:
                self._proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._proc.terminate()
                self._proc.wait()
            self._proc = None
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def __enter__(self) -> "Session":
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
            raise ValueError(f"answer must be callable, got {answer!r}")
        if seed is not None:
            seed = _lmhost.int_arg("seed", seed, 0, 2**63 - 1)
        if index is not None:
            index = _lmhost.int_arg("index", index, 1, 2**31 - 1)
        self._s = _lmhost.Study(
            os.fspath(protocol),
            str(participant),
            os.fspath(out),
            str(port),
            answer,
            scene=None if scene is None else os.fspath(scene),
            seed=seed,
            index=index,
            finger=finger,
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
