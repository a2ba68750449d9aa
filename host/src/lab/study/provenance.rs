//! What a run records of the rig it ran on, and the check that a resumed
//! session continues on the same rig: the scene (its file and the CRC-32
//! of its text), the backend and port, the library's CRCs as planned for
//! the device, the time scale. A trial's row carries its wall-clock time
//! (RFC 3339 UTC, formatted here without a date library) and the device's
//! health over it.

use super::record::Run;
pub use super::record::SceneRecord;
use crate::error::InputError;
use crate::lab::session::Session;
use crate::plan::scene::Scene;

/// The scene of `--scene` (`None`: the built-in one) and its record.
pub fn load_scene(path: Option<&std::path::Path>) -> Result<(Scene, SceneRecord), InputError> {
    Ok(match path {
        Some(p) => {
            let text = crate::limits::read_text_file("scene file", p)?;
            let scene = Scene::from_toml(&text, &p.display().to_string())?;
            (scene, SceneRecord::of(Some(p), Some(&text)))
        }
        None => (Scene::default(), SceneRecord::of(None, None)),
    })
}

/// This run's record in `session.json`: the device as it described
/// itself, every library entry as planned for it (id, CRC-32, timing),
/// the scene, the time scale and the finger.
pub fn run_record(
    session: &Session,
    first_trial: usize,
    o: &super::RunOptions,
    scene: SceneRecord,
) -> anyhow::Result<Run> {
    let info = session.info();
    Ok(Run {
        started_unix_s: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
        first_trial,
        lmhost_version: env!("CARGO_PKG_VERSION").into(),
        device: serde_json::to_value(info)?,
        library: session
            .loaded()
            .iter()
            .map(|l| {
                serde_json::json!({
                    "id": l.id,
                    "crc32": format!("{:08x}", l.crc32),
                    "timing": l.planned.timing,
                })
            })
            .collect(),
        time_scale: o.time_scale,
        finger: format!("{:?}", o.finger),
        scene: Some(scene),
        backend: info.backend.clone(),
        port: info.port.clone(),
        resumed_anyway: None,
        instruments: o.instruments.as_ref().map(|i| i.describe()),
    })
}

/// Refuses `now` when it differs from the last of `runs` in its rig,
/// unless `anyway`: then `now` records what differed (and a warning
/// says it).
pub fn check_rig(runs: &[Run], now: &mut Run, anyway: bool) -> Result<(), InputError> {
    let Some(last) = runs.last() else {
        return Ok(());
    };
    let d = rig_differences(last, now);
    if d.is_empty() {
        return Ok(());
    }
    let what = d.join("; ");
    if !anyway {
        return Err(InputError::new(format!(
            "--resume: this rig differs from the session's: {what}; nothing was changed (give --resume-anyway to go on, recorded in session.json)"
        )));
    }
    crate::errln!("warning: --resume-anyway: the rig differs: {what}");
    now.resumed_anyway = Some(what);
    Ok(())
}

/// The library entries' CRCs of a run: (id, crc32), in its order.
fn crcs(run: &Run) -> Vec<(String, String)> {
    run.library
        .iter()
        .map(|l| {
            let s = |k: &str| l.get(k).and_then(|v| v.as_str()).unwrap_or("").to_owned();
            (s("id"), s("crc32"))
        })
        .collect()
}

/// What differs between the rig of `before` (the session's last run) and
/// `now`, one phrase each: the scene's text, the backend kind, the
/// library's CRCs, the time scale. Empty: the same rig.
pub fn rig_differences(before: &Run, now: &Run) -> Vec<String> {
    let mut d = Vec::new();
    // A session.json written before the scene was recorded has none: it
    // cannot be compared, so it is not called different.
    if let Some(b) = &before.scene
        && let Some(n) = &now.scene
        && b.crc32 != n.crc32
    {
        d.push(format!("the scene ({} then, {} now)", b.show(), n.show()));
    }
    let kind = |r: &Run| {
        if r.backend.is_empty() {
            r.device
                .get("backend")
                .and_then(|v| v.as_str())
                .unwrap_or("")
                .to_owned()
        } else {
            r.backend.clone()
        }
    };
    if kind(before) != kind(now) {
        d.push(format!(
            "the backend (`{}` then, `{}` now)",
            kind(before),
            kind(now)
        ));
    }
    let (b, n) = (crcs(before), crcs(now));
    if b != n {
        let first = b
            .iter()
            .zip(&n)
            .find(|(x, y)| x != y)
            .map(|(x, y)| {
                if x.0 == y.0 {
                    format!("`{}` `{}` then, `{}` now", x.0, x.1, y.1)
                } else {
                    format!("`{}` then, `{}` now", x.0, y.0)
                }
            })
            .unwrap_or_else(|| format!("{} entries then, {} now", b.len(), n.len()));
        d.push(format!("the library's CRCs ({first})"));
    }
    if before.time_scale != now.time_scale {
        d.push(format!(
            "the time scale ({} then, {} now)",
            crate::limits::show(before.time_scale),
            crate::limits::show(now.time_scale)
        ));
    }
    d
}

