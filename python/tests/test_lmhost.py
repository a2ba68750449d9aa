"""The binding against the real `lmhost` binary: same bytes, same numbers,
same error lines."""

import json
import math
import os
import socket
import subprocess
import threading
import time

import numpy as np
import pytest

import lmhost
from conftest import cli

PAPER = "scenes/paper.toml"


@pytest.mark.parametrize("scene", [None, PAPER])
@pytest.mark.parametrize("foci", [1, 4])
def test_plan_phases_equal_the_cli_byte_for_byte(lmhost_bin, root, tmp_path, scene, foci):
    out = tmp_path / "cli.npy"
    args = ["plan", "--foci", foci, "--out", out]
    if scene:
        args += ["--scene", root / scene]
    cli(lmhost_bin, *args)
    sc = lmhost.Scene.load(root / scene) if scene else lmhost.Scene.flat()
    p = lmhost.plan(foci=foci, scene=sc)
    mine = tmp_path / "py.npy"
    p.save(mine)
    assert mine.read_bytes() == out.read_bytes()
    cli_phases = np.load(out)
    assert p.phases.dtype == np.uint8
    assert p.phases.shape == (p.steps, sc.transducers[0].shape[0])
    assert np.array_equal(p.phases, cli_phases)
    assert p.foci_mm.shape == (p.steps, foci, 3)


@pytest.mark.parametrize("target", ["lm", "autd3"])
@pytest.mark.parametrize("ext", ["json", "bin"])
def test_plan_save_writes_what_plan_out_writes(lmhost_bin, root, tmp_path, target, ext):
    out = tmp_path / f"cli.{ext}"
    cli(lmhost_bin, "plan", "--scene", root / PAPER, "--foci", 4, "--target", target, "--out", out)
    mine = tmp_path / f"py.{ext}"
    lmhost.plan(foci=4, scene=lmhost.Scene.load(root / PAPER), target=target).save(mine)
    assert mine.read_bytes() == out.read_bytes()


@pytest.mark.parametrize("ext", ["json", "npy", "bin"])
def test_a_saved_plan_uploads_as_planned(lmhost_bin, tmp_path, ext):
    p = lmhost.plan(foci=4, radius=3, target="autd3")
    f = tmp_path / f"py.{ext}"
    p.save(f)
    # The JSON report carries its timing; .npy and .bin take --freq.
    timing = [] if ext == "json" else ["--freq", p.summary()["timing"]["freq_hz"]]
    r = cli(lmhost_bin, "upload", "--port", "autd3:emulator", "--phases", f, *timing, "--json")
    v = json.loads(r.stdout.splitlines()[0])
    assert (v["crc32"], v["readback_mismatches"]) == (p.crc32, 0)
    assert v["dwell_us"] == p.summary()["timing"]["dwell_us"]


def test_plan_summary_matches_cli_json(lmhost_bin, root):
    j = json.loads(cli(lmhost_bin, "plan", "--foci", 4, "--radius", 5, "--json").stdout)
    p = lmhost.plan(foci=4, radius=5)
    assert p.summary() == j
    assert p.steps == j["steps"]
    assert p.index_offset == j["index_offset"]
    assert p.step_mm == j["step_mm"]
    assert p.crc32 == j["crc32"]
    assert np.allclose(p.foci_mm, np.array(j["foci_mm"]))


def test_autd3_target_is_on_the_25_us_grid(lmhost_bin, tmp_path):
    out = tmp_path / "a.npy"
    cli(lmhost_bin, "plan", "--target", "autd3", "--radius", 5, "--out", out)
    p = lmhost.plan(radius=5, target="autd3")
    assert p.dwell_us % 25 == 0
    assert p.timing["divide"] * 25 == p.dwell_us
    assert np.array_equal(p.phases, np.load(out))


def test_scene_transducers():
    pos, nrm = lmhost.Scene.flat().transducers
    assert pos.shape == nrm.shape == (996, 3)
    assert np.allclose(np.linalg.norm(nrm, axis=1), 1.0)


