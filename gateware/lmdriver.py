"""Transducer-driver gateware for the LM firmware's SPI output.

The contract (SPI mode, frame layout, latch, timing, faults) is
`firmware/DRIVER.md`; this file implements it and nothing else:

    SPI slave (mode 0, CS low = one frame) -> back buffer (N phases,
    amplitude, intensity) -> on CS high, if the frame was whole and valid,
    a latch request -> at the next carrier period start, back -> front
    (all channels at once) -> N PWM generators, 40 kHz, rising edge at
    phase/256 of the period, duty = amplitude x intensity -> outputs.

Safety: after reset, and when no valid frame was latched for
`timeout_cycles`, every output is low until the next valid frame.

Several boards on one bus: a frame carries `total` phases and this board
drives `n` of them from channel `first` (four 64-channel boards with
`first` = 0, 64, 128, 192 drive 256 channels from the same SCK, MOSI and
CS). Each checks the whole frame. So that boards on one reference clock
also share the carrier's phase, the first valid frame after reset or a
timeout latches at once and restarts the carrier there: every board sees
the same CS edge, and its outputs were silent, so nothing glitches.

Clock: f_clk = 40 kHz x 256 x k (k = `clocks_per_count`, default 8:
81.92 MHz). The SPI pins are sampled in the clock domain, so SCK must be
at most f_clk / 4.
"""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

#: First byte of every frame (lm-fw-core `output::SPI_FRAME_MAGIC`).
SPI_FRAME_MAGIC = 0xA5
#: Header bytes before the phases (lm-fw-core `output::SPI_HEADER_LEN`).
SPI_HEADER_LEN = 7
#: The carrier.
CARRIER_HZ = 40_000
#: Carrier counts per period (the phase resolution).
COUNTS = 256


def duty_counts(amplitude, intensity):
    """High time in carrier counts for a frame's amplitude and intensity:
    round(128 x a x i / 255^2) within one count, 128 (50 %) at full."""
    return (amplitude * intensity * 129 + 32768) >> 16