/// `t` as RFC 3339 UTC to the millisecond (`2026-11-26T08:41:59.123Z`).
pub fn rfc3339_utc(t: std::time::SystemTime) -> String {
    let d = t.duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    let secs = d.as_secs();
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, dd) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{dd:02}T{:02}:{:02}:{:02}.{:03}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60,
        d.subsec_millis()
    )
}

/// Now, as [`rfc3339_utc`].
pub fn now_utc() -> String {
    rfc3339_utc(std::time::SystemTime::now())
}

/// (year, month, day) of `z` days since 1970-01-01 in the proleptic
/// Gregorian calendar (H. Hinnant's `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::study::columns::is_rfc3339_utc;
    use std::time::{Duration, UNIX_EPOCH};

    fn run(scene: &str, backend: &str, crc: &str, scale: f64) -> Run {
        Run {
            started_unix_s: 0,
            first_trial: 1,
            lmhost_version: "0".into(),
            device: serde_json::json!({"backend": backend}),
            library: vec![serde_json::json!({"id": "a", "crc32": crc})],
            time_scale: scale,
            finger: "none".into(),
            scene: Some(SceneRecord::of(
                Some(std::path::Path::new("s.toml")),
                Some(scene),
            )),
            backend: backend.into(),
            port: "sim".into(),
            resumed_anyway: None,
            instruments: None,
        }
    }

    #[test]
    fn times_are_rfc3339_utc() {
        // Known instants (date -u -d @N).
        let at = |s: u64, ms: u64| {
            rfc3339_utc(UNIX_EPOCH + Duration::from_secs(s) + Duration::from_millis(ms))
        };
        assert_eq!(at(0, 0), "1970-01-01T00:00:00.000Z");
        assert_eq!(at(951_782_400, 5), "2000-02-29T00:00:00.005Z");
        assert_eq!(at(1_795_682_519, 123), "2026-11-26T08:41:59.123Z");
        assert_eq!(at(4_107_542_399, 999), "2100-02-28T23:59:59.999Z");
        assert!(is_rfc3339_utc(&at(1_795_682_519, 1)) && !is_rfc3339_utc(""));
        for bad in [
            "2026-13-01T00:00:00.000Z",
            "2026-11-26 08:41:59.123Z",
            "2026-11-26T08:41:59.123z",
            "2026-11-2aT08:41:59.123Z",
            "2026-11-26T24:41:59.123Z",
            "2026-11-26T08:41:59.1234Z",
            "2026-11-26T08:41:59.12éZ",
            "x",
        ] {
            assert!(!is_rfc3339_utc(bad), "{bad}");
        }
    }

    #[test]
    fn a_different_rig_is_named_by_what_differs() {
        let a = run("scene", "autd3", "0000000a", 1.0);
        assert!(rig_differences(&a, &a.clone()).is_empty());
        let d = rig_differences(&a, &run("scene2", "lm-firmware", "0000000b", 2.0));
        assert_eq!(d.len(), 4, "{d:?}");
        assert!(d[0].starts_with("the scene (`s.toml` (CRC `"), "{d:?}");
        assert_eq!(d[1], "the backend (`autd3` then, `lm-firmware` now)");
        assert_eq!(
            d[2],
            "the library's CRCs (`a` `0000000a` then, `0000000b` now)"
        );
        assert_eq!(d[3], "the time scale (1 then, 2 now)");
        // A session.json from before the scene was recorded.
        let mut old = a.clone();
        old.scene = None;
        assert!(rig_differences(&old, &a).is_empty());
    }

    #[test]
    fn a_long_value_read_back_is_cut_in_the_rig_refusal() {
        // Every value read back from session.json is quoted, so a long one
        // (an edit, a paste) is cut to its echo: the refusal stays a line.
        let long = "a b ".repeat(300);
        let a = run("scene", "autd3", "0000000a", 1.0);
        type Edit = fn(&mut Run, String);
        let edits: [Edit; 4] = [
            |r, v| r.library[0]["crc32"] = v.into(),
            |r, v| r.backend = v,
            // The path is named when the CRC differs.
            |r, v| {
                let s = r.scene.as_mut().unwrap();
                s.path = Some(v);
                s.crc32 = Some("0".into());
            },
            |r, v| r.scene.as_mut().unwrap().crc32 = Some(v),
        ];
        for edit in edits {
            let mut edited = a.clone();
            edit(&mut edited, long.clone());
            let e = check_rig(&[edited], &mut a.clone(), false)
                .unwrap_err()
                .to_string();
            assert!(e.len() < 600 && !e.contains(&"a b ".repeat(30)), "{e}");
        }
    }
}
