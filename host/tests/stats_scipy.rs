//! `lmhost::lab::stats` against scipy: every statistic and p-value in
//! `stats/reference.json` (written by `stats/scipy_reference.py` with the
//! scipy that `cargo xtask python` pins, and regenerated there to check
//! it) to a relative error of 1e-6, or an absolute error of 1e-12 where
//! the reference is below 1e-10. A case scipy answers with no meaningful
//! number ("degenerate") must be refused here.

use std::fmt::Debug;
use std::path::Path;

use lmhost::lab::stats::special;
use lmhost::lab::stats::table::{
    Design, FriedmanFamily, Observation, PairFamily, Repeats, analyse,
};
use lmhost::lab::stats::{friedman, paired_t, paired_t_power, shapiro_wilk, wilcoxon};
use serde_json::Value;

const REL: f64 = 1e-6;
const ABS: f64 = 1e-12;
const TINY: f64 = 1e-10;
/// The non-central t's absolute accuracy where its terms cancel (see
/// `special_functions_match_scipy`); the power never depends on that tail
/// beyond it.
const NCT_ABS: f64 = 1e-14;

fn fixture() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/stats/reference.json");
    let text = std::fs::read_to_string(&path).expect("the committed scipy fixture");
    serde_json::from_str(&text).expect("the fixture is JSON")
}

/// Collects mismatches so one run lists them all.
#[derive(Default)]
struct Check {
    failures: Vec<String>,
    compared: usize,
    /// Largest relative error among references ≥ TINY, and where.
    worst: (f64, String),
}

impl Check {
    fn close(&mut self, what: &str, got: f64, want: f64) {
        self.compared += 1;
        let ok = if want.abs() < TINY {
            (got - want).abs() <= ABS
        } else {
            let rel = ((got - want) / want).abs();
            if rel > self.worst.0 || self.worst.1.is_empty() {
                self.worst = (rel, what.to_string());
            }
            rel <= REL
        };
        if !ok {
            self.failures
                .push(format!("{what}: got {got:e}, scipy {want:e}"));
        }
    }

    fn truth(&mut self, what: &str, ok: bool) {
        self.compared += 1;
        if !ok {
            self.failures.push(what.to_string());
        }
    }

    /// Each `(key, got)` against the case's value under `key`.
    fn fields(&mut self, what: &str, case: &Value, got: &[(&str, f64)]) {
        for (key, g) in got {
            self.close(&format!("{what} {key}"), *g, num(&case[*key]));
        }
    }

    /// What a scipy case asks of `got`: refused where scipy found the
    /// case degenerate, else a value to compare (returned).
    fn outcome<T: Debug, E: Debug>(
        &mut self,
        what: &str,
        case: &Value,
        got: Result<T, E>,
    ) -> Option<T> {
        if degenerate(case) {
            self.truth(&format!("{what}: refused, got {got:?}"), got.is_err());
            return None;
        }
        match got {
            Ok(r) => Some(r),
            Err(e) => {
                self.truth(&format!("{what}: Err({e:?})"), false);
                None
            }
        }
    }

    /// Each `(key, got)` count equals the row's value under `key`: one
    /// check.
    fn counts(&mut self, what: &str, want: &Value, got: &[(&str, usize)]) {
        let differ: Vec<String> = got
            .iter()
            .filter(|(key, g)| want[*key].as_u64() != Some(*g as u64))
            .map(|(key, g)| format!("{key} {g} vs scipy {}", want[*key]))
            .collect();
        self.truth(&format!("{what}: {}", differ.join(", ")), differ.is_empty());
    }

    /// A test of a corrected family: its statistic and p, and its
    /// Bonferroni-corrected p, against the row's.
    fn corrected(&mut self, what: &str, want: &Value, test: (f64, f64), p_bonferroni: Option<f64>) {
        let (statistic, p) = test;
        let p_bonferroni = p_bonferroni.unwrap_or(f64::NAN);
        let got = [
            ("statistic", statistic),
            ("p", p),
            ("p_bonferroni", p_bonferroni),
        ];
        self.fields(what, want, &got);
    }

