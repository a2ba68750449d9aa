"""The Python snippets of README.md and python/README.md, run as written
(in a folder holding the repository's `scenes/` and `studies/`), so a
renamed keyword or attribute in a document fails here."""

import os
import re
import subprocess
import time

import pytest


def snippets(path):
    """The ```python blocks of a document, in order."""
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), re.S | re.M)


@pytest.fixture
def folder(root, tmp_path, monkeypatch):
    for d in ("scenes", "studies"):
        os.symlink(root / d, tmp_path / d)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_python_readme_snippet(root, folder, capsys):
    (code,) = snippets(root / "python" / "README.md")
    ns = {}
    exec(compile(code, "python/README.md", "exec"), ns)
    # The comment quotes the shape: (82, 996).
    assert ns["lmm"].phases.shape == (82, 996)
    assert ns["field"].force_n > 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith("(82, 996) 2439.02")
    assert printed[-1] == "0", "readback_mismatches"


def test_readme_library_snippet(root, folder):
    code = snippets(root / "README.md")[0]
    ns = {}
    exec(compile(code, "README.md", "exec"), ns)
    # The comment quotes ((82, 996), 2439.02...).
    assert ns["lmm"].phases.shape == (82, 996)
    assert abs(ns["lmm"].dwell_us - 2439.02) < 0.01
    assert (folder / "lmm.npy").stat().st_size > 82 * 996


def test_readme_session_client(root, folder, lmhost_bin, capsys):
    """The ten-line client against the README's own session command."""
    code = snippets(root / "README.md")[1]
    sock = str(folder / "lm.sock")
    assert "/tmp/lm.sock" in code
    code = code.replace("/tmp/lm.sock", sock)
    session = subprocess.Popen(
        [str(lmhost_bin), "session", "--library", "studies/paper-library.toml",
         "--port", "autd3:emulator", "--control", sock, "--events", "events.jsonl",
         "--synthetic"],
        stderr=subprocess.PIPE, text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while not os.path.exists(sock):
            assert session.poll() is None, session.stderr.read()
            assert time.monotonic() < deadline, "no control socket"
            time.sleep(0.1)
        exec(compile(code, "README.md", "exec"), {})
        assert session.wait(timeout=30) == 0
    finally:
        if session.poll() is None:
            session.kill()
            session.wait()
    out = capsys.readouterr().out
    assert "'cmd': 'present', 'ok': True" in out
    assert out.count("'event': 'onset'") == 3 and out.count("'event': 'offset'") == 3
