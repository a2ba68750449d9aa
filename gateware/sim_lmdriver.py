"""Simulation tests of the driver gateware against `firmware/DRIVER.md`.

`cargo xtask gateware` runs this with the frames the real firmware core
sent for a planned LM-M sequence (`target/gateware/frames.bin`, from the
`spi_frames` test of lm-fw-core). Prints one line per test, the figures,
and `N passed, M failed`; exits 1 if any failed. Figures also go to
`target/gateware/figures.json`.
"""

import json
import os
import random
import re
import sys
import time
from pathlib import Path

from amaranth import Module, ResetInserter, Signal
from amaranth.sim import Simulator

from lmdriver import (COUNTS, ROM_DEPTH, ROM_MAGIC, SPI_FRAME_MAGIC, SPI_HEADER_LEN, Board,
                      LmDriver, duty_counts, placeholder_words, stamp_words)

ROOT = Path(__file__).resolve().parent.parent
#: frames.bin in, figures.json out (`cargo xtask gateware` sets it).
OUT = Path(os.environ.get("LM_GW_OUT", ROOT / "target" / "gateware"))
N = 16  # channels in the simulation (the fixture's transducers)
K = 2  # clocks per carrier count in the simulation (speed)
HALF = 2  # clocks per SCK half period: SCK = f_clk / 4, the fastest allowed
SYNC = 4  # clocks from a pin to the logic (2-FF synchroniser + edge detect)


# --- stimulus ------------------------------------------------------------

