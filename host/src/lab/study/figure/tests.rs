//! The report's figures: the paper's layout, printed size, the protocol's
//! words, the fixed range and the marks, read back from the PDF's text
//! (through its ToUnicode map) and the PNG's header.

use super::*;
use crate::field::plot::{Format, ONE_COLUMN_MM, TWO_COLUMN_MM};
use crate::lab::study::analysis;
use crate::lab::study::protocol::Unlinked;
use crate::lab::study::test_files::{exp1_vibration, studies};
use crate::pdf::read::texts as pdf_texts;
use crate::rng::SplitMix64;

/// Ten participants' answers to `vibration`, one per condition, from
/// `value(participant, condition)`; the stats and tests the report makes
/// of them.
fn study(
    p: &Unlinked,
    value: impl Fn(usize, usize) -> f64,
) -> (Vec<Stat>, Vec<analysis::QuestionStats>) {
    let mut rows = Vec::new();
    let mut stats = Vec::new();
    for (c, cond) in p.conditions.iter().enumerate() {
        let mut values: Vec<f64> = (0..10).map(|who| value(who, c)).collect();
        for (who, v) in values.iter().enumerate() {
            rows.push((format!("p{who:02}"), c, format!("{v}")));
        }
        values.sort_by(f64::total_cmp);
        stats.push(Stat {
            stimulus: cond.stimulus.clone(),
            levels: cond.levels.clone(),
            question: "vibration".into(),
            values,
            not_perceived: 0,
        });
    }
    let design = analysis::design(&p.report, &p.factors, &p.conditions);
    let tests = vec![analysis::question("vibration", &rows, &p.conditions, &design).unwrap()];
    (stats, tests)
}

