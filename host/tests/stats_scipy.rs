//! `lmhost::lab::stats` against scipy: every statistic and p-value in
//! `stats/reference.json` (written by `stats/scipy_reference.py` with the
//! scipy that `cargo xtask python` pins, and regenerated there to check
//! it) to a relative error of 1e-6, or an absolute error of 1e-12 where
//! the reference is below 1e-10. A case scipy answers with no meaningful
//! number ("degenerate") must be refused here.

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

fn name(case: &Value) -> &str {
    case["name"].as_str().unwrap()
}

#[test]
fn shapiro_wilk_matches_scipy() {
    let f = fixture();
    let mut c = Check::default();
    for case in f["shapiro"].as_array().unwrap() {
        let x = values(&case["x"]);
        let got = shapiro_wilk(&x);
        let n = name(case);
        if case.get("degenerate").is_some() {
            c.truth(&format!("shapiro {n}: refused, got {got:?}"), got.is_err());
            continue;
        }
        let Ok(r) = got else {
            c.truth(&format!("shapiro {n}: {got:?}"), false);
            continue;
        };
        c.close(&format!("shapiro {n} W"), r.w, num(&case["w"]));
        c.close(&format!("shapiro {n} p"), r.p, num(&case["p"]));
    }
    c.finish("Shapiro-Wilk", 80);
}

#[test]
fn wilcoxon_matches_scipy() {
    let f = fixture();
    let mut c = Check::default();
    for case in f["wilcoxon"].as_array().unwrap() {
        let x = values(&case["x"]);
        let y = values(&case["y"]);
        let got = wilcoxon(&x, &y);
        let n = name(case);
        if case.get("degenerate").is_some() {
            c.truth(&format!("wilcoxon {n}: refused, got {got:?}"), got.is_err());
            continue;
        }
        let Ok(r) = got else {
            c.truth(&format!("wilcoxon {n}: {got:?}"), false);
            continue;
        };
        c.truth(
            &format!(
                "wilcoxon {n}: method {} vs scipy {}",
                r.method.name(),
                case["method"]
            ),
            r.method.name() == case["method"].as_str().unwrap(),
        );
        c.truth(
            &format!("wilcoxon {n}: n {} / {}", r.n, r.n_nonzero),
            r.n as u64 == case["n"].as_u64().unwrap()
                && r.n_nonzero as u64 == case["n_nonzero"].as_u64().unwrap(),
        );
        c.close(
            &format!("wilcoxon {n} statistic"),
            r.statistic,
            num(&case["statistic"]),
        );
        c.close(&format!("wilcoxon {n} p"), r.p, num(&case["p"]));
        c.close(&format!("wilcoxon {n} R+"), r.r_plus, num(&case["r_plus"]));
        c.close(
            &format!("wilcoxon {n} R-"),
            r.r_minus,
            num(&case["r_minus"]),
        );
        c.close(&format!("wilcoxon {n} z"), r.z, num(&case["z"]));
        c.close(&format!("wilcoxon {n} r"), r.r, num(&case["r"]));
        c.close(
            &format!("wilcoxon {n} rank-biserial"),
            r.rank_biserial,
            num(&case["rank_biserial"]),
        );
    }
    c.finish("Wilcoxon", 300);
}

#[test]
fn friedman_matches_scipy() {
    let f = fixture();
    let mut c = Check::default();
    for case in f["friedman"].as_array().unwrap() {
        let samples: Vec<Vec<f64>> = case["samples"]
            .as_array()
            .unwrap()
            .iter()
            .map(values)
            .collect();
        let slices: Vec<&[f64]> = samples.iter().map(Vec::as_slice).collect();
        let got = friedman(&slices);
        let n = name(case);
        if case.get("degenerate").is_some() {
            c.truth(&format!("friedman {n}: refused, got {got:?}"), got.is_err());
            continue;
        }
        let Ok(r) = got else {
            c.truth(&format!("friedman {n}: {got:?}"), false);
            continue;
        };
        c.truth(
            &format!("friedman {n}: n {}", r.n),
            r.n as u64 == case["n"].as_u64().unwrap(),
        );
        c.close(
            &format!("friedman {n} statistic"),
            r.statistic,
            num(&case["statistic"]),
        );
        c.close(&format!("friedman {n} p"), r.p, num(&case["p"]));
        c.close(
            &format!("friedman {n} Kendall's W"),
            r.kendall_w,
            num(&case["kendall_w"]),
        );
    }
    c.finish("Friedman", 50);
}

