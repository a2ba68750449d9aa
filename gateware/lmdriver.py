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

The slice is either fixed when the design is built (`first`, `total`:
one netlist per board) or read at run time from two input ports
(`slice_ports=True`): then every board with the same channel count
shares one netlist, and `SliceRom` + `Board` give the ports their values
from a block RAM that the bitstream build stamps per board (`icebram`,
`gateware/README.md`). A slice that does not fit (`first + n > total`)
is refused at run time: no frame is ever whole, the outputs stay low.

Clock: f_clk = 40 kHz x 256 x k (k = `clocks_per_count`, default 8:
81.92 MHz). The SPI pins are sampled in the clock domain, so SCK must be
at most f_clk / 4.
"""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.memory import Memory
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


def driver_ports(n):
    """The ports of an `n`-channel driver: the SPI bus in, the outputs and
    the frame counters out (a board shows the same, and `ready`)."""
    return {
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
    }


class LmDriver(wiring.Component):
    """`n` channels, the frame's channels `first`..`first + n` of `total`
    (default: all, `total` = `n`); `clocks_per_count` clocks per 1/256
    carrier period; `timeout_cycles` clocks without a latched frame before
    going silent. With `slice_ports=True`, `first` and `total` are not
    parameters but 16-bit input ports (static while the board runs), and
    the netlist depends on `n` alone."""

    def __init__(self, n=256, clocks_per_count=8, timeout_cycles=None, first=0, total=None,
                 slice_ports=False):
        assert 1 <= n and clocks_per_count >= 1
        self.n = n
        self.slice_ports = slice_ports
        if slice_ports:
            self.first_value = self.total_value = None
        else:
            total = n if total is None else total
            assert 0 <= first and first + n <= total <= 0xFFFF
            self.first_value, self.total_value = first, total
        self.k = clocks_per_count
        period = COUNTS * clocks_per_count
        # Default: 100 ms (DRIVER.md, "MCU silent").
        self.timeout_cycles = timeout_cycles or (CARRIER_HZ // 10) * period
        ports = driver_ports(n)
        if slice_ports:
            ports["first"] = In(16)
            ports["total"] = In(16)
        super().__init__(ports)

    def elaborate(self, platform):
        m = Module()
        n = self.n
        hdr = SPI_HEADER_LEN

        # The slice. As parameters: constants. As ports: registered (they
        # are static), so their adders stay off the SPI logic's paths.
        if self.slice_ports:
            max_total = 0xFFFF
            total = self.total
            start = Signal(range(hdr + max_total + 1))       # index of our first phase
            stop = Signal(range(hdr + max_total + n + 1))    # one past our last
            end = Signal(range(hdr + max_total + 1))         # index after the last byte
            last_index = Signal(range(hdr + max_total + 2))  # where the index saturates
            slice_ok = Signal()
            m.d.sync += [
                start.eq(self.first + hdr),
                stop.eq(self.first + hdr + n),
                end.eq(self.total + hdr),
                last_index.eq(self.total + hdr + 1),
                slice_ok.eq((self.first + n <= self.total) & (self.total != 0)),
            ]
        else:
            max_total = self.total_value
            total = Const(self.total_value, 16)
            start = Const(hdr + self.first_value)
            stop = Const(hdr + self.first_value + n)
            end = Const(hdr + self.total_value)
            last_index = Const(hdr + self.total_value + 1)
            slice_ok = Const(1)

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
        index = Signal(range(hdr + max_total + 2))  # saturates at the top
        ok = Signal()
        back = [Signal(8, name=f"back{i}") for i in range(n)]
        back_amp = Signal(8)
        back_int = Signal(8)
        pending = Signal()
        byte = Cat(mosi, shift)
        # Our phases: frame bytes start .. stop - 1 (start >= the header).
        # Registered: the index is used when a byte completes, at least 8
        # SCK periods (32 clocks) after it last changed, so a copy one
        # clock old is the same value and keeps the compares and the
        # subtraction off the path to the 64 phase registers.
        in_slice = Signal()
        rel = Signal(range(n))
        m.d.sync += [
            in_slice.eq((index >= start) & (index < stop)),
            rel.eq((index - start)[:len(rel)]),
        ]

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
                        with m.If(byte != total[:8]):
                            m.d.sync += ok.eq(0)
                    with m.Case(6):
                        with m.If(byte != total[8:16]):
                            m.d.sync += ok.eq(0)
                with m.If(in_slice & ~pending):
                    with m.Switch(rel):
                        for i in range(n):
                            with m.Case(i):
                                m.d.sync += back[i].eq(byte)

        good = Signal(16)
        bad = Signal(16)
        whole = ok & slice_ok & (bits == 0) & (index == end)
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


#: Words of the slice ROM: one 256 x 16 block RAM (an iCE40 SB_RAM40_4K).
ROM_DEPTH = 256
#: Word 3 of a stamped slice ROM ("LM"): a ROM without it is not stamped.
ROM_MAGIC = 0x4C4D


def stamp_words(n, first, total):
    """A board's slice ROM: first, total, its channel count, the magic,
    then the placeholder's own words (`SliceRom` reads words 0-3 once
    after reset; random filler keeps every bit column of the ROM distinct,
    which `icebram` needs to find a stamped ROM again)."""
    assert 1 <= n and 0 <= first and first + n <= total <= 0xFFFF
    return [first, total, n, ROM_MAGIC] + placeholder_words()[4:]


def placeholder_words(seed=0x4C4D5F31):
    """The ROM contents a template netlist is built with: random words, so
    that synthesis cannot fold them into logic and `icebram` finds them
    (and only them) in the placed design; word 3 is never the magic, so an
    unstamped template keeps its outputs low."""
    import random

    rng = random.Random(seed)
    words = [rng.randrange(0x10000) for _ in range(ROM_DEPTH)]
    if words[3] == ROM_MAGIC:
        words[3] ^= 1
    return words


def hex_lines(words):
    """One 4-digit hex word per line: `icebram`'s format."""
    return "".join(f"{w:04x}\n" for w in words)