fn write_pdf_png(b: &BoxFigure, width_mm: f64, name: &str) -> (Vec<u8>, Vec<u8>) {
    let dir = crate::files::scratch(&format!("boxfig-{name}"));
    let fig = Figure {
        width_mm,
        formats: vec![Format::Png, Format::Pdf],
    };
    let written = write(&dir.join("f"), b, &fig).unwrap();
    assert_eq!(written, [dir.join("f.png"), dir.join("f.pdf")]);
    let png = std::fs::read(dir.join("f.png")).unwrap();
    let pdf = std::fs::read(dir.join("f.pdf")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    (pdf, png)
}

/// The page's width and height in mm from its MediaBox.
fn media_box_mm(pdf: &[u8]) -> (f64, f64) {
    let text = String::from_utf8_lossy(pdf);
    let mb: Vec<f64> = text
        .split("/MediaBox [")
        .nth(1)
        .unwrap()
        .split(']')
        .next()
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let mm = |v: f64| v / 72.0 * 25.4;
    (mm(mb[2] - mb[0]), mm(mb[3] - mb[1]))
}

fn png_size(png: &[u8]) -> (u32, u32) {
    assert_eq!(&png[1..4], b"PNG");
    let be = |at: usize| u32::from_be_bytes(png[at..at + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn a_likert_figure_is_printed_at_a_column_width_with_the_protocols_words_and_scale() {
    let p = Unlinked::from_toml(&exp1_vibration(), "test").unwrap();
    // Answers between 3 and 5 only: an auto-ranged axis would span them.
    let (stats, tests) = study(&p, |who, c| 3.0 + ((who + c) % 3) as f64);
    let figs = plan(&p, &stats, &tests);
    assert_eq!(figs.len(), 1);
    let b = &figs[0];
    assert_eq!(b.column, "vibration");
    assert_eq!(b.range, (1.0, 7.0));
    assert_eq!(b.ticks, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
    assert_eq!(b.series, ["LM-S 5 Hz", "LM-M 5 Hz", "LM-S 25 Hz"]);
    assert_eq!(b.groups, ["2", "3", "4", "5", "6"]);
    assert_eq!(b.boxes.len(), 15);
    // Grouped by radius, the type by colour.
    assert_eq!((b.boxes[1].group, b.boxes[1].series), (0, 1));
    assert_eq!((b.boxes[3].group, b.boxes[3].series), (1, 0));
    for (width, px) in [(ONE_COLUMN_MM, 998), (TWO_COLUMN_MM, 2041)] {
        let (pdf, png) = write_pdf_png(b, width, &format!("{width}"));
        let (w, h) = media_box_mm(&pdf);
        assert!((w - width).abs() < 0.2, "{w} mm wide");
        assert!((40.0..=width.min(120.0)).contains(&h), "{h} mm high");
        let (pw, ph) = png_size(&png);
        assert_eq!(pw, px, "288 dpi");
        assert!((f64::from(ph) / f64::from(pw) - h / w).abs() < 0.01);
        let texts = pdf_texts(&pdf);
        let all = texts.join("\n");
        for want in [
            "LM-S 5 Hz",
            "LM-M 5 Hz",
            "LM-S 25 Hz",
            "orbit radius A (mm)",
            "vibration rating",
            "1 = not at all, 7 = very intensely",
            "Q1. How intensely",
        ] {
            assert!(all.contains(want), "no `{want}` in {texts:?}");
        }
        assert!(!all.contains("lms-5hz"), "a raw level id: {texts:?}");
        // The y axis is the scale's: 1..7 whatever the answers span.
        for t in 1..=7 {
            assert!(texts.contains(&t.to_string()), "no tick {t}: {texts:?}");
        }
        assert!(!texts.iter().any(|t| t == "0" || t == "8" || t == "3.5"));
        // n under every box.
        assert_eq!(texts.iter().filter(|t| *t == "10").count(), 15);
        assert!(!all.contains('*'), "no pair differs: {texts:?}");
    }
}

#[test]
fn a_significant_pair_is_starred_and_a_flat_one_is_not() {
    let p = Unlinked::from_toml(&exp1_vibration(), "test").unwrap();
    // LM-S 25 Hz far above the others at A = 2 mm; the rest noise.
    let fast = p
        .conditions
        .iter()
        .position(|c| c.levels == ["lms-25hz", "2"])
        .unwrap();
    let noise = |who: usize, c: usize| {
        let mut r = SplitMix64::new((who * 100 + c) as u64);
        1.0 + (r.next_u64() % 7) as f64
    };
    let (stats, tests) = study(&p, |who, c| {
        if c == fast {
            6.0 + (who % 2) as f64
        } else {
            noise(who, c)
        }
    });
    let b = &plan(&p, &stats, &tests)[0];
    let starred: Vec<&Mark> = b.marks.iter().filter(|m| m.text.contains('*')).collect();
    assert!(!starred.is_empty(), "{:?}", b.marks);
    // Each starred pair is one of A = 2 mm's with LM-S 25 Hz in it.
    for m in &starred {
        let (x, y) = (&b.boxes[m.a], &b.boxes[m.b]);
        assert_eq!((x.group, y.group), (0, 0), "{m:?}");
        assert!(x.series == 2 || y.series == 2, "{m:?}");
    }
    assert!(
        starred
            .iter()
            .any(|m| [b.boxes[m.a].series, b.boxes[m.b].series] == [0, 2])
    );
    let (pdf, _) = write_pdf_png(b, ONE_COLUMN_MM, "stars");
    let texts = pdf_texts(&pdf);
    assert!(
        texts.iter().any(|t| t.starts_with('*')),
        "no star drawn: {texts:?}"
    );
    // The same conditions all alike: no star anywhere.
    let (stats, tests) = study(&p, |who, _| 3.0 + (who % 3) as f64);
    let b = &plan(&p, &stats, &tests)[0];
    assert!(
        b.marks.iter().all(|m| !m.text.contains('*')),
        "{:?}",
        b.marks
    );
    let (pdf, _) = write_pdf_png(b, ONE_COLUMN_MM, "flat");
    assert!(!pdf_texts(&pdf).iter().any(|t| t.contains('*')));
}

/// Experiment 3's rows: the final depth, and the force where they hold it.
fn exp3_stats(p: &Unlinked, force: bool) -> Vec<Stat> {
    let mut out = Vec::new();
    for c in &p.conditions {
        let mut push = |question: &str, values: Vec<f64>| {
            out.push(Stat {
                stimulus: c.stimulus.clone(),
                levels: c.levels.clone(),
                question: question.into(),
                values,
                not_perceived: 0,
            })
        };
        push(columns::FINAL_DEPTH, vec![2.0, 2.25, 3.5]);
        if force {
            push(FORCE, vec![0.12, 0.24, 0.53]);
        }
    }
    out
}

use crate::lab::study::columns;

#[test]
fn experiment_3_is_drawn_in_newtons_when_the_rows_hold_the_force() {
    let exp3 = std::fs::read_to_string(studies("paper-exp3.toml")).unwrap();
    let p = Unlinked::from_toml(&exp3, "test").unwrap();
    let figs = plan(&p, &exp3_stats(&p, true), &[]);
    assert_eq!(figs.len(), 1, "the force replaces the depth");
    let b = &figs[0];
    assert_eq!(b.column, FORCE);
    assert_eq!(b.y_label, "perceived force (N)");
    assert_eq!(b.range.0, 0.0);
    assert!(b.range.1 >= 0.53 && b.range.1 <= 1.0, "{:?}", b.range);
    let (pdf, _) = write_pdf_png(b, ONE_COLUMN_MM, "force");
    let texts = pdf_texts(&pdf);
    assert!(
        texts.iter().any(|t| t == "perceived force (N)"),
        "{texts:?}"
    );
    assert!(
        !texts
            .iter()
            .any(|t| t.contains("(mm)") && t.contains("depth"))
    );
    // Without the force: the depth in mm over the adjustment's range.
    let figs = plan(&p, &exp3_stats(&p, false), &[]);
    assert_eq!(figs.len(), 1);
    assert_eq!(figs[0].y_label, "final pushing depth (mm)");
    assert_eq!(figs[0].range, (0.0, 10.0));
}

#[test]
fn lm_type_ids_read_as_the_paper_writes_them() {
    assert_eq!(level_label("lms-5hz"), "LM-S 5 Hz");
    assert_eq!(level_label("lmm-25hz"), "LM-M 25 Hz");
    assert_eq!(level_label("lms-fast"), "lms-fast");
    assert_eq!(level_label("4"), "4");
    assert_eq!(ticks_over(0.0, 10.0), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
    assert_eq!(nice_up(0.56), 1.0);
    // Degenerate and overflowing spans give their ends, not a loop.
    assert_eq!(ticks_over(3.0, 3.0), [3.0]);
    assert_eq!(ticks_over(-f64::MAX, f64::MAX), [-f64::MAX, f64::MAX]);
}