class Wave:
    """Pin values per clock: cs_n, sck, mosi, rst."""

    def __init__(self):
        self.cs, self.sck, self.mosi, self.rst = [], [], [], []
        self.marks = {}

    def __len__(self):
        return len(self.cs)

    def put(self, cs, sck, mosi, rst=0, cycles=1):
        for _ in range(cycles):
            self.cs.append(cs)
            self.sck.append(sck)
            self.mosi.append(mosi)
            self.rst.append(rst)

    def idle(self, cycles):
        self.put(1, 0, 0, cycles=cycles)

    def reset(self, cycles=3):
        self.put(1, 0, 0, rst=1, cycles=cycles)

    def frame(self, data, bits=None, half=HALF):
        """One transaction (mode 0, MSB first); `bits` cuts it short.
        Returns the clock at which CS goes high."""
        bits = len(data) * 8 if bits is None else bits
        self.last_start = len(self)
        self.put(0, 0, 0, cycles=half)
        for b in range(bits):
            v = (data[b // 8] >> (7 - b % 8)) & 1
            self.put(0, 0, v, cycles=half)
            self.put(0, 1, v, cycles=half)
        self.put(0, 0, 0, cycles=half)
        at = len(self)
        self.put(1, 0, 0, cycles=half)
        return at


def frame_bytes(amp, inten, phases, step=0, count=None):
    count = len(phases) if count is None else count
    return bytes([SPI_FRAME_MAGIC, amp, inten, step & 0xFF, step >> 8,
                  count & 0xFF, count >> 8]) + bytes(phases)


def pattern_of(frame):
    """(phases, duty) a valid frame puts on the outputs."""
    return tuple(frame[SPI_HEADER_LEN:]), duty_counts(frame[1], frame[2])


def valid(frame, n=N):
    return (len(frame) == SPI_HEADER_LEN + n and frame[0] == SPI_FRAME_MAGIC
            and frame[5] | frame[6] << 8 == n)


# --- simulation ------------------------------------------------------------

def simulate(wave, n=N, k=K, timeout_cycles=None, first=0, total=None, dut=None, static=()):
    """Runs the wave; returns per clock: out, period_start, active, good,
    bad (and `ready` for a `Board`). `dut` replaces the default driver;
    `static` is (port, value) pairs held from the first clock."""
    dut = dut or LmDriver(n, k, timeout_cycles, first=first, total=total)
    rst = Signal()
    top = Module()
    top.submodules.dut = ResetInserter({"sync": rst})(dut)
    sim = Simulator(top)
    sim.add_clock(1 / (40e3 * 256 * k))
    rec = {"out": [], "ps": [], "active": [], "good": [], "bad": [], "ready": []}
    has_ready = isinstance(dut, Board)

    async def bench(ctx):
        for port, value in static:
            ctx.set(port, value)
        prev = (None, None, None, None)
        for t in range(len(wave)):
            cur = (wave.cs[t], wave.sck[t], wave.mosi[t], wave.rst[t])
            for sig, old, new in zip((dut.cs_n, dut.sck, dut.mosi, rst), prev, cur):
                if old != new:
                    ctx.set(sig, new)
            prev = cur
            await ctx.tick()
            rec["out"].append(ctx.get(dut.out))
            rec["ps"].append(ctx.get(dut.period_start))
            rec["active"].append(ctx.get(dut.active))
            rec["good"].append(ctx.get(dut.good_frames))
            rec["bad"].append(ctx.get(dut.bad_frames))
            if has_ready:
                rec["ready"].append(ctx.get(dut.ready))

    sim.add_testbench(bench)
    sim.run()
    return rec


def expected_high(pattern, n, k):
    """Per channel, the set of clock offsets in a period where it is high."""
    phases, duty = pattern
    period = COUNTS * k
    return [frozenset(o for o in range(period) if (o // k - p) % COUNTS < duty)
            for p in phases]


def periods(rec, n, k):
    """[(start clock, per-channel high offsets)] for every whole period. A
    period cut short by a carrier restart (the first latch from silence)
    must be silent, and is skipped."""
    period = COUNTS * k
    starts = [t for t, v in enumerate(rec["ps"]) if v]
    res = []
    for j, s in enumerate(starts):
        if j + 1 < len(starts) and starts[j + 1] - s < period:
            assert not any(rec["out"][s:starts[j + 1]]), f"a cut period at clock {s} is not silent"
            continue
        if s + period > len(rec["out"]):
            break
        words = rec["out"][s:s + period]
        res.append((s, [frozenset(o for o, w in enumerate(words) if w >> i & 1)
                        for i in range(n)]))
    return res


def classify(rec, patterns, n, k):
    """Per whole period: the index of the pattern shown, -1 = silent.
    Fails on a period that matches no pattern (a partial one)."""
    silent = [frozenset()] * n
    table = {tuple(expected_high(p, n, k)): i for i, p in enumerate(patterns)}
    out = []
    for s, highs in periods(rec, n, k):
        key = tuple(highs)
        if highs == silent:
            out.append((s, -1))
        elif key in table:
            out.append((s, table[key]))
        else:
            raise AssertionError(f"period at clock {s}: outputs match no single frame")
    return out


def edge_error_lsb(rec, patterns, shown, n, k):
    """Largest |rising edge - phase| over all channels and shown periods, in
    1/256 of a period (edges measured from the period start)."""
    worst = 0.0
    for s, idx in shown:
        if idx < 0:
            continue
        phases, duty = patterns[idx]
        if duty == 0:
            continue
        words = rec["out"][s:s + COUNTS * k]
        for i, p in enumerate(phases):
            bits = [w >> i & 1 for w in words]
            rises = [o for o in range(len(bits)) if bits[o] and not bits[o - 1]]
            assert len(rises) == 1, f"channel {i}: {len(rises)} rising edges in a period"
            err = (rises[0] / k - p + COUNTS / 2) % COUNTS - COUNTS / 2
            worst = max(worst, abs(err))
    return worst


# --- tests -----------------------------------------------------------------

FIG = {}
FRAMES = []


def load_frames():
    path = OUT / "frames.bin"
    data = path.read_bytes()
    frames, i = [], 0
    while i < len(data):
        ln = int.from_bytes(data[i:i + 4], "little")
        frames.append(data[i + 4:i + 4 + ln])
        i += 4 + ln
    return frames


def test_constants_match_the_firmware():
    src = (ROOT / "firmware/core/src/output.rs").read_text()
    magic = int(re.search(r"SPI_FRAME_MAGIC: u8 = (0x[0-9A-Fa-f]+);", src).group(1), 16)
    hdr = int(re.search(r"SPI_HEADER_LEN: usize = (\d+);", src).group(1))
    assert (magic, hdr) == (SPI_FRAME_MAGIC, SPI_HEADER_LEN), (magic, hdr)


def test_lm_m_frames_from_the_core():
    """Every frame of two LM-M cycles: each period shows exactly one whole
    frame, in order, switching at the first period start after CS high;
    edges at the phase; high time from amplitude x intensity."""
    frames = FRAMES
    assert len(frames) >= 25 and all(valid(f) for f in frames), "frames.bin"
    rng = random.Random(17)
    period = COUNTS * K
    w = Wave()
    w.reset()
    w.idle(period + 37)
    cs_high, cs_low = [], []
    for f in frames:
        cs_high.append(w.frame(f))
        cs_low.append(w.last_start)
        w.idle(rng.randrange(period + 10, 2 * period))  # ≥ 1 period: no overrun
    w.idle(2 * period)
    t0 = time.perf_counter()
    rec = simulate(w, timeout_cycles=100 * period)
    FIG["sim_clocks_per_s"] = len(w) / (time.perf_counter() - t0)
    patterns = [pattern_of(f) for f in frames]
    shown = classify(rec, patterns, N, K)
    # A muted frame (the core's last, on Stop) shows as silence.
    keys = [patterns[i] if i >= 0 else None for _, i in shown]
    want = [p if p[1] > 0 else None for p in patterns]
    starts = [s for s, _ in shown]
    assert all(want[j] != want[j + 1] for j in range(len(frames) - 1))
    assert want[-1] is None and frames[-1][1] == 0, "the core's Stop frame is muted"
    # Silent until the first frame, then frame j from the first period start
    # after its CS high (+ the synchroniser) until frame j + 1's.
    lat = []
    q_prev, prev_key = 0, None
    for j, at in enumerate(cs_high):
        q = next(q for q in range(q_prev, len(starts)) if starts[q] > at + SYNC - 2)
        assert all(k == prev_key for k in keys[q_prev + (j > 0):q]), f"frame {j - 1} held"
        assert keys[q] == want[j], f"frame {j} shown at the next period start"
        assert starts[q] - at <= period + SYNC, (j, starts[q] - at)
        lat.append(starts[q] - at)
        q_prev, prev_key = q, want[j]
    assert all(k == prev_key for k in keys[q_prev:])
    # Periods indexed by pattern: replace indices by the frame shown.
    shown = [(s, patterns.index(k) if k else -1) for s, k in zip(starts, keys)]
    FIG["stop_frame_silent_after_clocks"] = lat[-1]
    FIG["latch_to_output_clocks_max"] = max(lat)
    FIG["latch_to_output_clocks_min"] = min(lat)
    err = edge_error_lsb(rec, patterns, shown, N, K)
    assert err <= 1, err
    FIG["phase_error_max_lsb"] = err
    FIG["duty_counts"] = patterns[0][1]
    FIG["frames_checked"] = len(frames)
    FIG["frame_bytes"] = len(frames[0])
    # CS low to CS high (SCK = f_clk / 4), and the same in SCK periods at
    # the board's 16 MHz SCK (DRIVER.md).
    FIG["spi_frame_clocks"] = cs_high[0] - cs_low[0]
    FIG["spi_frame_us_at_16mhz"] = FIG["spi_frame_clocks"] / (2 * HALF) / 16
    assert rec["good"][-1] == len(frames) and rec["bad"][-1] == 0


def test_reset_and_timeout_silence_the_outputs():
    period = COUNTS * K
    timeout = 3 * period + 11
    rng = random.Random(3)
    f = frame_bytes(255, 255, [rng.randrange(256) for _ in range(N)])
    w = Wave()
    w.reset()
    w.idle(2 * period)
    w.frame(f)
    w.idle(2 * period)
    w.reset(5)  # reset mid-pattern
    reset_at = len(w)
    w.idle(2 * period)
    w.frame(f)
    w.idle(timeout + 3 * period)
    rec = simulate(w, timeout_cycles=timeout)
    out, act = rec["out"], rec["active"]
    assert all(v == 0 for v in out[:period]), "silent after power-on reset"
    assert any(out[reset_at - 10:reset_at - 5])
    assert all(v == 0 for v in out[reset_at - 4:reset_at + 2 * period]), "silent from reset"
    on = [t for t, a in enumerate(act) if a]
    assert on, "the second frame latched"
    last_on = on[-1]
    # Active from the latch for exactly the timeout, then silent to the end.
    start = max(t for t in on if t == 0 or not act[t - 1])
    assert last_on - start + 1 == timeout + 1, (last_on - start, timeout)
    assert all(v == 0 for v in out[last_on + 2:]), "silent after the timeout"
    FIG["timeout_to_silent_clocks"] = last_on - start + 2


def fault_cases(rng):
    ph = lambda: [rng.randrange(256) for _ in range(N)]
    good = frame_bytes(255, 200, ph())
    cases = {
        "bad magic": bytes([0x5A]) + frame_bytes(255, 255, ph())[1:],
        "count too small": frame_bytes(255, 255, ph(), count=N - 1),
        "count too large": frame_bytes(255, 255, ph(), count=N + 256),
        "short: header only": frame_bytes(255, 255, ph())[:SPI_HEADER_LEN],
        "short: one phase missing": frame_bytes(255, 255, ph())[:-1],
        "long: one byte extra": frame_bytes(255, 255, ph()) + b"\x00",
        "empty transaction": b"",
    }
    return good, cases


def test_corrupt_short_and_long_frames_keep_the_previous_pattern():
    rng = random.Random(5)
    period = COUNTS * K
    good, cases = fault_cases(rng)
    w = Wave()
    w.reset()
    w.frame(good)
    w.idle(2 * period)
    for name, data in cases.items():
        w.frame(data)
        w.idle(2 * period)
    # A byte cut mid-way (CS high after 3 bits of the last phase).
    cut = frame_bytes(255, 255, [rng.randrange(256) for _ in range(N)])
    w.frame(cut, bits=len(cut) * 8 - 5)
    w.idle(2 * period)
    # Overrun: a second frame before the first one latched.
    a = frame_bytes(128, 255, [rng.randrange(256) for _ in range(N)])
    b = frame_bytes(64, 255, [rng.randrange(256) for _ in range(N)])
    # Align so a's latch is pending while b starts: start right after a period start.
    w.idle(period - (len(w) % period))
    w.frame(a)
    w.frame(b)
    w.idle(3 * period)
    final = frame_bytes(255, 255, [rng.randrange(256) for _ in range(N)])
    w.frame(final)
    w.idle(2 * period)
    rec = simulate(w, timeout_cycles=100 * period)
    pats = [pattern_of(good), pattern_of(a), pattern_of(final)]
    seq = [i for _, i in classify(rec, pats, N, K)]
    dedup = [x for j, x in enumerate(seq) if j == 0 or seq[j - 1] != x]
    assert dedup == [-1, 0, 1, 2], dedup
    assert rec["bad"][-1] == len(cases) + 2, rec["bad"][-1]
    assert rec["good"][-1] == 3
    FIG["fault_cases"] = len(cases) + 2


def test_random_spi_fuzz():
    """Random transactions (good, mutated, cut, noise) and SCK glitches with
    CS high: every period shows silence or one whole frame that a reference
    model accepts, and the driver latches exactly the frames it accepts."""
    rng = random.Random(1234)
    period = COUNTS * K
    w = Wave()
    w.reset()
    accepted, sent = [], 0
    for _ in range(40):
        kind = rng.randrange(6)
        f = bytearray(frame_bytes(rng.randrange(256), rng.randrange(256),
                                  [rng.randrange(256) for _ in range(N)], rng.randrange(65536)))
        bits = None
        if kind == 1:
            f[rng.randrange(SPI_HEADER_LEN)] ^= 1 << rng.randrange(8)
        elif kind == 2:
            bits = rng.randrange(len(f) * 8)
        elif kind == 3:
            f = bytearray(rng.randrange(256) for _ in range(rng.randrange(40)))
        elif kind == 4:
            for _ in range(rng.randrange(1, 20)):  # SCK noise with CS high
                w.put(1, rng.randrange(2), rng.randrange(2), cycles=rng.randrange(1, 4))
        f = bytes(f)
        whole = bits is None or bits == len(f) * 8
        w.frame(f, bits=bits)
        sent += 1
        if whole and valid(f):
            accepted.append(f)
        w.idle(rng.randrange(period + 10, 2 * period))
    w.idle(period)
    rec = simulate(w, timeout_cycles=100 * period)
    pats = [pattern_of(f) for f in accepted]
    seq = [i for _, i in classify(rec, pats, N, K)]
    shown = sorted({i for i in seq if i >= 0})
    assert rec["good"][-1] == len(accepted), (rec["good"][-1], len(accepted))
    assert rec["bad"][-1] == sent - len(accepted)
    # Identical patterns may alias; each shown one is accepted and the last
    # accepted one is on at the end.
    assert seq[-1] == len(pats) - 1 or pats[seq[-1]] == pats[-1]
    FIG["fuzz_transactions"] = sent
    FIG["fuzz_accepted"] = len(accepted)
    assert shown


def test_boards_on_one_bus_drive_their_slice_in_phase():
    """Two 8-channel boards (`first` 0 and 8) on one bus, reset at
    different times, get the same 16-phase frames: each shows its slice,
    edges exact, and their carriers start on the same clock from the first
    frame on; a 16-channel board sees the same."""
    period = COUNTS * K
    rng = random.Random(29)
    frames = [frame_bytes(255, 255, [rng.randrange(256) for _ in range(N)], step=s)
              for s in range(3)]
    half = N // 2
    recs, waves = [], []
    for lead in (0, 777):  # the second board leaves reset 777 clocks later
        w = Wave()
        w.reset(3 + lead)
        w.idle(period + 300 - lead)
        firsts = []
        for f in frames:
            firsts.append(w.frame(f))
            w.idle(period + 100)
        w.idle(period)
        waves.append((w, firsts))
    assert waves[0][1] == waves[1][1], "the same CS edges on both"
    for board, (w, _) in enumerate(waves):
        recs.append(simulate(w, n=half, first=board * half, total=N,
                             timeout_cycles=100 * period))
    starts = [[t for t, v in enumerate(r["ps"]) if v and t > waves[0][1][0]] for r in recs]
    assert starts[0] and starts[0] == starts[1], "carriers in phase after the first frame"
    for board, r in enumerate(recs):
        pats = [(tuple(f[SPI_HEADER_LEN + board * half:SPI_HEADER_LEN + (board + 1) * half]),
                 duty_counts(f[1], f[2])) for f in frames]
        shown = classify(r, pats, half, K)
        assert sorted({i for _, i in shown if i >= 0}) == [0, 1, 2], shown
        assert edge_error_lsb(r, pats, shown, half, K) <= 1
        assert r["good"][-1] == 3 and r["bad"][-1] == 0
    # A frame for a 24-channel rig is not whole for a board expecting 16.
    w = Wave()
    w.reset()
    w.frame(frame_bytes(255, 255, [0] * 24))
    w.idle(2 * period)
    r = simulate(w, n=half, first=half, total=N, timeout_cycles=100 * period)
    assert r["good"][-1] == 0 and r["bad"][-1] == 1
    FIG["boards_in_phase"] = 2


def test_last_board_of_the_paper_array_latches_its_slice():
    """The 16th board of the paper's 996-transducer array: 36 channels
    from 960, its slice not in the netlist but read from its stamped ROM
    (`Board`, as the bitstream has it). It shows phases 960..995 of each
    996-phase frame, edges exact, from the period after each frame."""
    period = COUNTS * K
    rng = random.Random(996)
    total, first, n = 996, 960, 36
    frames = [frame_bytes(255, 200 + 40 * j, [rng.randrange(256) for _ in range(total)], step=j)
              for j in range(2)]
    w = Wave()
    w.reset()
    w.idle(20)  # the ROM is read in 5 clocks
    w.frame(frames[0])
    w.idle(period + 10)
    w.frame(frames[1])
    w.idle(2 * period)
    # At K = 2 and SCK = f_clk / 4 a frame lasts 62 carrier periods: a long timeout.
    rec = simulate(w, n=n, dut=Board(n, stamp_words(n, first, total), K, 1000 * period))
    assert rec["ready"][10] == 1 and all(rec["ready"][10:]), "ready once the ROM is read"
    pats = [(tuple(f[SPI_HEADER_LEN + first:SPI_HEADER_LEN + first + n]), duty_counts(f[1], f[2]))
            for f in frames]
    shown = classify(rec, pats, n, K)
    seq = [i for _, i in shown]
    dedup = [x for j, x in enumerate(seq) if j == 0 or seq[j - 1] != x]
    assert dedup == [-1, 0, 1], dedup
    assert edge_error_lsb(rec, pats, shown, n, K) == 0
    assert rec["good"][-1] == 2 and rec["bad"][-1] == 0, (rec["good"][-1], rec["bad"][-1])
    FIG["last_board_channels"] = n


def test_a_board_without_its_stamp_stays_silent():
    """An unstamped template (placeholder ROM), a ROM stamped for another
    channel count, a slice past the frame's end: `ready` stays low and no
    frame latches. A driver given such a slice on its ports drops every
    frame itself, and so does a board whose slice is right, for a frame
    whose count is one short (the count is checked against the port)."""
    period = COUNTS * K
    rng = random.Random(7)
    f = frame_bytes(255, 255, [rng.randrange(256) for _ in range(8)])
    w = Wave()
    w.reset()
    w.idle(20)
    w.frame(f)
    w.idle(2 * period)
    short_count = Wave()
    short_count.reset()
    short_count.idle(20)
    short_count.frame(frame_bytes(255, 255, [rng.randrange(256) for _ in range(8)], count=7))
    short_count.idle(2 * period)
    overrun = [7, 8, 4, ROM_MAGIC] + [0] * (ROM_DEPTH - 4)  # channels 7..10 of 8
    for name, rom in [("placeholder", placeholder_words()), ("stamped for 8 channels",
                      stamp_words(8, 0, 8)), ("slice past the end", overrun)]:
        rec = simulate(w, n=4, dut=Board(4, rom, K, 100 * period))
        assert not any(rec["ready"]), name
        assert rec["good"][-1] == 0 and not any(rec["out"]), name
    # The same board stamped right latches the frame (the test has teeth).
    rec = simulate(w, n=4, dut=Board(4, stamp_words(4, 4, 8), K, 100 * period))
    assert rec["ready"][-1] and rec["good"][-1] == 1 and any(rec["out"])
    drv = LmDriver(4, K, 100 * period, slice_ports=True)
    rec = simulate(w, n=4, dut=drv, static=[(drv.first, 5), (drv.total, 8)])
    assert rec["good"][-1] == 0 and rec["bad"][-1] == 1 and not any(rec["out"])
    rec = simulate(w, n=4, dut=(drv := LmDriver(4, K, 100 * period, slice_ports=True)),
                   static=[(drv.first, 4), (drv.total, 8)])
    assert rec["good"][-1] == 1 and rec["bad"][-1] == 0
    rec = simulate(short_count, n=4, dut=Board(4, stamp_words(4, 4, 8), K, 100 * period))
    assert rec["good"][-1] == 0 and rec["bad"][-1] == 1 and not any(rec["out"])


def test_pin_file_and_wiring_tables_match_the_board():
    """`hx8k.py` holds the board's header map (EB85's schematic) and the
    pin choice; the checked-in PCF and firmware/DRIVER.md's tables must be
    exactly what it says, and the choice must keep off ground, supply,
    reserved and shared pins."""
    import hx8k

    pcf = (ROOT / "gateware/ice40hx8k-b-evn.pcf").read_text()
    assert pcf == hx8k.pcf_text(), "ice40hx8k-b-evn.pcf: rewrite it with `python hx8k.py --pcf`"
    used = [*hx8k.CONTROL.values(), *hx8k.GUARDS, *hx8k.OUTPUTS]
    balls = [hx8k.ball(w) for w in used] + [hx8k.LED_BALL]
    assert len(hx8k.OUTPUTS) == hx8k.CHANNELS == 64 and len(set(balls)) == len(balls)
    for where in used:
        net = hx8k.ball(where)
        assert net != "GND" and not net.startswith("VCC") and net not in hx8k.RESERVED, where
        assert where[0] != "J1", f"{where}: J1 is shared with the FT2232H and the LEDs"
    assert all(sum(1 for v in h.values() if v == "GND") == 10 for h in hx8k.HEADERS.values())
    doc = (ROOT / "firmware/DRIVER.md").read_text()
    rows = re.findall(r"^\| (\d+) \| (J\d) \| (\d+) \| ([A-T]\d+) \| (\d) \|$", doc, re.M)
    bank = {"J1": 0, "J2": 1, "J3": 2, "J4": 3}
    want = [(str(k), h, str(p), hx8k.ball((h, p)), str(bank[h])) for k, (h, p) in enumerate(hx8k.OUTPUTS)]
    assert rows == want, "DRIVER.md's output table and hx8k.OUTPUTS differ"
    for name, label in [("clk_ref", "reference"), ("cs_n", "CS"), ("mosi", "MOSI"), ("sck", "SCK"),
                        ("oe_n", "`oe_n`")]:
        hdr, pin = hx8k.CONTROL[name]
        assert re.search(rf"^\| {re.escape(label)}[^|]* \| {pin} \| {hx8k.ball((hdr, pin))}\b", doc, re.M), name
    guards = ", ".join(str(p) for _, p in hx8k.GUARDS)
    assert f"| guard, driven low | {guards} | " in doc
    # The array table: 996 transducers as `cargo xtask bitstream --all` splits them.
    arr = re.findall(r"^\| (\d+) \| (\d+) \| (\d+) \| (\d+)-(\d+) \| `hx8k_b(\d\d)_(\d+)-(\d+)_of_996\.bin` \|$",
                     doc, re.M)
    want = [(i, 64 * i, min(64, 996 - 64 * i)) for i in range(16)]
    got = [(int(b), int(f), int(n)) for b, f, n, *_ in arr]
    assert got == want, got
    assert all(int(lo) == f and int(hi) == f + n - 1 and int(b2) == b and int(lo2) == f and int(hi2) == f + n - 1
               for (b, f, n), (_, _, _, lo, hi, b2, lo2, hi2) in zip(want, arr))
    FIG["pins_checked"] = len(used)


def test_documented_clock_k8():
    """At the documented clock (k = 8, 81.92 MHz) with SCK = 16 MHz-like
    ratio (f_clk / 5, rounded to whole clocks: 3+2): edges exact."""
    k = 8
    period = COUNTS * k
    f = FRAMES[len(FRAMES) // 2]
    w = Wave()
    w.reset()
    w.idle(10)
    w.frame(f, half=3)
    w.idle(2 * period + 5)
    rec = simulate(w, k=k, timeout_cycles=100 * period)
    shown = classify(rec, [pattern_of(f)], N, k)
    assert [i for _, i in shown][-1] == 0
    err = edge_error_lsb(rec, [pattern_of(f)], shown, N, k)
    assert err == 0, err
    FIG["phase_error_max_lsb_k8"] = err


def main():
    global FRAMES
    try:
        FRAMES = load_frames()
    except OSError as e:
        print(f"cannot read the core's frames ({e}): run `cargo xtask gateware`")
        return 2
    tests = [v for k, v in globals().items() if k.startswith("test_")]
    passed = failed = 0
    t0 = time.perf_counter()
    for t in tests:
        t1 = time.perf_counter()
        try:
            t()
            passed += 1
            print(f"ok   {t.__name__} ({time.perf_counter() - t1:.1f} s)")
        except Exception as e:  # report every failing test, not just the first
            failed += 1
            print(f"FAIL {t.__name__}: {type(e).__name__}: {e}")
    period_s = 1 / 40e3
    FIG["sim_channels"] = N
    FIG["sim_clocks_per_count"] = K
    print("figures:")
    for k, v in FIG.items():
        print(f"  {k}: {v:.4g}" if isinstance(v, float) else f"  {k}: {v}")
    if "latch_to_output_clocks_max" in FIG:
        clk = 40e3 * 256 * K
        print(f"  latch to output: {FIG['latch_to_output_clocks_min'] / clk * 1e6:.2f}"
              f"..{FIG['latch_to_output_clocks_max'] / clk * 1e6:.2f} µs"
              f" (carrier period {period_s * 1e6:.0f} µs)")
    out = OUT / "figures.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(FIG, indent=1))
    print(f"{passed} passed, {failed} failed ({time.perf_counter() - t0:.1f} s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
