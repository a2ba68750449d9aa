"""The driver on a Lattice iCE40-HX8K Breakout Board (ICE40HX8K-B-EVN):
up to 64 channels per board, pins in `ice40hx8k-b-evn.pcf` (written from
`HEADERS` and `PINS` below: `python hx8k.py --pcf`).

The 81.92 MHz design clock comes from a 10.24 MHz reference on a header
pin (the Nucleo's crystal-derived clock output, shared by every driver
board on the bus; `firmware/DRIVER.md`) through the HX8K's PLL: 10.24 MHz
x 64 / 8, exact (DIVR 0, DIVF 63, DIVQ 3, filter range 1, as `icepll -i
10.24 -o 81.92` gives). The design is held in reset until the PLL locks.

A board's slice of the frame (`first`, `total`) is not in the netlist: it
is read after reset from one block RAM (`lmdriver.SliceRom`), built with
placeholder contents and stamped per board into the placed design with
`icebram` (`cargo xtask bitstream`). Every board with the same channel
count is the same netlist, placed and routed once.

`oe_n` (output enable, active low) goes low only while the PLL is locked
and the stamped slice was read and is valid; the board's output buffers
take it on their OE inputs (DRIVER.md, "Power-on and configuration").
LED D9 shows `active` (a latched pattern drives the outputs).

    python hx8k.py --channels 64 --rom-hex rom.hex out.il   # RTLIL, top `top`
    python hx8k.py --stamp --channels 36 --first 960 --total 996 board.hex
    python hx8k.py --pcf                                      # the pin file
"""

import argparse
import sys

from amaranth import ClockDomain, ClockSignal, Elaboratable, Instance, Module, Signal
from amaranth.back import rtlil
from amaranth.lib.cdc import ResetSynchronizer

from lmdriver import Board, hex_lines, placeholder_words, stamp_words

#: Channels per breakout board: the output pins below.
CHANNELS = 64

# The board's four 2 x 20 headers, pin by pin, from the schematic in the
# iCE40HX-8K Breakout Board User Guide (Lattice EB85, Appendix A, sheets
# 3 and 4: connectors J1-J4 and the FPGA banks; the user guide's text:
# J2 is populated, J1, J3 and J4 are unpopulated hole rows). A ball name
# is a CT256 ball wired to that pin; other entries are the nets the
# schematic shows. Pins 7, 8, 15, 16, 23, 24, 31, 32, 39, 40 are ground on
# all four. Each bank's VCCIO is the board's +3.3 V through a 1 ohm
# resistor (R21, R22, R27, R25).
GND_PINS = (7, 8, 15, 16, 23, 24, 31, 32, 39, 40)


def _header(power, balls):
    pins = dict(power)
    pins.update({p: "GND" for p in GND_PINS})
    free = [p for p in range(1, 41) if p not in pins]
    assert len(free) == len(balls), (len(free), len(balls))
    pins.update(zip(free, balls))
    return pins


HEADERS = {
    # Bank 0. Shared on the board: A16, A15, B15, B13, B14, B12, B10 with
    # the FT2232H's UART lines (sheet 2), and B5, B4, A2, A1, C5, C4, B3,
    # C3 with LEDs D9..D2 (sheet 5).
    "J1": _header({2: "VCCIO0"}, [
        "A16", "A15", "B15", "B13", "B14", "B12", "B11", "A11", "B10", "A10", "C9",
        "A9", "B9", "B8", "A7", "B7", "C7", "A6", "C6", "B6", "C5", "A5", "C4",
        "B5", "C3", "B4", "B3", "A2", "A1"]),
    # Bank 1; pins 1 and 3 are the FPGA's 1.2 V core supply.
    "J2": _header({1: "VCC_1.2V", 2: "VCCIO1", 3: "VCC_1.2V"}, [
        "R15", "P16", "P15", "N16", "M15", "M16", "L16", "K15", "K16", "K14", "J14",
        "G14", "F14", "J15", "H14", "H16", "G15", "G16", "F15", "F16", "E14", "E16",
        "D15", "D16", "D14", "C16", "B16"]),
    # Bank 2; pin 10 (P13) is CBSEL1, a configuration pin.
    "J3": _header({2: "VCCIO2"}, [
        "R16", "T15", "T16", "T13", "T14", "N12", "P13", "N10", "M11", "T11", "P10",
        "T10", "R10", "P8", "P9", "T9", "R9", "T7", "T8", "T6", "R6", "T5", "R5",
        "R3", "R4", "R2", "T3", "T1", "T2"]),
    # Bank 3; pins 1 and 3 are +3.3 V; pin 22 (J3) carries the board's
    # 12 MHz oscillator.
    "J4": _header({1: "VCC_3.3V", 2: "VCCIO3", 3: "VCC_3.3V"}, [
        "R1", "P1", "P2", "N3", "N2", "M2", "M1", "L3", "L1", "K3", "K1", "J2", "J1",
        "H2", "J3", "G2", "H1", "F2", "G1", "E2", "F1", "D1", "D2", "C1", "C2", "B1",
        "B2"]),
}
#: Balls on a header that the design must leave alone.
RESERVED = {"P13": "CBSEL1", "J3": "12 MHz oscillator"}
#: LED D9 (net LED0, EB85 sheets 3 and 5; also on J1, which the design does not use).
LED_BALL = "B5"

#: The bus and the output enable: J2 pins 25-37, each beside a ground pin
#: or a guard; the reference on H16, a global-buffer input (GBIN2).
CONTROL = {
    "clk_ref": ("J2", 25),
    "cs_n": ("J2", 29),
    "mosi": ("J2", 33),
    "sck": ("J2", 35),
    "oe_n": ("J2", 37),
}
#: Driven low, between the bus wires of J2's ribbon.
GUARDS = [("J2", p) for p in (26, 27, 28, 30, 34, 36, 38)]


