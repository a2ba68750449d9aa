#!/usr/bin/env python3
"""Bench helper: the reading rate the IMADA driver achieves over a pty.

A pty stands in for the gauge's serial port; its other end answers every
`D` request at once with `+0.49NTO`, so what is measured is the driver's
own cost (request, line read, parse, pacing), not a gauge's. Usage:

    python3 xtask/gauge_rate.py target/release/lmhost 2 1000   # S, Hz
"""

import json
import os
import subprocess
import sys
import threading
import tty


def main() -> None:
    binary, seconds, rate = sys.argv[1], sys.argv[2], sys.argv[3]
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)

    def serve() -> None:
        buf = b""
        while True:
            try:
                buf += os.read(master, 64)
            except OSError:
                return
            while b"\r" in buf:
                line, buf = buf.split(b"\r", 1)
                if line == b"D":
                    os.write(master, b"+0.49NTO\r")

    threading.Thread(target=serve, daemon=True).start()
    out = subprocess.run(
        [binary, "gauge", "read", "--port", path, "--model", "imada",
         "--for", seconds, "--rate", rate, "--json"],
        capture_output=True, text=True, check=True)
    v = json.loads(out.stdout)
    t = [r["at_us"] for r in v["series"]["samples"]]
    achieved = (len(t) - 1) / ((t[-1] - t[0]) * 1e-6)
    print(f"asked {rate} Hz for {seconds} s: {len(t)} readings, "
          f"achieved {achieved:.1f} Hz, median {v['median_n']} N")


if __name__ == "__main__":
    main()
