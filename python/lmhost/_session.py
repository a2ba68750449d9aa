"""A client of ``lmhost session``'s control socket (:class:`Session`) and
the ``lmhost`` binary it starts (:func:`find_binary`)."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, Iterator, Optional, Sequence, Union

from . import _args, _lmhost
from ._lmhost import DeviceError

PathLike = Union[str, "os.PathLike[str]"]


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
        timeout = _args.timeout_s("timeout", timeout)
        library = _args.opt_path("library", library)
        port = _args.opt_text("port", port, "a --port name")
        scene = _args.opt_path("scene", scene)
        socket_path = _args.opt_path("socket_path", socket_path)
        token_file = _args.opt_path("token_file", token_file)
        args = _args.texts("args", args)
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
        if token is not None:
            token = _args.control_text("token", token)
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
                library,
                "--control",
                socket_path,
                "--exit-with-stdin",
            ]
            if port is not None:
                cmd += ["--port", port]
            if scene is not None:
                cmd += ["--scene", scene]
            if _lmhost.bool_arg("synthetic", synthetic):
                cmd.append("--synthetic")
            if tcp_port is not None:
                cmd += ["--tcp", str(tcp_port)]
            cmd += args
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
            self._sock = self._connect(socket_path, timeout)
            self._sock.settimeout(timeout)
        else:
            if token_file is None and token is None:
                if socket_path is None:
                    raise ValueError("Session over TCP needs token=, token_file= or socket_path=")
                token_file = socket_path + ".token"
            self._sock = self._connect_tcp(tcp_port, timeout)
            self._sock.settimeout(timeout)
            if token is None:
                token = self._read_token(token_file, timeout)
                if len(token) > _args.CONTROL["token_chars"]:
                    raise ValueError(
                        f"token_file {token_file}: {len(token)} characters, more than "
                        f"{_args.CONTROL['token_chars']}: a session's token file holds its token alone"
                    )
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
                # A bounded read: a token file is one short line, and a
                # path given by mistake may be any file.
                with open(path, "rb") as f:
                    head = f.read(_args.CONTROL["line_bytes"] + 1)
                return head.decode(errors="replace").strip()
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
        :meth:`events`. Returns the reply; ``ok: false`` raises ValueError.

        A field given as None is absent: it is left out of the line, so the
        session takes its default (``command("present", stimulus=s,
        on_s=None)`` plays until stopped), as a None of :meth:`present` and
        of :func:`lmhost.plan` is the default."""
        msg: Dict[str, Any] = {"cmd": _args.command_name("cmd", cmd)}
        for k, v in fields.items():
            _args.command_name("field name", k)
            if isinstance(v, str) or (v is not None and k in ("stimulus", "gate", "token")):
                # By its own kind and limit, before the line is built.
                v = _args.control_text(k, v)
            elif v is None or isinstance(v, bool):
                pass
            elif hasattr(type(v), "__index__"):
                # An int (numpy's too) as it is: the session judges it.
                v = _args.whole(k, v)
            elif isinstance(v, float) or hasattr(type(v), "__float__"):
                v = _lmhost.float_arg(k, v)  # no NaN or infinity on the wire
            else:
                # No field of the protocol is a list or an object: one is
                # refused here by its name, never sent for the session to
                # refuse, nor failing in the JSON encoder ("cannot send
                # Object of type PosixPath", a NaN inside a list).
                raise ValueError(
                    f"{k} must be a string, a number, True, False or None, got {_args.shown(v)}"
                )
            if v is not None:
                msg[k] = v
        try:
            line = json.dumps(msg, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{cmd}: cannot send {e}") from None
        most = _args.CONTROL["line_bytes"]
        if len(line.encode()) > most:
            # Only values no field limit covers get here (escapes that
            # lengthen a string, a number of thousands of digits).
            raise ValueError(
                f"{cmd}: its values make a line of {len(line.encode())} bytes, more than the {most} a session reads"
            )
        self._open_sock().sendall((line + "\n").encode())
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
            stimulus=_args.control_text("stimulus", stimulus),
            gate=None if gate is None else _args.control_text("gate", gate),
            on_s=None if on_s is None else _lmhost.float_arg("on_s", on_s),
            off_s=None if off_s is None else _lmhost.float_arg("off_s", off_s),
            repeat=None if repeat is None else _lmhost.repeat_arg(repeat),
        )

    def prepare(self, stimulus: str) -> int:
        """Load an entry into an idle slot; returns the slot."""
        return self.command("prepare", stimulus=_args.control_text("stimulus", stimulus))["slot"]

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
            timeout = _args.timeout_s("timeout", timeout)
        while True:
            while self._events:
                ev = self._events.pop(0)
                yield ev
                if ev.get("event") == "closed":
                    return
            old = self._open_sock().gettimeout()
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
        timeout = _args.timeout_s("timeout", timeout)
        deadline = time.monotonic() + timeout
        for ev in self.events(timeout=timeout):
            if ev.get("event") == event and all(ev.get(k) == v for k, v in match.items()):
                return ev
            if time.monotonic() > deadline:
                break
        raise DeviceError(f"no `{event}` event within {timeout} s")

    def _open_sock(self) -> socket.socket:
        """The connection, or DeviceError once closed (as a closed
        :class:`Device` says), never the socket's own "Bad file
        descriptor"."""
        if self._sock is None or self._sock.fileno() < 0:
            raise DeviceError("this Session is closed")
        return self._sock

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