class SliceRom(wiring.Component):
    """The board's slice (`first`, `total`) read once after reset from a
    256 x 16 ROM (`init`: `stamp_words` or `placeholder_words`). `valid`
    goes high six clocks after reset, and only if word 2 is this board's
    channel count `n`, word 3 is `ROM_MAGIC` and the slice fits
    (`first + n <= total`)."""

    def __init__(self, n, init):
        assert len(init) == ROM_DEPTH
        self.n = n
        self.init = list(init)
        super().__init__({"first": Out(16), "total": Out(16), "valid": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.mem = mem = Memory(shape=16, depth=ROM_DEPTH, init=self.init)
        rd = mem.read_port(domain="sync")
        step = Signal(range(6))
        channels = Signal(16)
        magic = Signal(16)
        loaded = Signal()
        m.d.comb += rd.addr.eq(step)
        with m.If(step != 5):
            m.d.sync += step.eq(step + 1)
        # The read port is synchronous: word a is on `rd.data` one clock
        # after `step` was a.
        with m.Switch(step):
            with m.Case(1):
                m.d.sync += self.first.eq(rd.data)
            with m.Case(2):
                m.d.sync += self.total.eq(rd.data)
            with m.Case(3):
                m.d.sync += channels.eq(rd.data)
            with m.Case(4):
                m.d.sync += [magic.eq(rd.data), loaded.eq(1)]
        # Registered: `valid` resets the whole driver, so it comes from a
        # flip-flop, not from the comparators.
        m.d.sync += self.valid.eq(loaded & (channels == self.n) & (magic == ROM_MAGIC)
                                  & (self.first + self.n <= self.total))
        return m


class Board(wiring.Component):
    """One driver board's logic: the slice ROM and an `n`-channel driver
    with its slice as ports, held in reset until the ROM is read and
    valid. `ready` says the board may drive its outputs (the board's top
    gates its output-enable pin with it and the PLL lock)."""

    def __init__(self, n, rom_init, clocks_per_count=8, timeout_cycles=None):
        self.n = n
        self.rom_init = rom_init
        self.k = clocks_per_count
        self.timeout_cycles = timeout_cycles
        super().__init__({**driver_ports(n), "ready": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.rom = rom = SliceRom(self.n, self.rom_init)
        drv = LmDriver(self.n, self.k, self.timeout_cycles, slice_ports=True)
        m.submodules.drv = ResetInserter({"sync": ~rom.valid})(drv)
        m.d.comb += [
            drv.first.eq(rom.first),
            drv.total.eq(rom.total),
            drv.sck.eq(self.sck),
            drv.mosi.eq(self.mosi),
            drv.cs_n.eq(self.cs_n),
            self.out.eq(drv.out),
            self.period_start.eq(drv.period_start),
            self.active.eq(drv.active),
            self.bad_frames.eq(drv.bad_frames),
            self.good_frames.eq(drv.good_frames),
        ]
        m.d.sync += self.ready.eq(rom.valid)
        return m


if __name__ == "__main__":
    import argparse

    from amaranth.back import rtlil

    p = argparse.ArgumentParser(description="Write the driver as RTLIL (for Yosys)")
    p.add_argument("--channels", type=int, default=256)
    p.add_argument("--first", type=int, default=0, help="first frame channel this board drives")
    p.add_argument("--total", type=int, default=None, help="phases per frame [default: --channels]")
    p.add_argument("--slice-ports", action="store_true",
                   help="first and total as 16-bit input ports instead of parameters")
    p.add_argument("--clocks-per-count", type=int, default=8)
    p.add_argument("--name", default="lm_driver", help="the top module's name")
    p.add_argument("out")
    a = p.parse_args()
    top = LmDriver(a.channels, a.clocks_per_count, first=a.first, total=a.total,
                   slice_ports=a.slice_ports)
    with open(a.out, "w") as f:
        f.write(rtlil.convert(top, name=a.name))