    /// A study-table test: done where the fixture has its value
    /// (`expected`), left undone where it does not; the result if done.
    fn done<T: Debug>(
        &mut self,
        what: &str,
        got: Option<T>,
        expected: bool,
        want: &Value,
    ) -> Option<T> {
        match (got, expected) {
            (Some(r), true) => Some(r),
            (None, false) => None,
            (g, _) => {
                self.truth(&format!("{what}: {g:?} vs {want}"), false);
                None
            }
        }
    }

    fn finish(self, section: &str, at_least: usize) {
        assert!(
            self.failures.is_empty(),
            "{section}: {} of {} checks differ from scipy:\n{}",
            self.failures.len(),
            self.compared,
            self.failures.join("\n")
        );
        assert!(
            self.compared >= at_least,
            "{section}: only {} checks ran",
            self.compared
        );
        println!(
            "{section}: {} checks; largest relative error {:.1e} ({})",
            self.compared, self.worst.0, self.worst.1
        );
    }
}

/// Whether scipy found the case degenerate (no meaningful number).
fn degenerate(case: &Value) -> bool {
    case.get("degenerate").is_some()
}

/// The fixture's exact encoding of a dataset: value = num / den · 2^exp2.
fn values(e: &Value) -> Vec<f64> {
    let den = e["den"].as_i64().unwrap() as f64;
    let exp2 = e["exp2"].as_i64().unwrap() as i32;
    e["num"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| match k.as_i64() {
            Some(k) => ldexp(k as f64 / den, exp2),
            None => f64::NAN,
        })
        .collect()
}