class LmDriver(wiring.Component):
    """`n` channels, the frame's channels `first`..`first + n` of `total`
    (default: all, `total` = `n`); `clocks_per_count` clocks per 1/256
    carrier period; `timeout_cycles` clocks without a latched frame before
    going silent."""

    def __init__(self, n=256, clocks_per_count=8, timeout_cycles=None, first=0, total=None):
        total = n if total is None else total
        assert 1 <= n and 0 <= first and first + n <= total <= 0xFFFF and clocks_per_count >= 1
        self.n = n
        self.first = first
        self.total = total
        self.k = clocks_per_count
        period = COUNTS * clocks_per_count
        # Default: 100 ms (DRIVER.md, "MCU silent").
        self.timeout_cycles = timeout_cycles or (CARRIER_HZ // 10) * period
        super().__init__({
            "sck": In(1),
            "mosi": In(1),
            "cs_n": In(1, init=1),
            "out": Out(n),
            # One clock, aligned with `out`, at each carrier period start.
            "period_start": Out(1),
            # High while a latched pattern drives the outputs.
            "active": Out(1),
            # Frames dropped (short, long, corrupt, overrun), wrapping.
            "bad_frames": Out(16),
            # Frames latched, wrapping.
            "good_frames": Out(16),
        })

    def elaborate(self, platform):
        m = Module()
        n = self.n
        total, first = self.total, self.first

        sck = Signal()
        mosi = Signal()
        cs_n = Signal(init=1)
        m.submodules.sck_sync = FFSynchronizer(self.sck, sck)
        m.submodules.mosi_sync = FFSynchronizer(self.mosi, mosi)
        m.submodules.cs_sync = FFSynchronizer(self.cs_n, cs_n, init=1)
        sck_prev = Signal()
        cs_prev = Signal(init=1)
        m.d.sync += [sck_prev.eq(sck), cs_prev.eq(cs_n)]
        sck_rise = sck & ~sck_prev
        cs_fall = cs_prev & ~cs_n
        cs_rise = ~cs_prev & cs_n

        # --- SPI slave and back buffer -------------------------------
        shift = Signal(7)
        bits = Signal(3)
        index = Signal(range(SPI_HEADER_LEN + total + 2))  # saturates at the top
        ok = Signal()
        back = [Signal(8, name=f"back{i}") for i in range(n)]
        back_amp = Signal(8)
        back_int = Signal(8)
        pending = Signal()
        byte = Cat(mosi, shift)
        last_index = SPI_HEADER_LEN + total + 1

        with m.If(cs_fall):
            m.d.sync += [bits.eq(0), index.eq(0), ok.eq(~pending)]
        with m.Elif(~cs_n & sck_rise):
            m.d.sync += [shift.eq(byte[:7]), bits.eq(bits + 1)]
            with m.If(bits == 7):
                with m.If(index != last_index):
                    m.d.sync += index.eq(index + 1)
                with m.Switch(index):
                    with m.Case(0):
                        with m.If(byte != SPI_FRAME_MAGIC):
                            m.d.sync += ok.eq(0)
                    # A latch still pending owns the back buffer.
                    with m.Case(1):
                        with m.If(~pending):
                            m.d.sync += back_amp.eq(byte)
                    with m.Case(2):
                        with m.If(~pending):
                            m.d.sync += back_int.eq(byte)
                    with m.Case(5):
                        with m.If(byte != (total & 0xFF)):
                            m.d.sync += ok.eq(0)
                    with m.Case(6):
                        with m.If(byte != (total >> 8)):
                            m.d.sync += ok.eq(0)
                    for i in range(n):
                        with m.Case(SPI_HEADER_LEN + first + i):
                            with m.If(~pending):
                                m.d.sync += back[i].eq(byte)

        good = Signal(16)
        bad = Signal(16)
        whole = ok & (bits == 0) & (index == SPI_HEADER_LEN + total)
        latch = Signal()

        # --- carrier ---------------------------------------------------
        sub = Signal(range(self.k))
        count = Signal(8)
        tick = sub == self.k - 1
        with m.If(tick):
            m.d.sync += [sub.eq(0), count.eq(count + 1)]
        with m.Else():
            m.d.sync += sub.eq(sub + 1)
        wrap = tick & (count == COUNTS - 1)

        # --- latch, front buffer, timeout -----------------------------
        front = [Signal(8, name=f"front{i}") for i in range(n)]
        duty = Signal(8)
        active = Signal()
        silence = Signal(range(self.timeout_cycles + 1))

        # Duty from the header, pipelined (two clocks): the header arrives
        # at least N + 4 bytes before the latch can be armed.
        product = Signal(16)
        back_duty = Signal(8)
        m.d.sync += [
            product.eq(back_amp * back_int),
            back_duty.eq((product * 129 + 32768) >> 16),
        ]

        with m.If(cs_rise & ~whole):
            m.d.sync += bad.eq(bad + 1)
        with m.If(wrap & pending):
            m.d.sync += [f.eq(b) for f, b in zip(front, back)]
            m.d.sync += [
                duty.eq(back_duty),
                active.eq(1),
                pending.eq(0),
                silence.eq(0),
                good.eq(good + 1),
            ]
        with m.Elif(cs_rise & whole & ~active):
            # From silence: latch now and restart the carrier here (after
            # the carrier's own update above, so this assignment wins).
            m.d.sync += [f.eq(b) for f, b in zip(front, back)]
            m.d.sync += [
                duty.eq(back_duty),
                active.eq(1),
                silence.eq(0),
                good.eq(good + 1),
                sub.eq(0),
                count.eq(0),
            ]
        with m.Else():
            with m.If(cs_rise & whole):
                m.d.sync += pending.eq(1)
            with m.If(silence == self.timeout_cycles):
                m.d.sync += active.eq(0)
            with m.Else():
                m.d.sync += silence.eq(silence + 1)

        # --- PWM: high from count == phase for `duty` counts ------------
        for i in range(n):
            since = Signal(8, name=f"since{i}")
            m.d.comb += since.eq(count - front[i])
            m.d.sync += self.out[i].eq(active & (since < duty))
        m.d.sync += [
            self.period_start.eq((count == 0) & (sub == 0)),
            self.active.eq(active),
        ]
        m.d.comb += [self.bad_frames.eq(bad), self.good_frames.eq(good)]
        return m


if __name__ == "__main__":
    import argparse

    from amaranth.back import rtlil

    p = argparse.ArgumentParser(description="Write the driver as RTLIL (for Yosys)")
    p.add_argument("--channels", type=int, default=256)
    p.add_argument("--first", type=int, default=0, help="first frame channel this board drives")
    p.add_argument("--total", type=int, default=None, help="phases per frame [default: --channels]")
    p.add_argument("--clocks-per-count", type=int, default=8)
    p.add_argument("--name", default="lm_driver", help="the top module's name")
    p.add_argument("out")
    a = p.parse_args()
    top = LmDriver(a.channels, a.clocks_per_count, first=a.first, total=a.total)
    with open(a.out, "w") as f:
        f.write(rtlil.convert(top, name=a.name))