def test_simulate_matches_the_cli_summary(lmhost_bin, tmp_path):
    out = tmp_path / "sim"
    cli(lmhost_bin, "simulate", "--plane-size", 6, "--plane-step", 0.5, "--out", out)
    f = lmhost.simulate(lmhost.plan(), plane_size=6, plane_step=0.5)
    want = json.loads((out / "summary.json").read_text())
    assert f.mean_pressure.shape == f.lm_power.shape == (len(f.v_mm), len(f.u_mm))
    assert np.allclose(f.mean_pressure, np.load(out / "mean_pressure.npy"))
    assert np.allclose(f.lm_power, np.load(out / "lm_power.npy"))
    assert f.summary["force"] == want["force"]
    assert f.force_n > 0


def test_simulate_carries_the_scenes_force_calibration(lmhost_bin, root, tmp_path):
    """`lmhost calibrate force` writes [calibration]; Python's simulate then
    gives the measured force for the static focus and the CLI's maps, and
    an explicit calibration replaces the scene's."""
    scene = tmp_path / "rig.toml"
    scene.write_text((root / PAPER).read_text())
    cli(lmhost_bin, "calibrate", "force", "--measured", 0.022, "--scene", scene, "--write")
    static = lmhost.plan(radius=0, scene=lmhost.Scene.load(scene))
    f = lmhost.simulate(static, plane_size=17, plane_step=0.25)
    assert abs(f.force_n - 0.022) < 1e-9
    assert f.summary["force"]["calibration_source"] == "scene"
    out = tmp_path / "sim"
    cli(lmhost_bin, "simulate", "--scene", scene, "--radius", 0, "--plane-size", 17,
        "--plane-step", 0.25, "--out", out)
    assert np.allclose(f.mean_pressure, np.load(out / "mean_pressure.npy"))
    raw = lmhost.simulate(static, plane_size=17, plane_step=0.25, calibration=1.0)
    k = f.summary["force"]["calibration"]
    assert 0 < k < 1 and abs(raw.force_n * k - 0.022) < 1e-9
    assert np.allclose(f.amplitude, raw.amplitude * k ** 0.5)


def test_tracker_equals_lmhost_track_json(lmhost_bin, root, tmp_path):
    rec = tmp_path / "rec.npy"
    cli(lmhost_bin, "track", "--synthetic", "--seconds", 1, "--record", rec,
        "--scene", root / PAPER, "--fast")
    lines = cli(lmhost_bin, "track", "--depth", rec, "--scene", root / PAPER,
                "--json", "--fast").stdout.splitlines()
    want = [json.loads(l) for l in lines if l.startswith("{")]
    frames = np.load(rec)
    times = np.load(rec.with_suffix(".timestamps.npy"))
    assert len(want) == len(frames) > 10
    tr = lmhost.Tracker(lmhost.Scene.load(root / PAPER), rec.with_suffix(".intrinsics.toml"))
    assert tr.shape == frames.shape[1:]
    seen = 0
    for frame, t, w in zip(frames, times, want):
        r = tr.process(frame, t=float(t))
        assert r.points == w["points"]
        assert r.present == w["present"]
        if w["centroid_mm"] is None:
            assert r.centroid_mm is None
        else:
            seen += 1
            assert r.centroid_mm == pytest.approx(w["centroid_mm"], abs=1e-9)
    assert seen > 0


def test_tracker_intrinsics_from_a_dict(root):
    intr = dict(width=64, height=48, fx=40.0, fy=40.0, ppx=32.0, ppy=24.0, depth_scale=0.001)
    tr = lmhost.Tracker(lmhost.Scene.load(root / PAPER), intr)
    r = tr.process(np.zeros((48, 64), np.uint16))
    assert (r.points, r.present, r.centroid_mm) == (0, False, None)


def test_tracker_intrinsics_file_read_as_the_cli_reads_it(root, tmp_path):
    # Windows tools write a byte-order mark and CRLF, PowerShell 5 UTF-16:
    # the file is read by the Rust core, as `lmhost track --intrinsics`.
    text = "width = 64\nheight = 48\nfx = 40.0\nfy = 40.0\nppx = 32.0\nppy = 24.0\ndepth_scale = 0.001\n"
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    tr = lmhost.Tracker(lmhost.Scene.load(root / PAPER), bom)
    assert tr.shape == (48, 64)
    wide = tmp_path / "wide.toml"
    wide.write_bytes(text.encode("utf-16"))
    with pytest.raises(ValueError, match=r"wide.toml: it is UTF-16 \(little-endian\) text, not UTF-8"):
        lmhost.Tracker(lmhost.Scene.load(root / PAPER), wide)
    with pytest.raises(ValueError, match="cannot read intrinsics .*missing.toml"):
        lmhost.Tracker(lmhost.Scene.load(root / PAPER), tmp_path / "missing.toml")


