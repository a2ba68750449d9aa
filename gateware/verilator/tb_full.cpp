// Full-width check of the driver gateware under Verilator: the SPI frames
// lm-fw-core sent for the paper's LM-M at full width (996 transducers),
// into BOARDS driver boards on one bus (each a slice of the frame, reset
// at a different time), every carrier period of every channel checked.
// Built and run by `gateware/full_width.py` (`cargo xtask gateware`).
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <vector>
#include <set>
#include "Vtop.h"
#include "verilated.h"
#include "boards.h"  // BOARDS, FIRST[], WIDTH[], TOTAL, K, word(), ps(), good(), bad()

static const int COUNTS = 256;
static const int PERIOD = COUNTS * K;
static const int HALF = 3;   // clocks per SCK half period: SCK = f_clk / 6 (16 MHz at 81.92 MHz is / 5.12)
static const int SYNC = 4;   // pin to logic

// What one channel did in one carrier period: its level at the period
// start and the offsets of its rising and falling edges after it.
struct Wave {
    int level0 = 0;
    int rises = 0, falls = 0;
    long rise = -1, fall = -1;
};

struct Board {
    std::vector<uint32_t> prev;
    long start = -1;          // current period's start clock
    int shown = -1;           // frame shown in it (-1: none)
    std::vector<Wave> ch;     // per channel, this period
    std::vector<long> starts; // period starts after the first frame
};

