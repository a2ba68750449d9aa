"""Python overhead per call against the same work in Rust, in one run.

    cargo build --release -p lmhost
    (cd python && maturin develop --release)      # in a venv with numpy
    LMHOST_BIN=target/release/lmhost python python/bench.py

The frame is the busiest of a 1 s synthetic-finger recording made with
`lmhost track --synthetic --record` (a flat frame without the binary).

Rust figures come from `lmhost._lmhost._bench_rust`, which times the same
library calls (`Stimulus::plan_for`, `track::Pipeline::step`) in a loop
inside the extension: no Python between the calls.
"""

import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import lmhost
from lmhost import _lmhost

ROOT = Path(__file__).resolve().parents[1]
INTRINSICS = dict(width=848, height=480, fx=426.0, fy=426.0, ppx=423.5, ppy=239.5,
                  depth_scale=0.0001)


def best(f, repeats):
    b = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        b = min(b, time.perf_counter() - t0)
    return b


def main():
    scene = lmhost.Scene.load(ROOT / "scenes" / "paper.toml")
    frame = np.full((480, 848), 3000, np.uint16)
    try:
        binary = lmhost.find_binary()
    except lmhost.DeviceError:
        binary = None
    if binary:
        with tempfile.TemporaryDirectory() as d:
            rec = Path(d) / "rec.npy"
            subprocess.run([binary, "track", "--synthetic", "--seconds", "1", "--fast",
                            "--record", str(rec), "--scene", str(ROOT / "scenes" / "paper.toml")],
                           check=True, capture_output=True)
            frames = np.load(rec)
        probe = lmhost.Tracker(scene, INTRINSICS)
        frame = max(frames, key=lambda f: probe.process(f).points).copy()
    points = lmhost.Tracker(scene, INTRINSICS).process(frame).points
    toml = "".join(f"{k} = {v}\n" for k, v in INTRINSICS.items())
    repeats = 200
    for _ in range(3):  # warm up caches and the allocator
        _lmhost._bench_rust(scene, toml, frame, 5)
    flat = lmhost.Scene.flat()
    tr = lmhost.Tracker(scene, INTRINSICS)
    t = [0.0]

    def step():
        t[0] += 1 / 90
        tr.process(frame, t=t[0])

    # Interleaved rounds, best of each: a busy machine slows both alike.
    rust_plan = rust_track = py_plan = py_track = float("inf")
    for _ in range(5):
        rp, rt = _lmhost._bench_rust(scene, toml, frame, repeats // 5)
        rust_plan, rust_track = min(rust_plan, rp), min(rust_track, rt)
        py_plan = min(py_plan, best(lambda: lmhost.plan(radius=3.0, foci=4, scene=flat),
                                    repeats // 5))
        py_track = min(py_track, best(step, repeats))
    print(f"plan LM-M A=3 mm (flat 2x2, 82 steps x 996): rust {rust_plan*1e6:9.1f} us  "
          f"python {py_plan*1e6:9.1f} us  overhead {100*(py_plan-rust_plan)/rust_plan:+.1f} %")
    print(f"Tracker.process 848x480 ({points} points):    rust {rust_track*1e6:9.1f} us  "
          f"python {py_track*1e6:9.1f} us  overhead {(py_track-rust_track)*1e6:+.1f} us/frame")


if __name__ == "__main__":
    main()