/// x · 2^e, exact (in two steps so that 2^e itself never overflows).
fn ldexp(x: f64, e: i32) -> f64 {
    let half = e / 2;
    x * 2f64.powi(half) * 2f64.powi(e - half)
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// Checks each case of the fixture's `section` with `check`, given the
/// case's name for messages (`{section} {name}`); the fixture and the
/// checks made, to finish.
fn each_case(section: &str, mut check: impl FnMut(&mut Check, &str, &Value)) -> (Value, Check) {
    let f = fixture();
    let mut c = Check::default();
    for case in f[section].as_array().unwrap() {
        let what = format!("{section} {}", case["name"].as_str().unwrap());
        check(&mut c, &what, case);
    }
    (f, c)
}

#[test]
fn shapiro_wilk_matches_scipy() {
    let (_, c) = each_case("shapiro", |c, what, case| {
        let x = values(&case["x"]);
        if let Some(r) = c.outcome(what, case, shapiro_wilk(&x)) {
            c.fields(what, case, &[("w", r.w), ("p", r.p)]);
        }
    });
    c.finish("Shapiro-Wilk", 80);
}

#[test]
fn wilcoxon_matches_scipy() {
    let (_, c) = each_case("wilcoxon", |c, what, case| {
        let x = values(&case["x"]);
        let y = values(&case["y"]);
        let Some(r) = c.outcome(what, case, wilcoxon(&x, &y)) else {
            return;
        };
        c.truth(
            &format!(
                "{what}: method {} vs scipy {}",
                r.method.name(),
                case["method"]
            ),
            r.method.name() == case["method"].as_str().unwrap(),
        );
        c.counts(what, case, &[("n", r.n), ("n_nonzero", r.n_nonzero)]);
        c.fields(
            what,
            case,
            &[
                ("statistic", r.statistic),
                ("p", r.p),
                ("r_plus", r.r_plus),
                ("r_minus", r.r_minus),
                ("z", r.z),
                ("r", r.r),
                ("rank_biserial", r.rank_biserial),
            ],
        );
    });
    c.finish("Wilcoxon", 300);
}

#[test]
fn friedman_matches_scipy() {
    let (_, c) = each_case("friedman", |c, what, case| {
        let samples: Vec<Vec<f64>> = case["samples"]
            .as_array()
            .unwrap()
            .iter()
            .map(values)
            .collect();
        let slices: Vec<&[f64]> = samples.iter().map(Vec::as_slice).collect();
        let Some(r) = c.outcome(what, case, friedman(&slices)) else {
            return;
        };
        c.counts(what, case, &[("n", r.n)]);
        c.fields(
            what,
            case,
            &[
                ("statistic", r.statistic),
                ("p", r.p),
                ("kendall_w", r.kendall_w),
            ],
        );
    });
    c.finish("Friedman", 50);
}

#[test]
fn paired_t_power_matches_statsmodels() {
    let (f, mut c) = each_case("paired", |c, what, case| {
        let x = values(&case["x"]);
        let y = values(&case["y"]);
        let alpha = num(&case["alpha"]);
        if let Some(r) = c.outcome(what, case, paired_t(&x, &y, alpha)) {
            c.fields(
                what,
                case,
                &[("d_z", r.d_z), ("t", r.t), ("power", r.power)],
            );
        }
    });
    for row in f["power_grid"].as_array().unwrap() {
        let (d, n, alpha) = (
            num(&row["d"]),
            row["n"].as_u64().unwrap() as usize,
            num(&row["alpha"]),
        );
        let what = format!("power d={d} n={n} alpha={alpha} (via {})", row["via"]);
        match paired_t_power(d, n, alpha) {
            Ok(p) => c.close(&what, p, num(&row["power"])),
            Err(e) => c.truth(&format!("{what}: {e}"), false),
        }
    }
    c.finish("paired t", 280);
}

/// A special function of its arguments.
type Special = fn(&[f64]) -> f64;

#[test]
fn special_functions_match_scipy() {
    let f = fixture();
    let s = &f["special"];
    let mut c = Check::default();
    let rows = |k: &str| {
        s[k].as_array()
            .unwrap()
            .iter()
            .map(|r| r.as_array().unwrap().iter().map(num).collect::<Vec<f64>>())
            .collect::<Vec<_>>()
    };
    // Each function's rows: its arguments, then scipy's value.
    let functions: [(&str, Special); 6] = [
        ("norm_sf", |a| special::norm_sf(a[0])),
        ("norm_ppf", |a| special::norm_ppf(a[0])),
        ("chi2_sf", |a| special::chi2_sf(a[0], a[1])),
        ("t_sf", |a| special::t_sf(a[0], a[1])),
        ("t_isf", |a| special::t_isf(a[0], a[1])),
        ("ln_gamma", |a| special::ln_gamma(a[0])),
    ];
    for (key, f) in functions {
        for r in rows(key) {
            let (args, want) = r.split_at(r.len() - 1);
            let shown: Vec<String> = args.iter().map(f64::to_string).collect();
            c.close(&format!("{key}({})", shown.join(", ")), f(args), want[0]);
        }
    }
    for r in rows("nct_cdf") {
        let (t, df, nc) = (r[0], r[1], r[2]);
        let got = special::nct_cdf(t, df, nc);
        let what = format!("nct_cdf({t}, {df}, {nc})");
        if r[3].is_nan() {
            // scipy answers NaN here (t < 0, nc ≫ 0); T ≤ t < 0 needs
            // Z + nc < 0, so the value lies in [0, Φ(−nc)].
            c.truth(
                &format!("{what} = {got:e} within [0, Φ(−nc)]"),
                (0.0..=special::norm_sf(nc)).contains(&got),
            );
        } else if (got - r[3]).abs() <= NCT_ABS {
            // A lower tail with nc > 0 is a difference of cancelling
            // sums, good to about 1e-14 absolute in scipy (Boost) as here:
            // at nct_cdf(−4, 99, 2.5) ≈ 2.0205412e-10 (an mpmath integral
            // to 40 digits) scipy is 9e-6 off, relatively.
            c.truth(&what, true);
        } else {
            c.close(&what, got, r[3]);
        }
    }
    c.finish("special functions", 400);
}

#[test]
fn study_table_matches_scipy_pipeline() {
    let f = fixture();
    let d = &f["design"];
    let rows: Vec<Observation> = d["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            Observation::new(
                r[0].as_str().unwrap(),
                r[1].as_str().unwrap(),
                r[2].as_f64(),
            )
        })
        .collect();
    let strings = |v: &Value| -> Vec<String> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_str().unwrap().to_string())
            .collect()
    };
    let design = Design {
        alpha: num(&d["alpha"]),
        repeats: Repeats::Mean,
        pairs: d["pair_families"]
            .as_array()
            .unwrap()
            .iter()
            .map(|fam| PairFamily {
                name: fam["name"].as_str().unwrap().to_string(),
                pairs: fam["pairs"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|p| {
                        let p = strings(p);
                        (p[0].clone(), p[1].clone())
                    })
                    .collect(),
            })
            .collect(),
        friedman: d["friedman_families"]
            .as_array()
            .unwrap()
            .iter()
            .map(|fam| FriedmanFamily {
                name: fam["name"].as_str().unwrap().to_string(),
                groups: fam["groups"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(strings)
                    .collect(),
            })
            .collect(),
    };
    let out = analyse(&rows, &design).expect("the design is valid");
    let expect = &d["expect"];
    let mut c = Check::default();

    let normality = expect["normality"].as_array().unwrap();
    c.truth(
        "one normality row per condition",
        out.normality.len() == normality.len(),
    );
    for (got, want) in out.normality.iter().zip(normality) {
        let what = format!("normality {}", got.condition);
        c.truth(
            &format!("{what}: condition"),
            got.condition == want["condition"].as_str().unwrap(),
        );
        c.counts(&what, want, &[("n", got.n)]);
        if let Some(r) = c.done(&what, got.shapiro_wilk.done(), !degenerate(want), want) {
            c.fields(&what, want, &[("w", r.w), ("p", r.p)]);
        }
    }

    let pairs = expect["pairs"].as_array().unwrap();
    c.truth("one row per pair", out.pairs.len() == pairs.len());
    for (got, want) in out.pairs.iter().zip(pairs) {
        let what = format!("pair {} − {}", got.a, got.b);
        c.truth(
            &format!("{what}: names"),
            got.a == want["a"].as_str().unwrap() && got.b == want["b"].as_str().unwrap(),
        );
        c.counts(&what, want, &[("n", got.n), ("m", got.m)]);
        if let Some(w) = c.done(&what, got.wilcoxon.done(), !degenerate(want), want) {
            c.corrected(&what, want, (w.statistic, w.p), got.p_bonferroni);
            c.truth(
                &format!("{what}: method"),
                w.method.name() == want["method"].as_str().unwrap(),
            );
        }
        if let Some(t) = c.done(&what, got.paired_t.done(), want.get("d_z").is_some(), want) {
            c.fields(&what, want, &[("d_z", t.d_z), ("power", t.power)]);
        }
    }

    let friedman_rows = expect["friedman"].as_array().unwrap();
    c.truth(
        "one row per Friedman group",
        out.friedman.len() == friedman_rows.len(),
    );
    for (got, want) in out.friedman.iter().zip(friedman_rows) {
        let what = format!("friedman {} {:?}", got.family, got.conditions);
        c.counts(&what, want, &[("n", got.n), ("m", got.m)]);
        if let Some(r) = c.done(&what, got.friedman.done(), !degenerate(want), want) {
            c.corrected(&what, want, (r.statistic, r.p), got.p_bonferroni);
        }
    }
    c.finish("study table", 150);
}