int main(int argc, char** argv) {
    if (argc < 2) { fprintf(stderr, "usage: %s FRAMES.bin\n", argv[0]); return 2; }
    FILE* fp = fopen(argv[1], "rb");
    if (!fp) { perror(argv[1]); return 2; }
    std::vector<std::vector<uint8_t>> frames;
    for (;;) {
        uint8_t h[4];
        if (fread(h, 1, 4, fp) != 4) break;
        uint32_t n = h[0] | h[1] << 8 | h[2] << 16 | (uint32_t)h[3] << 24;
        std::vector<uint8_t> f(n);
        if (fread(f.data(), 1, n, fp) != n) { fprintf(stderr, "truncated frames file\n"); return 2; }
        frames.push_back(f);
    }
    fclose(fp);
    const int HDR = 7;
    for (auto& f : frames)
        if ((int)f.size() != HDR + TOTAL) { fprintf(stderr, "a frame of %zu bytes, want %d\n", f.size(), HDR + TOTAL); return 2; }

    Verilated::commandArgs(argc, argv);
    Vtop* t = new Vtop;
    long cycle = 0;
    std::vector<Board> b(BOARDS);
    for (int i = 0; i < BOARDS; i++) { b[i].prev.assign((WIDTH[i] + 31) / 32, 0); b[i].ch.assign(WIDTH[i], Wave()); }
    std::vector<long> cs_high;
    long first_latch_after = -1;
    double worst = 0;
    long periods = 0, partial = 0, edge_checks = 0;
    std::vector<long> first_shown(frames.size(), -1);

    auto finish = [&](int i, bool at_end) {
        Board& B = b[i];
        if (B.start < 0) return;
        long len = cycle - B.start;
        if (len != PERIOD) {
            // Cut short by the carrier restart of a latch from silence: it
            // must have been silent. The run's last, unfinished one is not
            // a period.
            if (!at_end)
                for (int c = 0; c < WIDTH[i]; c++)
                    if (B.ch[c].level0 || B.ch[c].rises || B.ch[c].falls) { partial++; break; }
            return;
        }
        periods++;
        const std::vector<uint8_t>* f = B.shown >= 0 ? &frames[B.shown] : nullptr;
        // The duty the frame's amplitude and intensity give (DRIVER.md).
        int duty = f ? (((*f)[1] * (*f)[2] * 129 + 32768) >> 16) : 0;
        bool whole = true;
        auto lsb = [&](long o, int want) {
            double err = (double)o / K - want;
            while (err > COUNTS / 2) err -= COUNTS;
            while (err < -COUNTS / 2) err += COUNTS;
            return err < 0 ? -err : err;
        };
        for (int c = 0; c < WIDTH[i]; c++) {
            const Wave& w = B.ch[c];
            if (duty == 0) { if (w.level0 || w.rises || w.falls) whole = false; continue; }
            // High while (count - phase) mod 256 < duty: at most one rise
            // (at the phase) and one fall (duty later) inside the period.
            int p = (*f)[HDR + FIRST[i] + c];
            int end = (p + duty) % COUNTS;
            int high0 = ((COUNTS - p) % COUNTS) < duty;
            if (w.level0 != high0 || w.rises != (p != 0) || w.falls != (end != 0)) { whole = false; continue; }
            if (w.rises) { double e = lsb(w.rise, p); if (e > worst) worst = e; }
            if (w.falls) { double e = lsb(w.fall, end); if (e > worst) worst = e; }
            edge_checks++;
        }
        if (!whole) partial++;
    };

    auto tick = [&]() {
        t->clk = 0; t->eval();
        t->clk = 1; t->eval();
        cycle++;
        for (int i = 0; i < BOARDS; i++) {
            Board& B = b[i];
            bool begins = ps(t, i);
            if (begins) {
                finish(i, false);
                B.start = cycle;
                int g = good(t, i);
                B.shown = g - 1;
                if (B.shown >= 0 && first_shown[B.shown] < 0 && i == 0) first_shown[B.shown] = cycle;
                if (first_latch_after >= 0 && cycle > first_latch_after) B.starts.push_back(cycle);
            }
            for (size_t w = 0; w < B.prev.size(); w++) {
                uint32_t cur = word(t, i, w);
                uint32_t rise = cur & ~B.prev[w], fall = B.prev[w] & ~cur;
                B.prev[w] = cur;
                if (begins) {
                    for (int bit = 0; bit < 32 && (int)w * 32 + bit < WIDTH[i]; bit++) {
                        Wave& x = B.ch[w * 32 + bit];
                        x = Wave();
                        x.level0 = (cur >> bit) & 1;
                    }
                    continue;
                }
                if (B.start < 0) continue;
                while (rise) {
                    int c = (int)w * 32 + __builtin_ctz(rise);
                    rise &= rise - 1;
                    if (c < WIDTH[i]) { B.ch[c].rises++; B.ch[c].rise = cycle - B.start; }
                }
                while (fall) {
                    int c = (int)w * 32 + __builtin_ctz(fall);
                    fall &= fall - 1;
                    if (c < WIDTH[i]) { B.ch[c].falls++; B.ch[c].fall = cycle - B.start; }
                }
            }
        }
    };
    auto put = [&](int cs, int sck, int mosi, int n) {
        for (int k = 0; k < n; k++) { t->cs_n = cs; t->sck = sck; t->mosi = mosi; tick(); }
    };

    // Reset, released board by board 300 clocks apart.
    t->cs_n = 1; t->sck = 0; t->mosi = 0;
    for (int r = 0; r < 3 + 300 * BOARDS; r++) {
        uint32_t mask = 0;
        for (int i = 0; i < BOARDS; i++) if (r < 3 + 300 * i) mask |= 1u << i;
        t->rst = mask;
        tick();
    }
    t->rst = 0;
    put(1, 0, 0, PERIOD + 37);
    srand(17);
    for (size_t j = 0; j < frames.size(); j++) {
        const auto& f = frames[j];
        put(0, 0, 0, HALF);
        for (size_t bit = 0; bit < f.size() * 8; bit++) {
            int v = (f[bit / 8] >> (7 - bit % 8)) & 1;
            put(0, 0, v, HALF);
            put(0, 1, v, HALF);
        }
        put(0, 0, 0, HALF);
        cs_high.push_back(cycle);
        if (j == 0) first_latch_after = cycle + SYNC + 2;
        put(1, 0, 0, PERIOD + 10 + rand() % PERIOD);
    }
    put(1, 0, 0, 2 * PERIOD);
    for (int i = 0; i < BOARDS; i++) finish(i, true);

    int passed = 0, failed = 0;
    auto check = [&](bool ok, const char* name, const char* detail) {
        if (ok) passed++; else failed++;
        printf("%s %s%s%s\n", ok ? "ok  " : "FAIL", name, detail[0] ? ": " : "", detail);
    };
    char d[256];
    snprintf(d, sizeof d, "%ld channel-periods, max |edge - planned| = %.3f LSB", edge_checks, worst);
    check(edge_checks > 0 && worst <= 1.0, "every rising edge at its planned phase, every fall a duty later", d);
    snprintf(d, sizeof d, "%ld whole periods on %d boards, %ld not one whole frame", periods, BOARDS, partial);
    check(periods > 0 && partial == 0, "every period shows one whole frame on every channel", d);
    long lat_max = 0; int unseen = 0;
    for (size_t j = 0; j < frames.size(); j++) {
        if (first_shown[j] < 0) { unseen++; continue; }
        long lat = first_shown[j] - cs_high[j];
        if (lat > lat_max) lat_max = lat;
    }
    snprintf(d, sizeof d, "%zu frames, %d never shown, latch to output max %ld clocks (%.2f us; period %d)",
             frames.size(), unseen, lat_max, lat_max / (40e3 * COUNTS * K) * 1e6, PERIOD);
    check(unseen == 0 && lat_max <= PERIOD + SYNC + 2, "each frame shown from the period after its CS high", d);
    bool same = true;
    for (int i = 1; i < BOARDS; i++) same = same && b[i].starts == b[0].starts;
    snprintf(d, sizeof d, "%zu period starts compared", b[0].starts.size());
    check(same && !b[0].starts.empty(), "boards reset apart share the carrier phase", d);
    bool counts = true;
    for (int i = 0; i < BOARDS; i++) counts = counts && good(t, i) == (int)frames.size() && bad(t, i) == 0;
    check(counts, "each board latched every frame, none dropped", "");
    printf("full width: %d channels on %d boards, %zu frames, %ld clocks\n", TOTAL, BOARDS, frames.size(), cycle);
    printf("%d passed, %d failed\n", passed, failed);
    t->final();
    delete t;
    return failed ? 1 : 0;
}