#[test]
fn paired_t_power_matches_statsmodels() {
    let f = fixture();
    let mut c = Check::default();
    for case in f["paired"].as_array().unwrap() {
        let x = values(&case["x"]);
        let y = values(&case["y"]);
        let alpha = num(&case["alpha"]);
        let got = paired_t(&x, &y, alpha);
        let n = name(case);
        if case.get("degenerate").is_some() {
            c.truth(&format!("paired {n}: refused, got {got:?}"), got.is_err());
            continue;
        }
        let Ok(r) = got else {
            c.truth(&format!("paired {n}: {got:?}"), false);
            continue;
        };
        c.close(&format!("paired {n} d_z"), r.d_z, num(&case["d_z"]));
        c.close(&format!("paired {n} t"), r.t, num(&case["t"]));
        c.close(&format!("paired {n} power"), r.power, num(&case["power"]));
    }
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
    for r in rows("norm_sf") {
        c.close(&format!("norm_sf({})", r[0]), special::norm_sf(r[0]), r[1]);
    }
    for r in rows("norm_ppf") {
        c.close(
            &format!("norm_ppf({})", r[0]),
            special::norm_ppf(r[0]),
            r[1],
        );
    }
    for r in rows("chi2_sf") {
        c.close(
            &format!("chi2_sf({}, {})", r[0], r[1]),
            special::chi2_sf(r[0], r[1]),
            r[2],
        );
    }
    for r in rows("t_sf") {
        c.close(
            &format!("t_sf({}, {})", r[0], r[1]),
            special::t_sf(r[0], r[1]),
            r[2],
        );
    }
    for r in rows("t_isf") {
        c.close(
            &format!("t_isf({}, {})", r[0], r[1]),
            special::t_isf(r[0], r[1]),
            r[2],
        );
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
    for r in rows("ln_gamma") {
        c.close(
            &format!("ln_gamma({})", r[0]),
            special::ln_gamma(r[0]),
            r[1],
        );
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
        c.truth(
            &format!("{what}: n"),
            got.n as u64 == want["n"].as_u64().unwrap(),
        );
        match (got.shapiro_wilk.done(), want.get("degenerate").is_some()) {
            (Some(r), false) => {
                c.close(&format!("{what} W"), r.w, num(&want["w"]));
                c.close(&format!("{what} p"), r.p, num(&want["p"]));
            }
            (None, true) => {}
            (g, _) => c.truth(&format!("{what}: {g:?} vs {want}"), false),
        }
    }

    let pairs = expect["pairs"].as_array().unwrap();
    c.truth("one row per pair", out.pairs.len() == pairs.len());
    for (got, want) in out.pairs.iter().zip(pairs) {
        let what = format!("pair {} − {}", got.a, got.b);
        c.truth(
            &format!("{what}: names, n, m"),
            got.a == want["a"].as_str().unwrap()
                && got.b == want["b"].as_str().unwrap()
                && got.n as u64 == want["n"].as_u64().unwrap()
                && got.m as u64 == want["m"].as_u64().unwrap(),
        );
        match (got.wilcoxon.done(), want.get("degenerate").is_some()) {
            (Some(w), false) => {
                c.close(
                    &format!("{what} statistic"),
                    w.statistic,
                    num(&want["statistic"]),
                );
                c.close(&format!("{what} p"), w.p, num(&want["p"]));
                c.close(
                    &format!("{what} p Bonferroni"),
                    got.p_bonferroni.unwrap(),
                    num(&want["p_bonferroni"]),
                );
                c.truth(
                    &format!("{what}: method"),
                    w.method.name() == want["method"].as_str().unwrap(),
                );
            }
            (None, true) => {}
            (g, _) => c.truth(&format!("{what}: {g:?} vs {want}"), false),
        }
        match (got.paired_t.done(), want.get("d_z")) {
            (Some(t), Some(dz)) => {
                c.close(&format!("{what} d_z"), t.d_z, num(dz));
                c.close(&format!("{what} power"), t.power, num(&want["power"]));
            }
            (None, None) => {}
            (g, _) => c.truth(&format!("{what}: {g:?} vs {want}"), false),
        }
    }

    let friedman_rows = expect["friedman"].as_array().unwrap();
    c.truth(
        "one row per Friedman group",
        out.friedman.len() == friedman_rows.len(),
    );
    for (got, want) in out.friedman.iter().zip(friedman_rows) {
        let what = format!("friedman {} {:?}", got.family, got.conditions);
        c.truth(
            &format!("{what}: n, m"),
            got.n as u64 == want["n"].as_u64().unwrap()
                && got.m as u64 == want["m"].as_u64().unwrap(),
        );
        match (got.friedman.done(), want.get("degenerate").is_some()) {
            (Some(r), false) => {
                c.close(
                    &format!("{what} statistic"),
                    r.statistic,
                    num(&want["statistic"]),
                );
                c.close(&format!("{what} p"), r.p, num(&want["p"]));
                c.close(
                    &format!("{what} p Bonferroni"),
                    got.p_bonferroni.unwrap(),
                    num(&want["p_bonferroni"]),
                );
            }
            (None, true) => {}
            (g, _) => c.truth(&format!("{what}: {g:?} vs {want}"), false),
        }
    }
    c.finish("study table", 150);
}
