"""The driver on a Lattice iCE40-HX8K Breakout Board (ICE40HX8K-B-EVN):
64 channels per board, pins in `ice40hx8k-b-evn.pcf`.

The 81.92 MHz design clock comes from a 10.24 MHz reference on a header
pin (the Nucleo's crystal-derived clock output, shared by every driver
board on the bus; `firmware/DRIVER.md`) through the HX8K's PLL: 10.24 MHz
x 64 / 8, exact (DIVR 0, DIVF 63, DIVQ 3, filter range 1, as `icepll -i
10.24 -o 81.92` gives). The design is held in reset until the PLL locks.
LED D2 (B5) shows `active` (a latched pattern drives the outputs).

    python hx8k.py --first 0 --total 256 out.il    # RTLIL, top module `top`
"""

import argparse

from amaranth import ClockDomain, ClockSignal, Elaboratable, Instance, Module, ResetSignal, Signal
from amaranth.back import rtlil
from amaranth.lib.cdc import ResetSynchronizer

from lmdriver import LmDriver

#: Channels per breakout board.
CHANNELS = 64


class Top(Elaboratable):
    def __init__(self, first=0, total=CHANNELS):
        self.first, self.total = first, total
        self.clk_ref = Signal()
        self.sck = Signal()
        self.mosi = Signal()
        self.cs_n = Signal(init=1)
        self.out = Signal(CHANNELS)
        self.led = Signal()

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
        drv = LmDriver(CHANNELS, 8, first=self.first, total=self.total)
        m.submodules.drv = drv
        m.d.comb += [
            drv.sck.eq(self.sck),
            drv.mosi.eq(self.mosi),
            drv.cs_n.eq(self.cs_n),
            self.out.eq(drv.out),
            self.led.eq(drv.active),
        ]
        return m


if __name__ == "__main__":
    p = argparse.ArgumentParser(description="Write the HX8K breakout board's top as RTLIL")
    p.add_argument("--first", type=int, default=0, help="first frame channel this board drives")
    p.add_argument("--total", type=int, default=CHANNELS, help="phases per frame")
    p.add_argument("out")
    a = p.parse_args()
    top = Top(a.first, a.total)
    ports = [top.clk_ref, top.sck, top.mosi, top.cs_n, top.out, top.led]
    with open(a.out, "w") as f:
        f.write(rtlil.convert(top, name="top", ports=ports))
