"""Experiment 1 with PsychoPy's TrialHandler instead of the hand-made loop
in experiment1.py: PsychoPy randomises the 15 conditions per repetition,
keeps the ratings and writes its own data file; lmhost presents.

Needs PsychoPy (`pip install psychopy`); not run by the tests.

    LMHOST_BIN=target/release/lmhost python python/examples/experiment1_psychopy.py
"""

import time

from psychopy import data

import lmhost

conditions = [
    {"stimulus": f"{t}-a{a}", "type": t, "radius_mm": a}
    for t in ["lms-5hz", "lmm-5hz", "lms-25hz"]
    for a in [2, 3, 4, 5, 6]
]
trials = data.TrialHandler(trialList=conditions, nReps=2, method="random", seed=7)

with lmhost.Session(library="studies/paper-library.toml", port="autd3:emulator",
                    synthetic=True) as s:
    for trial in trials:
        s.prepare(trial["stimulus"])
        s.present(trial["stimulus"], on_s=3.0)
        off = s.wait_for("offset", timeout=60, stimulus=trial["stimulus"])
        rating = int(input(f"{trial['stimulus']}: vibration 1-7? "))
        trials.addData("vibration", rating)
        trials.addData("presented_s", off["presented_s"])
        trials.addData("device_presented_s", off["device_presented_s"])
        s.wait_for("done", timeout=10, stimulus=trial["stimulus"])
        time.sleep(1.0)  # inter-trial interval

trials.saveAsWideText("exp1-psychopy.csv")