def test_device_emulator_upload_reads_back_clean():
    with lmhost.Device("autd3:emulator") as dev:
        assert dev.info()["backend"] == "autd3"
        r = dev.upload(lmhost.plan(radius=4, foci=4, target="autd3"), untracked=True)
        assert r["readback_mismatches"] == 0
        assert r["playing"] is True
        assert set(r) >= {"port", "slot", "crc32", "seconds", "payload_bytes", "frames", "wire"}
        assert dev.status()["state"] in ("Playing", "playing")
        assert dev.centroid(0.0, 0.0, 200.0) == "applied"
        dev.stop()


def test_upload_report_has_the_keys_of_upload_json(lmhost_bin):
    want = json.loads(cli(lmhost_bin, "upload", "--port", "autd3:emulator", "--json").stdout)
    with lmhost.Device("autd3:emulator") as dev:
        got = dev.upload(lmhost.plan(target="autd3"))
    assert set(got) == set(want)
    for k in ["crc32", "payload_bytes", "frames", "readback_mismatches", "steps", "dwell_us",
              "divide", "playing", "state", "mute_reason"]:
        assert got[k] == want[k], k


def test_session_by_its_socket_path(lmhost_bin, root, tmp_path):
    sock = tmp_path / "s.sock"
    proc = subprocess.Popen([str(lmhost_bin), "session", "--library",
                             str(root / "studies/paper-library.toml"), "--port", "autd3:emulator",
                             "--synthetic", "--control", str(sock)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        with lmhost.Session(socket_path=sock) as s:
            assert len(s.library()) == 15
            s.present("lmm-5hz-a4", gate="untracked")
            assert s.wait_for("onset")["stimulus"] == "lmm-5hz-a4"
            s.stop()
            assert s.wait_for("offset")["reason"] == "stop"
        assert proc.poll() is None  # a session it did not start keeps serving
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_session_over_tcp_needs_its_token(lmhost_bin, root, tmp_path):
    sock = tmp_path / "t.sock"
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    proc = subprocess.Popen([str(lmhost_bin), "session", "--library",
                             str(root / "studies/paper-library.toml"), "--port", "autd3:emulator",
                             "--control", str(sock), "--tcp", str(port)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        with lmhost.Session(socket_path=sock, tcp_port=port) as s:
            assert len(s.library()) == 15
        assert (os.stat(str(sock) + ".token").st_mode & 0o777) == 0o600
        # Without the token: one refusal, then the connection is closed.
        with socket.create_connection(("127.0.0.1", port), timeout=10) as c:
            c.sendall(b'{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked"}\n')
            reply = json.loads(c.makefile().readline())
            assert reply["ok"] is False and "token" in reply["error"]
            assert c.recv(1) == b""
        with pytest.raises(ValueError, match="authentication"):
            lmhost.Session(tcp_port=port, token="0" * 32)
        with lmhost.Session(socket_path=sock) as s:
            assert s.status()["state"] != "playing"
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_device_refuses_a_plan_for_another_target():
    with lmhost.Device("autd3:emulator") as dev:
        with pytest.raises(ValueError, match="target"):
            dev.upload(lmhost.plan())


def test_device_error_is_an_oserror():
    assert issubclass(lmhost.DeviceError, OSError)
    with pytest.raises(lmhost.DeviceError):
        lmhost.Device("/nonexistent/tty-lmhost")


BAD_PLANS = [
    dict(radius=-1),
    dict(radius=math.nan),
    dict(radius=1e30),
    dict(foci=0),
    dict(freq=0),
    dict(steps=0),
    dict(intensity=2),
    dict(center=(0, 0, math.inf)),
    dict(target="nope"),
]


@pytest.mark.parametrize("kw", BAD_PLANS, ids=lambda kw: ",".join(f"{k}={v}" for k, v in kw.items()))
def test_bad_plan_inputs_raise_value_error(kw):
    with pytest.raises(ValueError):
        lmhost.plan(**kw)


@pytest.mark.parametrize("flag,kw", [
    (["--radius", "-1"], dict(radius=-1)),
    (["--radius", "1e30", "--steps", "4"], dict(radius=1e30, steps=4)),
    (["--foci", "0"], dict(foci=0)),
    (["--intensity", "2"], dict(intensity=2)),
])
def test_value_error_says_what_the_cli_says(lmhost_bin, flag, kw):
    r = cli(lmhost_bin, "plan", *flag, check=False)
    assert r.returncode == 2
    with pytest.raises(ValueError) as e:
        lmhost.plan(**kw)
    assert str(e.value) in r.stderr


def test_bad_scene_and_port_and_simulate_inputs(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("this is = not a scene\n")
    for call in [
        lambda: lmhost.Scene.load(bad),
        lambda: lmhost.Scene.load(tmp_path / "missing.toml"),
        lambda: lmhost.Device("autd3:nonsense"),
        lambda: lmhost.Device("TCP:127.0.0.1:1"),
        lambda: lmhost.simulate(lmhost.plan(), plane_step=0),
        lambda: lmhost.simulate(lmhost.plan(), disk=math.nan),
        lambda: lmhost.simulate(lmhost.plan(intensity=0.5)),
    ]:
        with pytest.raises(ValueError):
            call()


def test_bad_depth_frames_raise_value_error(root):
    intr = dict(width=64, height=48, fx=40.0, fy=40.0, ppx=32.0, ppy=24.0, depth_scale=0.001)
    tr = lmhost.Tracker(lmhost.Scene.load(root / PAPER), intr)
    for frame in [
        np.zeros((48, 63), np.uint16),
        np.zeros((48, 64), np.float32),
        np.zeros((48, 64), np.int32),
        np.zeros((2, 48, 64), np.uint16),
        [[0] * 64] * 48,
    ]:
        with pytest.raises(ValueError):
            tr.process(frame)
    with pytest.raises(ValueError):
        tr.process(np.zeros((48, 64), np.uint16), t=math.nan)
    for bad in [dict(intr, width=0), dict(intr, fx="x"), dict(intr, depth_scale=-1), {}]:
        with pytest.raises(ValueError):
            lmhost.Tracker(lmhost.Scene.load(root / PAPER), bad)
    with pytest.raises(ValueError):
        lmhost.Tracker(lmhost.Scene.flat(), intr)  # no [camera]: cannot place the box


def test_session_against_the_emulator(lmhost_bin, root):
    with lmhost.Session(library=root / "studies/paper-library.toml", port="autd3:emulator",
                        synthetic=True) as s:
        ids = [e["id"] for e in s.library()]
        assert "lms-5hz-a3" in ids
        s.prepare("lms-5hz-a3")
        s.present("lms-5hz-a3", gate="untracked", on_s=0.3)
        onset = s.wait_for("onset", stimulus="lms-5hz-a3")
        assert onset["gate"] == "untracked"
        off = s.wait_for("offset", timeout=10)
        assert off["reason"] == "timer"
        assert s.status()["phase"] in (None, "on", "off", "switching")
        with pytest.raises(ValueError):
            s.present("no-such-stimulus")
        s.stop()


def test_a_panic_is_an_exception_not_a_crash():
    with pytest.raises(RuntimeError, match="internal error: a panic inside lmhost"):
        lmhost._lmhost._panic_for_test()
    assert lmhost.plan().steps == 82  # the interpreter carries on


def test_long_calls_release_the_gil():
    done = threading.Event()
    ticks = 0

    def work():
        lmhost.simulate(lmhost.plan(foci=4), plane_size=4, plane_step=0.4)
        done.set()

    t = threading.Thread(target=work)
    t0 = time.perf_counter()
    t.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    took = time.perf_counter() - t0
    # Python ran beside the call: about one tick per millisecond it took.
    assert ticks > 0.3 * took * 1000, (ticks, took)
