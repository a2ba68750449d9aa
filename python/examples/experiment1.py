"""The paper's Experiment 1 trial loop driving an `lmhost session`: every
stimulus type × radius, in a seeded random order per set, presented for
3 s with a 1 s gap, one rating per trial written to a CSV.

    LMHOST_BIN=target/release/lmhost python python/examples/experiment1.py \\
        --port autd3:emulator --synthetic --answers auto

`--answers auto` rates at random (a dry run); otherwise the experimenter
types the participant's 1-7 rating after each trial. `lmhost study run
studies/paper-exp1.toml` is the full runner (resume, questions, reports).
"""

import argparse
import csv
import random
import time

import lmhost

p = argparse.ArgumentParser()
p.add_argument("--port", default="autd3:emulator")
p.add_argument("--library", default="studies/paper-library.toml")
p.add_argument("--scene")
p.add_argument("--synthetic", action="store_true", help="a synthetic finger at the centre")
p.add_argument("--sets", type=int, default=2)
p.add_argument("--seed", type=int, default=1)
p.add_argument("--answers", choices=["ask", "auto"], default="ask")
p.add_argument("--out", default="exp1-trials.csv")
args = p.parse_args()

types = ["lms-5hz", "lmm-5hz", "lms-25hz"]
radii = [2, 3, 4, 5, 6]
rng = random.Random(args.seed)
with lmhost.Session(library=args.library, port=args.port, scene=args.scene,
                    synthetic=args.synthetic) as s, open(args.out, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["set", "trial", "stimulus", "presented_s", "present_fraction", "rating"])
    for set_ in range(1, args.sets + 1):
        order = [f"{t}-a{a}" for t in types for a in radii]
        rng.shuffle(order)
        for trial, stim in enumerate(order, 1):
            s.prepare(stim)  # a slot change only when presented
            s.present(stim, on_s=3.0)
            off = s.wait_for("offset", timeout=60, stimulus=stim)
            if args.answers == "auto":
                rating = rng.randint(1, 7)
            else:
                rating = int(input(f"set {set_} trial {trial} ({stim}): vibration 1-7? "))
            w.writerow([set_, trial, stim, off["presented_s"], off["present_fraction"], rating])
            f.flush()
            s.wait_for("done", timeout=10, stimulus=stim)
            time.sleep(1.0)  # the inter-trial interval, in silence
print(f"wrote {args.out}")
