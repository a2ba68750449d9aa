"""A live tracker loop on recorded depth frames: each frame through
`lmhost.Tracker` at its recorded time stamp, paced like the camera, the
centroid streamed to a device while a finger is present.

    lmhost track --synthetic --seconds 3 --record rec.npy --scene scenes/paper.toml
    python python/examples/track_live.py rec.npy scenes/paper.toml [--port autd3:emulator]
"""

import argparse
import time
from pathlib import Path

import numpy as np

import lmhost

p = argparse.ArgumentParser()
p.add_argument("recording", type=Path)
p.add_argument("scene", type=Path)
p.add_argument("--port", help="stream the centroid to this device (any --port form)")
p.add_argument("--fast", action="store_true", help="do not pace to the time stamps")
args = p.parse_args()

frames = np.load(args.recording, mmap_mode="r")
times = np.load(args.recording.with_suffix(".timestamps.npy"))
scene = lmhost.Scene.load(args.scene)
tracker = lmhost.Tracker(scene, args.recording.with_suffix(".intrinsics.toml"))
dev = None
if args.port:
    dev = lmhost.Device(args.port, scene)
    target = "autd3" if args.port.startswith("autd3:") else "lm"
    print(dev.upload(lmhost.plan(scene=scene, target=target)))
start = time.monotonic()
try:
    for frame, t in zip(frames, times):
        if not args.fast:
            time.sleep(max(0.0, t - (time.monotonic() - start)))
        r = tracker.process(np.ascontiguousarray(frame), t=float(t))
        print(r)
        if dev is not None:
            if r.gated and r.centroid_mm is not None:
                dev.centroid(*r.centroid_mm)
            else:
                dev.centroid(0.0, 0.0, 0.0, present=False)
            dev.tick()
finally:
    if dev is not None:
        dev.close()