def _outputs():
    """out[0..63]: J2's pins 4-22, then J3's, then J4's, in pin order."""
    used = set(CONTROL.values()) | set(GUARDS)
    outs = []
    for hdr in ("J2", "J3", "J4"):
        for pin in range(1, 41):
            net = HEADERS[hdr][pin]
            if (hdr, pin) in used or net == "GND" or net.startswith("VCC") or net in RESERVED:
                continue
            outs.append((hdr, pin))
    return outs[:CHANNELS]


#: Output channel k of a board -> (header, pin).
OUTPUTS = _outputs()


def ball(where):
    hdr, pin = where
    return HEADERS[hdr][pin]


def pcf_text():
    lines = [
        "# iCE40-HX8K Breakout Board (ICE40HX8K-B-EVN, CT256): the driver's pins.",
        "# Written by `python hx8k.py --pcf` from its HEADERS (the board's schematic,",
        "# Lattice EB85 Appendix A) and pin choice; a simulation test checks that",
        "# this file and firmware/DRIVER.md's table still match it.",
        "",
    ]
    for name, where in CONTROL.items():
        lines.append(f"set_io {name:<12}{ball(where):<5}# {where[0]} pin {where[1]}")
    for i, where in enumerate(GUARDS):
        lines.append(f"set_io {f'guard[{i}]':<12}{ball(where):<5}# {where[0]} pin {where[1]}, driven low")
    lines.append(f"set_io {'led':<12}{LED_BALL:<5}# LED D9")
    for i, where in enumerate(OUTPUTS):
        lines.append(f"set_io {f'out[{i}]':<12}{ball(where):<5}# {where[0]} pin {where[1]}")
    return "\n".join(lines) + "\n"


class Top(Elaboratable):
    """The board: `channels` (<= 64) driver outputs on out[0..channels-1],
    the rest of the 64 output pins driven low."""

    def __init__(self, channels=CHANNELS, rom_init=None):
        assert 1 <= channels <= CHANNELS
        self.channels = channels
        self.rom_init = rom_init or placeholder_words()
        self.clk_ref = Signal()
        self.sck = Signal()
        self.mosi = Signal()
        self.cs_n = Signal(init=1)
        self.out = Signal(CHANNELS)
        self.oe_n = Signal(init=1)
        self.guard = Signal(len(GUARDS))
        self.led = Signal()

    def ports(self):
        return [self.clk_ref, self.sck, self.mosi, self.cs_n, self.out, self.oe_n,
                self.guard, self.led]

    def elaborate(self, platform):
        m = Module()
        m.domains.sync = ClockDomain()
        pll_clk = Signal()
        locked = Signal()
        m.submodules.pll = Instance(
            "SB_PLL40_CORE",
            p_FEEDBACK_PATH="SIMPLE",
            p_DIVR=0,
            p_DIVF=63,
            p_DIVQ=3,
            p_FILTER_RANGE=1,
            i_REFERENCECLK=self.clk_ref,
            i_RESETB=1,
            i_BYPASS=0,
            o_PLLOUTGLOBAL=pll_clk,
            o_LOCK=locked,
        )
        m.d.comb += ClockSignal("sync").eq(pll_clk)
        m.submodules.reset_sync = ResetSynchronizer(~locked, domain="sync")
        m.submodules.board = board = Board(self.channels, self.rom_init, 8)
        m.d.comb += [
            board.sck.eq(self.sck),
            board.mosi.eq(self.mosi),
            board.cs_n.eq(self.cs_n),
            self.out.eq(board.out),  # zero-extended: unused outputs low
            # LOCK straight from the PLL, not through the clock it makes:
            # if the reference stops, the registers stop with it, and the
            # buffers must let go of the outputs anyway (DS1040: LOCK falls
            # within 50 ns of a loss of lock).
            self.oe_n.eq(~(locked & board.ready)),
            self.guard.eq(0),
            self.led.eq(board.active),
        ]
        return m


def main(argv=None):
    p = argparse.ArgumentParser(description="The HX8K breakout board's top (RTLIL), a slice "
                                "ROM stamp, or the pin file")
    p.add_argument("--channels", type=int, default=CHANNELS, help="outputs this board drives (<= 64)")
    p.add_argument("--rom-hex", help="also write the placeholder ROM contents the netlist is built with")
    p.add_argument("--stamp", action="store_true", help="write a board's ROM stamp to OUT (icebram's hex)")
    p.add_argument("--first", type=int, help="with --stamp: first frame channel this board drives")
    p.add_argument("--total", type=int, help="with --stamp: phases per frame")
    p.add_argument("--pcf", action="store_true", help="print the pin file")
    p.add_argument("out", nargs="?")
    a = p.parse_args(argv)
    if not 1 <= a.channels <= CHANNELS:
        p.error(f"--channels must be 1..{CHANNELS}")
    if a.pcf:
        sys.stdout.write(pcf_text())
        return 0
    if not a.out:
        p.error("OUT is required")
    if a.stamp:
        if a.first is None or a.total is None:
            p.error("--stamp needs --first and --total")
        if not (0 <= a.first and a.first + a.channels <= a.total <= 0xFFFF):
            p.error(f"first {a.first} + channels {a.channels} must be <= total {a.total} <= 65535")
        with open(a.out, "w") as f:
            f.write(hex_lines(stamp_words(a.channels, a.first, a.total)))
        return 0
    top = Top(a.channels)
    if a.rom_hex:
        with open(a.rom_hex, "w") as f:
            f.write(hex_lines(top.rom_init))
    with open(a.out, "w") as f:
        f.write(rtlil.convert(top, name="top", ports=top.ports()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
