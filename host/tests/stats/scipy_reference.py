#!/usr/bin/env python3
"""Reference values for `lmhost::lab::stats`, computed with scipy.

    scipy_reference.py write FIXTURE   # (re)generate the fixture
    scipy_reference.py check FIXTURE   # regenerate in memory, fail on any difference

The datasets come from a SplitMix64 generator written out below (integer
arithmetic, the same on every machine) and are stored as integers over a
denominator (value = num / den * 2**exp2), so that Rust and Python build
bit-identical f64 inputs and agree on every tie and zero. The statistics
and p-values are scipy's: `cargo xtask python` runs `check` with the
pinned scipy, so the committed fixture is scipy's output and not a copy of
the Rust code's. `host/tests/stats_scipy.rs` checks the Rust module
against it (relative error <= 1e-6; absolute <= 1e-12 for p < 1e-10).

Power of the paired t-test is statsmodels' formula (`TTestPower().power`,
two-sided: 1 - nctdtr(df, nc, c) + nctdtr(df, nc, -c), c = t.isf(alpha/2,
df), df = n - 1, nc = d_z * sqrt(n)) computed with scipy.special; when
statsmodels is importable the script also asserts that it agrees.
"""

import json
import math
import sys

import numpy as np
import scipy
import scipy.integrate as si
import scipy.special as sp
import scipy.stats as st

MASK = (1 << 64) - 1


