"""A study protocol (studies/paper-exp1.toml) run by lmhost, answered in a
PsychoPy window: lmhost keeps the order, the timing, the files and resume;
PsychoPy shows each question and takes the participant's key.

Needs PsychoPy (`pip install psychopy`); not run by the tests (tests:
python/tests/test_study.py answers from a plain function).

    python python/examples/study_psychopy.py p01
"""

import sys

from psychopy import event, visual

import lmhost

win = visual.Window(fullscr=False, color="black")
text = visual.TextStim(win, height=0.07, wrapWidth=1.8)


def answer(q):
    """Shows the question, returns the key pressed (1-7, or n for "not
    perceived" where the question allows it)."""
    keys = [str(i) for i in range(1, q["accepts"].get("points", 0) + 1)]
    lines = [q["prompt"]]
    if q["not_perceived"]:
        keys.append("n")
    text.text = "\n".join(lines)
    text.draw()
    win.flip()
    key = event.waitKeys(keyList=keys + ["escape"])[0]
    if key == "escape":
        raise KeyboardInterrupt("escape pressed")
    return "na" if key == "n" else key


study = lmhost.Study(
    "studies/paper-exp1.toml",
    participant=sys.argv[1] if len(sys.argv) > 1 else "p01",
    out="runs",
    port="autd3:emulator",  # the rig: a serial port or autd3:soem
    answer=answer,
    finger="synthetic",
    resume="--resume" in sys.argv,
)
for row in study:
    print(row["trial"], row["stimulus"], row["vibration"])
win.close()
