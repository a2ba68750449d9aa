"""The package's checks of arguments the extension does not take itself:
strings, paths, lists of strings and timeouts. Each refuses a value of the
wrong kind with one line naming the argument (ValueError, as every other
bad argument), never turns it into text with ``str()``: ``str(None)`` is
the participant ``"None"``, ``str(3)`` the serial port ``3``, and a
``bytes`` path its ``repr``, each then taken or refused as something it
never was."""

from __future__ import annotations

import operator
import os
from typing import Any, List, Optional

from . import _lmhost

#: The longest wait a timeout may ask for (s): longer is a hang, and the
#: socket's own conversion overflows (OverflowError) near 1e10 s.
MAX_TIMEOUT_S = 86_400.0


def timeout_s(name: str, value: Any) -> float:
    """A timeout in seconds: a finite number above 0 and at most a day."""
    t = _lmhost.float_arg(name, value)
    if not 0 < t <= MAX_TIMEOUT_S:
        raise ValueError(
            f"{name} {t} s is out of range: give a number above 0 and at most {MAX_TIMEOUT_S:g} s"
        )
    return t


def whole(name: str, value: Any) -> int:
    """An integer sent for its receiver to judge (a session command's
    ``repeat``): a Python or numpy integer as it is, however large, so the
    refusal names the receiver's range (``allowed 1..=10000``), not the
    width of a type in between; a bool, a float or anything else refused
    here by name."""
    if not isinstance(value, bool):
        try:
            return operator.index(value)
        except TypeError:
            pass
    raise ValueError(f"{name} must be an integer, got {shown(value)}")


#: A value as a message repeats it: its repr on one line, cut at 40
#: characters (a numpy array's rows joined, a long list not echoed whole),
#: the extension's own rule, so every message shows values alike.
shown = _lmhost.shown


def _kind(value: Any) -> str:
    return "None" if value is None else type(value).__name__


def text(name: str, value: Any, what: str) -> str:
    """``value`` if it is a ``str``; else ValueError naming ``name`` and
    saying it must be ``what`` (a string)."""
    if not isinstance(value, str):
        raise ValueError(f"{name} must be {what} (a string), got {_kind(value)}")
    return value


def opt_text(name: str, value: Any, what: str) -> Optional[str]:
    """As :func:`text`, None passed on (the argument left alone)."""
    return None if value is None else text(name, value, what)


def path(name: str, value: Any) -> str:
    """A path: a ``str`` or an ``os.PathLike`` naming a ``str`` (a
    ``pathlib.Path``), not empty; bytes and every other kind refused by
    name."""
    if isinstance(value, os.PathLike) and not isinstance(value, (bytes, bytearray)):
        try:
            value = os.fspath(value)
        except TypeError:
            pass
    if not isinstance(value, str):
        raise ValueError(f"{name} must be a path (a str or pathlib.Path), got {_kind(value)}")
    if not value:
        # The CLI refuses an empty path flag; "" is no file, and a folder
        # "" is the working directory (a study wrote there).
        raise ValueError(f"{name} must be a path, got an empty string")
    return value


def opt_path(name: str, value: Any) -> Optional[str]:
    """As :func:`path`, None passed on."""
    return None if value is None else path(name, value)


def texts(name: str, value: Any) -> List[str]:
    """A list or tuple of strings (a string alone is refused: it would be
    taken as its characters)."""
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{name} must be a list of strings, got {_kind(value)}")
    for i, v in enumerate(value):
        if not isinstance(v, str):
            raise ValueError(f"{name}[{i}] must be a string, got {_kind(v)}")
    return list(value)


#: The session's limits on a control line's values (``id_chars``,
#: ``token_chars``, ``line_bytes``), from the library.
CONTROL = _lmhost.CONTROL_LIMITS

#: What each string field of a control line is, and its most characters:
#: checked before the line is built, so a value too long is refused by
#: its own limit, not as a line longer than the session reads.
_FIELDS = {
    "stimulus": ("a library entry's id", CONTROL["id_chars"], "letters, digits, -, _ and ."),
    "token": ("a session's token", CONTROL["token_chars"], "hex digits, from the file SOCKET.token"),
}

#: The longest command name or field name sent (the longest the session
#: knows, ``subscribe``, has 9).
MAX_NAME_CHARS = 32

#: The gates a ``present`` takes.
GATES = ("tracked", "untracked")


def control_text(name: str, value: Any) -> str:
    """A string field of a session command, checked by kind and length in
    its own words (``stimulus: 5000 characters, more than 64: a library
    entry's id is at most 64 characters``) before its line is built."""
    if name == "gate":
        # The kind first: `in` would compare a numpy array element-wise.
        if not isinstance(value, str) or value not in GATES:
            got = shown(value) if isinstance(value, str) else _kind(value)
            raise ValueError(f'gate must be "tracked" or "untracked", got {got}')
        return value
    what, most, made = _FIELDS.get(name, ("a command's value", CONTROL["line_bytes"] // 2, "text"))
    value = text(name, value, what)
    n = len(value)
    if n > most:
        raise ValueError(f"{name}: {n} characters, more than {most}: {what} is at most {most} characters ({made})")
    return value


def command_name(name: str, value: Any) -> str:
    """A command's name or a field's, a string of at most
    :data:`MAX_NAME_CHARS` characters (the session says which it knows)."""
    if not isinstance(value, str):
        raise ValueError(f"{name} must be a command's name (a string), got {_kind(value)}")
    if len(value) > MAX_NAME_CHARS:
        raise ValueError(
            f"{name}: {len(value)} characters, more than {MAX_NAME_CHARS}: "
            f"a command's name or field is a word such as present or stimulus"
        )
    return value