class SplitMix64:
    def __init__(self, seed):
        self.state = seed & MASK

    def next(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def uniform(self):
        return (self.next() >> 11) / float(1 << 53)

    def below(self, n):
        return self.next() % n

    def normal(self):
        # Box-Muller; only used to make data, which is then rounded.
        u1 = 1.0 - self.uniform()
        u2 = self.uniform()
        return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def enc(values, den, exp2=0):
    """Values (None = missing) to the fixture's integer form; the values
    are rounded to 1/den first."""
    num = [None if v is None else int(round(v * den)) for v in values]
    return {"num": num, "den": den, "exp2": exp2}


def dec(e):
    return np.array(
        [np.nan if k is None else math.ldexp(k / e["den"], e["exp2"]) for k in e["num"]],
        dtype=np.float64,
    )


def fnum(v):
    """A float for JSON: None for NaN."""
    v = float(v)
    return None if math.isnan(v) else v


# ---------------------------------------------------------------- Shapiro-Wilk


def shapiro_case(name, data):
    x = dec(data)
    x = x[~np.isnan(x)]
    case = {"name": name, "x": data}
    if len(x) < 3:
        case["degenerate"] = "fewer than 3 values"
        return case
    if np.ptp(x) < 1e-19:
        # AS R94's fault 6 (range below its SMALL = 1e-19): scipy warns
        # ("Input data has range zero") and answers W = p = 1.
        case["degenerate"] = "range below 1e-19"
        return case
    r = st.shapiro(x)
    case["w"] = fnum(r.statistic)
    case["p"] = fnum(r.pvalue)
    return case


def shapiro_cases():
    g = SplitMix64(0x5EED_0001)
    cases = []
    for n in [3, 4, 5, 6, 7, 8, 10, 11, 12, 13, 20, 30, 50, 100, 500, 1000]:
        cases.append(shapiro_case(f"normal n={n}", enc([g.normal() for _ in range(n)], 10000)))
    for n in [5, 11, 12, 40]:
        cases.append(shapiro_case(f"uniform n={n}", enc([g.uniform() for _ in range(n)], 10000)))
    for n in [8, 30, 200]:
        xs = [-math.log(1.0 - g.uniform()) for _ in range(n)]
        cases.append(shapiro_case(f"exponential n={n}", enc(xs, 10000)))
    for n in [10, 13, 20]:
        cases.append(shapiro_case(f"likert 1-7 n={n}", enc([1 + g.below(7) for _ in range(n)], 1)))
    cases.append(shapiro_case("likert skewed n=10", enc([1, 1, 1, 1, 2, 1, 1, 3, 1, 7], 1)))
    cases.append(shapiro_case("n=3 evenly spaced", enc([1, 2, 3], 1)))
    cases.append(shapiro_case("n=3 two tied high", enc([1, 2, 2], 1)))
    cases.append(shapiro_case("n=3 two tied low", enc([1, 1, 2], 1)))
    cases.append(shapiro_case("n=3 uneven", enc([1.0, 1.5, 3.0], 10)))
    cases.append(shapiro_case("n=4 one outlier", enc([0, 0, 0, 1000], 1)))
    cases.append(shapiro_case("n=10 one outlier", enc([0, 0, 0, 0, 0, 0, 0, 0, 0, 1], 1)))
    cases.append(shapiro_case("n=11 one far outlier", enc([1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 1e6], 1)))
    cases.append(shapiro_case("n=30 one far outlier", enc([g.normal() for _ in range(29)] + [1e6], 10000)))
    cases.append(shapiro_case("all equal", enc([4, 4, 4, 4, 4], 1)))
    cases.append(shapiro_case("with missing values", enc([1, None, 3, 4, None, 7, 2], 1)))
    cases.append(shapiro_case("two values after exclusion", enc([1, None, 3], 1)))
    big = [1e12 + g.normal() for _ in range(25)]
    cases.append(shapiro_case("large offset 1e12", enc(big, 1000)))
    tiny = [g.normal() for _ in range(25)]
    cases.append(shapiro_case("small scale 2^-40", enc(tiny, 10000, exp2=-40)))
    cases.append(shapiro_case("tiny scale 2^-900 (range below AS R94's 1e-19)", enc(tiny, 10000, exp2=-900)))
    huge = [g.normal() for _ in range(25)]
    cases.append(shapiro_case("huge scale 2^900", enc(huge, 10000, exp2=900)))
    cases.append(shapiro_case("normal n=5000", enc([g.normal() for _ in range(5000)], 1000)))
    return cases


# ------------------------------------------------------------------ Wilcoxon


def wilcoxon_method(d):
    """Which method scipy's `method='auto'` picks (scipy/stats/_wilcoxon.py):
    more than 50 pairs: normal approximation; otherwise exact when no |d|
    ties and no zeros; otherwise a permutation test of every sign flip
    when n <= 13; otherwise the normal approximation."""
    n = len(d)
    if n > 50:
        return "normal"
    nz = d[d != 0]
    has_ties = len(np.unique(np.abs(nz))) < len(nz)
    if not has_ties and len(nz) == len(d):
        return "exact"
    return "permutation" if n <= 13 else "normal"


def wilcoxon_case(name, xe, ye):
    x, y = dec(xe), dec(ye)
    keep = ~(np.isnan(x) | np.isnan(y))
    x, y = x[keep], y[keep]
    d = x - y
    case = {"name": name, "x": xe, "y": ye}
    n_nonzero = int(np.count_nonzero(d))
    if len(d) == 0:
        case["degenerate"] = "no pairs"
        return case
    if n_nonzero == 0:
        # scipy: p = 1 by permutation (n <= 13), NaN otherwise; no test here.
        case["degenerate"] = "every difference is zero"
        return case
    r = st.wilcoxon(x, y)  # zero_method='wilcox', correction=False, method='auto'
    method = wilcoxon_method(d)
    # Check the method read from scipy's source against scipy itself (a
    # permutation test only against the normal approximation: scipy runs
    # it as a Python loop over 2^n sign flips, seconds at n = 13).
    normal_p = st.wilcoxon(x, y, method="asymptotic").pvalue
    if method == "exact":
        assert st.wilcoxon(x, y, method="exact").pvalue == r.pvalue, name
    elif method == "normal":
        assert normal_p == r.pvalue, name
    elif len(d) <= 11:
        assert st.wilcoxon(x, y, method=st.PermutationMethod()).pvalue == r.pvalue, name
    else:
        assert normal_p != r.pvalue, name
    # R+ and the signed z (tie-corrected, no continuity correction) that
    # the effect size r = z / sqrt(n_nonzero) uses.
    greater = st.wilcoxon(x, y, method="asymptotic", correction=False, alternative="greater")
    r_plus = float(greater.statistic)
    total = n_nonzero * (n_nonzero + 1) / 2
    r_minus = total - r_plus
    z = float(greater.zstatistic)
    case.update(
        {
            "statistic": fnum(r.statistic),
            "p": fnum(r.pvalue),
            "method": method,
            "n": int(len(d)),
            "n_nonzero": n_nonzero,
            "r_plus": r_plus,
            "r_minus": r_minus,
            "z": z,
            "r": z / math.sqrt(n_nonzero),
            "rank_biserial": (r_plus - r_minus) / total,
        }
    )
    return case


def wilcoxon_cases():
    g = SplitMix64(0x5EED_0002)
    cases = []

    def cont(n, shift, den=10000):
        x = [g.normal() for _ in range(n)]
        y = [v + shift + 0.5 * g.normal() for v in x]
        return enc(x, den), enc(y, den)

    for n in [1, 2, 3, 4, 5, 8, 10, 12, 13, 14, 20, 25, 30, 40, 49, 50, 51, 60, 100, 300]:
        cases.append(wilcoxon_case(f"continuous n={n}", *cont(n, 0.3)))
    cases.append(wilcoxon_case("exact boundary n=50 no ties", *cont(50, 0.1, den=1000000)))
    cases.append(wilcoxon_case("normal boundary n=51 no ties", *cont(51, 0.1, den=1000000)))
    cases.append(wilcoxon_case("no effect n=10", *cont(10, 0.0)))
    cases.append(wilcoxon_case("n=3 all positive", enc([2, 3, 5], 1), enc([1, 1, 1], 1)))
    cases.append(wilcoxon_case("n=3 mixed", enc([2, 0, 5], 1), enc([1, 1, 1], 1)))

    def likert(n, p_same):
        x, y = [], []
        for _ in range(n):
            a = 1 + g.below(7)
            b = a if g.uniform() < p_same else 1 + g.below(7)
            x.append(a)
            y.append(b)
        return enc(x, 1), enc(y, 1)

    for n, p_same in [(10, 0.2), (10, 0.5), (11, 0.3), (14, 0.3), (20, 0.3), (50, 0.3), (51, 0.3), (60, 0.1)]:
        cases.append(wilcoxon_case(f"likert n={n} same={p_same}", *likert(n, p_same)))
    cases.append(
        wilcoxon_case(
            "ties no zeros n=13 (permutation)",
            enc([3, 4, 5, 6, 2, 7, 3, 5, 6, 1, 2, 4, 5], 1),
            enc([1, 2, 3, 3, 1, 4, 1, 2, 3, 2, 1, 2, 3], 1),
        )
    )
    cases.append(
        wilcoxon_case(
            "ties no zeros n=14 (normal)",
            enc([3, 4, 5, 6, 2, 7, 3, 5, 6, 1, 2, 4, 5, 6], 1),
            enc([1, 2, 3, 3, 1, 4, 1, 2, 3, 2, 1, 2, 3, 4], 1),
        )
    )
    cases.append(
        wilcoxon_case(
            "zeros no ties n=9 (permutation)",
            enc([1, 2, 3, 4, 5, 6, 7, 8, 9], 1),
            enc([1, 2, 3.5, 3.3, 7.1, 1.4, 7, 11.7, 4.7], 10),
        )
    )
    cases.append(
        wilcoxon_case(
            "zeros no ties n=14 (normal)",
            enc([1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14], 1),
            enc([1, 2, 3.5, 3.3, 7.1, 1.4, 7, 11.7, 4.7, 19.9, 11, 0.8, 10.4, 0.1], 10),
        )
    )
    cases.append(wilcoxon_case("one non-zero difference", enc([1, 2, 3, 4], 1), enc([1, 2, 3, 5], 1)))
    cases.append(wilcoxon_case("all differences zero n=5", enc([1, 2, 3, 4, 5], 1), enc([1, 2, 3, 4, 5], 1)))
    cases.append(wilcoxon_case("all differences zero n=20", enc([3] * 20, 1), enc([3] * 20, 1)))
    cases.append(wilcoxon_case("all differences equal n=8", enc([2] * 8, 1), enc([1] * 8, 1)))
    cases.append(wilcoxon_case("all differences equal n=30", enc([2] * 30, 1), enc([1] * 30, 1)))
    cases.append(
        wilcoxon_case(
            "missing values excluded pairwise",
            enc([1, None, 3, 4, 5, 6, 2, None, 7, 5], 1),
            enc([2, 3, None, 1, 1, 2, 2, None, 1, 4], 1),
        )
    )
    cases.append(wilcoxon_case("only missing pairs", enc([None, 1], 1), enc([2, None], 1)))
    cases.append(
        wilcoxon_case("extreme exact p n=50", enc(list(range(1, 51)), 1), enc([0] * 50, 1))
    )
    cases.append(
        wilcoxon_case("extreme normal p n=300", enc(list(range(1, 301)), 1), enc([0] * 300, 1))
    )
    cases.append(
        wilcoxon_case(
            "magnitudes 2^-1000",
            enc([g.normal() for _ in range(15)], 10000, exp2=-1000),
            enc([g.normal() for _ in range(15)], 10000, exp2=-1000),
        )
    )
    cases.append(
        wilcoxon_case(
            "magnitudes 2^1000",
            enc([g.normal() for _ in range(15)], 10000, exp2=1000),
            enc([g.normal() for _ in range(15)], 10000, exp2=1000),
        )
    )
    return cases


# ------------------------------------------------------------------ Friedman


def friedman_case(name, samples):
    xs = [dec(s) for s in samples]
    m = np.vstack(xs)  # k x n
    keep = ~np.isnan(m).any(axis=0)
    m = m[:, keep]
    case = {"name": name, "samples": samples}
    k, n = m.shape
    if n == 0:
        case["degenerate"] = "no complete blocks"
        return case
    if all(np.ptp(m[:, j]) == 0 for j in range(n)):
        # scipy answers NaN: every block is one tie.
        case["degenerate"] = "every block is tied"
        return case
    r = st.friedmanchisquare(*m)
    case.update(
        {
            "statistic": fnum(r.statistic),
            "p": fnum(r.pvalue),
            "n": int(n),
            "kendall_w": fnum(r.statistic / (n * (k - 1))),
        }
    )
    return case


def friedman_cases():
    g = SplitMix64(0x5EED_0003)
    cases = []
    for k, n, effect in [(3, 3, 0.5), (3, 5, 0.5), (3, 10, 0.8), (4, 10, 0.3), (5, 10, 0.5), (3, 20, 0.2), (6, 30, 0.1), (15, 10, 0.3)]:
        base = [g.normal() for _ in range(n)]
        samples = [enc([b + effect * j + g.normal() for b in base], 10000) for j in range(k)]
        cases.append(friedman_case(f"continuous k={k} n={n}", samples))
    for k, n in [(3, 10), (5, 10), (3, 20), (15, 10)]:
        samples = [enc([1 + g.below(7) for _ in range(n)], 1) for _ in range(k)]
        cases.append(friedman_case(f"likert k={k} n={n}", samples))
    cases.append(
        friedman_case(
            "one block tied",
            [enc([1, 2, 3, 4], 1), enc([1, 3, 2, 5], 1), enc([1, 4, 4, 6], 1)],
        )
    )
    cases.append(
        friedman_case("every block tied", [enc([1, 2, 3], 1), enc([1, 2, 3], 1), enc([1, 2, 3], 1)])
    )
    cases.append(
        friedman_case(
            "missing values drop the block",
            [enc([1, 2, None, 4, 5, 3], 1), enc([2, 3, 3, 5, 7, 1], 1), enc([3, None, 4, 6, 6, 2], 1)],
        )
    )
    n = 200
    cases.append(
        friedman_case(
            "extreme p k=3 n=200",
            [enc([j + 0.1 * g.normal() for _ in range(n)], 10000) for j in range(3)],
        )
    )
    return cases


# ----------------------------------------------------------- paired t power


try:
    from statsmodels.stats.power import TTestPower
except ImportError:  # CI installs scipy only; the formula below is statsmodels'
    TTestPower = None


def power_ref(d, n, alpha):
    """Power of the two-sided paired t-test and where it came from:
    "nct" (scipy.special.nctdtr, statsmodels' formula) or, where nctdtr
    answers NaN (it does for some df and large nc, e.g. df = 1, nc = 8.5),
    "quad": the same power as an integral over S = sqrt(chi2_df / df),
    P(|T| > c) = int (Phi(nc - c s) + Phi(-nc - c s)) f_S(s) ds."""
    df = n - 1
    nc = d * math.sqrt(n)
    c = st.t.isf(alpha / 2, df)
    pw = (1.0 - sp.nctdtr(df, nc, c)) + sp.nctdtr(df, nc, -c)
    if TTestPower is not None:
        sm = TTestPower().power(effect_size=d, nobs=n, alpha=alpha)
        assert (math.isnan(sm) and math.isnan(pw)) or math.isclose(sm, pw, rel_tol=1e-12, abs_tol=1e-15), (d, n, alpha, sm, pw)
    if not math.isnan(pw):
        return float(pw), "nct"
    s = st.chi(df, scale=1 / math.sqrt(df))
    f = lambda x: (sp.ndtr(nc - c * x) + sp.ndtr(-nc - c * x)) * s.pdf(x)
    v, err = si.quad(f, 0, math.inf, epsabs=0, epsrel=1e-13, limit=200)
    assert err < 1e-12 * max(v, 1e-3), (d, n, alpha, v, err)
    return float(v), "quad"


def paired_case(name, xe, ye, alpha=0.05):
    x, y = dec(xe), dec(ye)
    keep = ~(np.isnan(x) | np.isnan(y))
    d = x[keep] - y[keep]
    case = {"name": name, "x": xe, "y": ye, "alpha": alpha, "n": int(len(d))}
    if len(d) < 2:
        case["degenerate"] = "fewer than 2 pairs"
        return case
    sd = float(np.std(d, ddof=1))
    if sd == 0:
        case["degenerate"] = "the differences do not vary"
        return case
    dz = float(np.mean(d)) / sd
    case["d_z"] = dz
    case["power"], case["power_via"] = power_ref(dz, len(d), alpha)
    # scipy's paired t-test on the same pairs, for the record.
    case["t"] = fnum(st.ttest_rel(x[keep], y[keep]).statistic)
    return case


def paired_cases():
    g = SplitMix64(0x5EED_0004)
    cases = []
    for n, shift in [(2, 1.0), (3, 0.5), (5, 0.5), (10, 0.1), (10, 0.5), (10, 1.5), (20, 0.3), (50, 0.2), (100, 0.05)]:
        x = [g.normal() for _ in range(n)]
        y = [v - shift + g.normal() for v in x]
        cases.append(paired_case(f"normal n={n} shift={shift}", enc(x, 10000), enc(y, 10000)))
    for n in [10, 20]:
        x = [1 + g.below(7) for _ in range(n)]
        y = [1 + g.below(7) for _ in range(n)]
        cases.append(paired_case(f"likert n={n}", enc(x, 1), enc(y, 1)))
    cases.append(paired_case("bonferroni alpha 0.05/3", enc([5, 6, 7, 5, 6, 4, 6, 7, 5, 6], 1), enc([3, 4, 4, 5, 3, 4, 2, 5, 4, 3], 1), alpha=0.05 / 3))
    cases.append(paired_case("constant differences", enc([2, 3, 4], 1), enc([1, 2, 3], 1)))
    cases.append(paired_case("one pair", enc([2], 1), enc([1], 1)))
    cases.append(paired_case("near-constant differences", enc([1.001, 2.0, 3.0, 4.0], 1000), enc([0, 1, 2, 3], 1)))
    return cases


def power_grid():
    rows = []
    for alpha in [0.05, 0.01, 0.05 / 3, 0.001]:
        for n in [2, 3, 5, 10, 13, 30, 100]:
            for d in [0.0, 0.05, 0.2, 0.5, -0.8, 1.0, 2.0, 3.5, 6.0, 15.0]:
                pw, via = power_ref(d, n, alpha)
                rows.append({"d": d, "n": n, "alpha": alpha, "power": pw, "via": via})
    return rows


# ------------------------------------------------------- special functions


def special():
    out = {}
    out["norm_sf"] = [[x, float(sp.ndtr(-x))] for x in [-8, -3, -1, -0.1, 0, 0.3, 1, 1.96, 3, 5, 8, 12, 20, 30, 37]]
    out["norm_ppf"] = [[p, float(sp.ndtri(p))] for p in [1e-300, 1e-20, 1e-10, 1e-5, 0.001, 0.025, 0.3, 0.5, 0.7, 0.975, 0.999, 1 - 1e-10]]
    out["chi2_sf"] = [
        [x, df, float(sp.chdtrc(df, x))]
        for df in [1, 2, 3, 4, 14]
        for x in [0.01, 0.5, 1, 2, 5, 10, 30, 100, 400]
    ]
    out["t_sf"] = [
        [t, df, float(st.t.sf(t, df))]
        for df in [1, 2, 3, 9, 29, 99]
        for t in [-5, -1, 0, 0.5, 1, 2, 5, 20, 100]
    ]
    out["t_isf"] = [
        [p, df, float(st.t.isf(p, df))]
        for df in [1, 2, 3, 9, 29, 99]
        for p in [0.4, 0.1, 0.025, 0.005, 0.05 / 30, 1e-6]
    ]
    # nctdtr answers NaN for some t < 0 with a large nc > 0 (values far
    # below 1e-9): those are null here and checked against Phi(-nc),
    # a bound on them, in the Rust test.
    out["nct_cdf"] = [
        [t, df, nc, fnum(sp.nctdtr(df, nc, t))]
        for df in [1, 2, 4, 9, 29, 99]
        for nc in [-3, -0.5, 0, 0.7, 2.5, 6, 12, 25]
        for t in [-4, -1, 0, 0.5, 2, 5, 15]
    ]
    out["ln_gamma"] = [[x, float(sp.gammaln(x))] for x in [0.5, 1, 1.5, 2.5, 10, 10.5, 100.5, 1e4, 1e6]]
    return out


# -------------------------------------------------- the table → the tests


def design():
    """A study like the paper's Experiment 1: 10 participants, 3 LM types
    x 5 radii, two sets each, Likert 1-7; 'not perceived' answers are
    missing. The reference pipeline: mean of a participant's answers per
    condition (missing answers left out; a cell with none is missing),
    then Shapiro-Wilk per condition, Wilcoxon per named pair (pairs with a
    missing cell excluded), Bonferroni within each family (m = the
    family's planned tests), d_z and power at alpha, Friedman per group
    over complete participants, Bonferroni within each family."""
    g = SplitMix64(0x5EED_0005)
    types = ["lms-5hz", "lmm-5hz", "lms-25hz"]
    radii = ["2", "3", "4", "5", "6"]
    boost = {"lms-5hz": 0, "lmm-5hz": -1, "lms-25hz": 2}
    rows = []
    for p in range(10):
        pid = f"p{p + 1:02}"
        for t in types:
            for r in radii:
                for _s in range(2):
                    if t == "lmm-5hz" and r == "2" and p < 7 and g.uniform() < 0.95:
                        v = None  # not perceived
                    else:
                        v = min(7, max(1, 3 + boost[t] + int(r) // 3 + g.below(3) - 1))
                    rows.append([pid, f"{t}/{r}", v])
    alpha = 0.05
    pair_families = [
        {"name": f"type at r={r}", "pairs": [[f"{a}/{r}", f"{b}/{r}"] for a, b in [(types[0], types[1]), (types[0], types[2]), (types[1], types[2])]]}
        for r in radii
    ]
    friedman_families = [
        {"name": "type", "groups": [[f"{t}/{r}" for t in types] for r in radii]},
        {"name": "radius", "groups": [[f"{t}/{r}" for r in radii] for t in types]},
    ]

    cells = {}
    for pid, cond, v in rows:
        cells.setdefault((pid, cond), []).append(v)
    participants = sorted({pid for pid, _, _ in rows})

    def cell(pid, cond):
        vs = [v for v in cells.get((pid, cond), []) if v is not None]
        return float(np.mean(vs)) if vs else math.nan

    conditions = [f"{t}/{r}" for t in types for r in radii]
    normality = []
    for c in conditions:
        x = np.array([cell(p, c) for p in participants])
        x = x[~np.isnan(x)]
        row = {"condition": c, "n": int(len(x))}
        if len(x) >= 3 and np.ptp(x) >= 1e-19:
            r = st.shapiro(x)
            row["w"], row["p"] = float(r.statistic), float(r.pvalue)
        else:
            row["degenerate"] = True
        normality.append(row)

    pairs = []
    for fam in pair_families:
        m = len(fam["pairs"])
        for a, b in fam["pairs"]:
            x = np.array([cell(p, a) for p in participants])
            y = np.array([cell(p, b) for p in participants])
            keep = ~(np.isnan(x) | np.isnan(y))
            x, y = x[keep], y[keep]
            d = x - y
            row = {"family": fam["name"], "a": a, "b": b, "n": int(len(d)), "m": m}
            if np.count_nonzero(d) == 0:
                row["degenerate"] = True
            else:
                w = st.wilcoxon(x, y)
                row["statistic"] = float(w.statistic)
                row["p"] = float(w.pvalue)
                row["p_bonferroni"] = min(1.0, float(w.pvalue) * m)
                row["method"] = wilcoxon_method(d)
            sd = float(np.std(d, ddof=1)) if len(d) >= 2 else 0.0
            if sd > 0:
                row["d_z"] = float(np.mean(d)) / sd
                row["power"], _ = power_ref(row["d_z"], len(d), alpha)
            pairs.append(row)

    friedman = []
    for fam in friedman_families:
        m = len(fam["groups"])
        for grp in fam["groups"]:
            mat = np.array([[cell(p, c) for p in participants] for c in grp])
            keep = ~np.isnan(mat).any(axis=0)
            mat = mat[:, keep]
            row = {"family": fam["name"], "conditions": grp, "n": int(mat.shape[1]), "m": m}
            if mat.shape[1] == 0 or all(np.ptp(mat[:, j]) == 0 for j in range(mat.shape[1])):
                row["degenerate"] = True
            else:
                r = st.friedmanchisquare(*mat)
                row["statistic"] = float(r.statistic)
                row["p"] = float(r.pvalue)
                row["p_bonferroni"] = min(1.0, float(r.pvalue) * m)
            friedman.append(row)

    return {
        "rows": rows,
        "alpha": alpha,
        "pair_families": pair_families,
        "friedman_families": friedman_families,
        "expect": {"normality": normality, "pairs": pairs, "friedman": friedman},
    }


def generate():
    return {
        "about": "scipy reference values for lmhost::lab::stats; made by scipy_reference.py, do not edit",
        "scipy": scipy.__version__,
        "shapiro": shapiro_cases(),
        "wilcoxon": wilcoxon_cases(),
        "friedman": friedman_cases(),
        "paired": paired_cases(),
        "power_grid": power_grid(),
        "special": special(),
        "design": design(),
    }


def diff(a, b, path="$"):
    """First difference between two JSON values (floats within 1e-12)."""
    if isinstance(a, float) and isinstance(b, float):
        return None if math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300) else f"{path}: {a!r} != {b!r}"
    if type(a) is not type(b):
        return f"{path}: {a!r} != {b!r}"
    if isinstance(a, dict):
        if a.keys() != b.keys():
            return f"{path}: keys {sorted(a.keys() ^ b.keys())} differ"
        for k in a:
            d = diff(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = diff(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    return None if a == b else f"{path}: {a!r} != {b!r}"


def main(argv):
    if len(argv) != 3 or argv[1] not in ("write", "check"):
        sys.stderr.write(__doc__)
        return 2
    mode, path = argv[1], argv[2]
    with np.errstate(all="ignore"):
        import warnings

        warnings.simplefilter("ignore")
        fresh = json.loads(json.dumps(generate(), allow_nan=False))
    if mode == "write":
        with open(path + ".tmp", "w") as f:
            json.dump(fresh, f, separators=(",", ":"), allow_nan=False)
            f.write("\n")
        import os

        os.replace(path + ".tmp", path)
        return 0
    with open(path) as f:
        committed = json.load(f)
    d = diff(fresh, committed)
    if d:
        sys.stderr.write(f"{path} is not what scipy {scipy.__version__} gives now; first difference at {d}\n")
        sys.stderr.write(f"regenerate with: python3 {argv[0]} write {path}\n")
        return 1
    print(f"{path}: matches scipy {scipy.__version__}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
