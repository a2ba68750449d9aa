//! The PDF a figure gives: sized, repeatable, text as Unicode glyphs of a
//! named font subset.

use plotters::prelude::*;

use super::read::{object, streams};
use super::*;
use crate::field::ObservationPlane;
use crate::field::plot::{self, Figure, Format, Labels, Overlay, Panel};

/// The data of stream object `n`, inflated.
fn stream_data(pdf: &[u8], n: usize) -> Vec<u8> {
    let mut s = streams(object(pdf, n));
    assert_eq!(s.len(), 1, "object {n}");
    s.remove(0)
}

fn text(obj: &[u8]) -> String {
    String::from_utf8_lossy(obj).into_owned()
}

#[test]
fn figure_pdf_is_sized_repeatable_and_embeds_a_font_subset() {
    let dir = crate::files::scratch("pdf");
    let plane = ObservationPlane::xy([0.0, 0.0, 200.0], 10.0, 8.0, 1.0);
    let map: Vec<f64> = (0..plane.nu() * plane.nv()).map(|i| i as f64).collect();
    let panel = Panel {
        map: &map,
        overlay: Overlay {
            orbit: (0..16)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 16.0;
                    [2.0 * a.cos(), 2.0 * a.sin()]
                })
                .collect(),
            foci: vec![[2.0, 0.0]],
            disk: Some(([0.0, 0.0], 6.0)),
        },
    };
    let labels = Labels {
        x: "a (mm)".into(),
        y: "v ∥ (0, 1, 0) (mm)".into(),
        colorbar: "mean rad. pressure (Pa)".into(),
        disk_mm: Some(6.0),
        ..Labels::default()
    };
    let fig = Figure {
        width_mm: 120.0,
        formats: vec![Format::Pdf],
    };
    let written = plot::heatmap(&dir.join("m"), &plane, &panel, &labels, &fig).unwrap();
    assert_eq!(written, vec![dir.join("m.pdf")]);
    let pdf = std::fs::read(dir.join("m.pdf")).unwrap();
    // The same figure, the same bytes.
    plot::heatmap(&dir.join("again"), &plane, &panel, &labels, &fig).unwrap();
    assert!(std::fs::read(dir.join("again.pdf")).unwrap() == pdf);
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(pdf.starts_with(b"%PDF-1.4\n"));
    assert!(pdf.ends_with(b"%%EOF\n"));

    // The page is the figure's printed width.
    let page = text(object(&pdf, 3));
    let mb = page.split("/MediaBox [0 0 ").nth(1).unwrap();
    let w_pt: f64 = mb.split(' ').next().unwrap().parse().unwrap();
    assert!((w_pt - 120.0 / 25.4 * 72.0).abs() < 0.5, "{w_pt} pt");
    // One embedded image (the heatmap) and the overlays' alpha (the
    // disk is drawn at 0.9).
    assert!(page.contains("/Im0 ") && !page.contains("/Im1"), "{page}");
    assert!(page.contains("/GS0 11 0 R"), "{page}");
    assert!(text(object(&pdf, 11)).contains("/CA 0.9"));

    // The font is a subset, named as one: `ABCDEF+DejaVuSans`.
    let font = text(object(&pdf, 5));
    let base = font.split("/BaseFont /").nth(1).unwrap();
    let (tag, name) = base.split_once('+').unwrap();
    assert!(tag.len() == 6 && tag.bytes().all(|b| b.is_ascii_uppercase()));
    assert!(name.starts_with("DejaVuSans"), "{name}");
    assert!(font.contains("/Identity-H") && font.contains("/ToUnicode 9 0 R"));
    // Cut to the glyphs drawn: a few dozen, not DejaVu's 6000.
    let file = stream_data(&pdf, 8);
    let sub = ttf_parser::Face::parse(&file, 0).unwrap();
    let full = ttf_parser::Face::parse(plot::FONT, 0).unwrap();
    assert!(
        (20..80).contains(&sub.number_of_glyphs()) && full.number_of_glyphs() > 5000,
        "{} glyphs",
        sub.number_of_glyphs()
    );
    assert!(file.len() * 20 < plot::FONT.len(), "{} bytes", file.len());
    // Every character drawn is in the ToUnicode map, the ∥ included.
    let cmap = text(&stream_data(&pdf, 9));
    for c in ['a', 'm', 'P', '∥', '(', '6'] {
        let hex = format!("<{:04X}>", u32::from(c));
        assert!(cmap.contains(&hex), "{c} {hex}");
    }
    // The image is the map's pixels, RGB.
    let img = object(&pdf, 12);
    let head = text(&img[..200.min(img.len())]);
    let num = |key: &str| -> usize {
        head.split(key)
            .nth(1)
            .unwrap()
            .split(|c: char| !c.is_ascii_digit())
            .nth(1)
            .unwrap()
            .parse()
            .unwrap()
    };
    assert_eq!(
        stream_data(&pdf, 12).len(),
        num("/Width") * num("/Height") * 3
    );
}

#[test]
fn text_is_unicode_glyphs_shown_and_measured_as_drawn() {
    let mut out = Vec::new();
    let mut b = PdfBackend::new(&mut out, (200, 100), 1.0, plot::FONT).unwrap();
    let style = TextStyle::from(("sans-serif", 12.4).into_font()).color(&BLACK);
    b.draw_text("µ∥a", &style, (10, 20)).unwrap();
    b.draw_text("aa", &style, (10, 40)).unwrap();
    // Glyphs numbered in order of first use after .notdef: µ 1, ∥ 2, a 3.
    let content = String::from_utf8_lossy(b.content.as_bytes()).into_owned();
    assert!(content.contains("/F1 10 Tf"), "{content}");
    let shown: Vec<&str> = content.lines().filter(|l| l.ends_with("Tj")).collect();
    assert_eq!(shown.len(), 2, "{content}");
    assert!(
        content.contains(r"(\000\001\000\002\000\003) Tj"),
        "{content}"
    );
    assert!(content.contains(r"(\000\003\000\003) Tj"), "{content}");
    assert_eq!(b.chars.values().collect::<String>(), "µ∥a");
    // Widths from the font: a wide letter is wider than a narrow one,
    // a digit is a digit wide, and a string is the sum of its letters.
    let w = |s: &str| b.font.width(s, 1000.0);
    assert!(w("W") > 1.5 * w("i"));
    assert!((w("0") - w("8")).abs() < 1e-9);
    assert!((w("Wi") - w("W") - w("i")).abs() < 1e-9);
    assert!(b.font.ascent > 700.0 && b.font.descent < -100.0);
    b.present().unwrap();
    assert!(out.starts_with(b"%PDF"));
    // A font that is not a font is an error, not a panic.
    assert!(PdfBackend::new(&mut Vec::new(), (1, 1), 1.0, b"not a font").is_err());
}

#[test]
fn a_short_bitmap_is_an_error_and_transparency_draws_nothing() {
    let mut out = Vec::new();
    let mut b = PdfBackend::new(&mut out, (10, 10), 1.0, plot::FONT).unwrap();
    assert!(b.blit_bitmap((0, 0), (4, 4), &[0; 47]).is_err());
    b.blit_bitmap((0, 0), (4, 4), &[0; 48]).unwrap();
    let before = b.content.as_bytes().len();
    b.draw_line((0, 0), (5, 5), &TRANSPARENT).unwrap();
    assert_eq!(b.content.as_bytes().len(), before);
    b.present().unwrap();
    assert!(out.starts_with(b"%PDF"));
}

#[test]
fn shapes_are_filled_or_outlined_as_asked() {
    let mut out = Vec::new();
    let mut b = PdfBackend::new(&mut out, (10, 10), 1.0, plot::FONT).unwrap();
    // Each shape in its own saved state, closed by fill (`f`) or stroke (`S`).
    let ops = |b: &mut PdfBackend<'_>, draw: &dyn Fn(&mut PdfBackend<'_>)| {
        let at = b.content.as_bytes().len();
        draw(b);
        let text = String::from_utf8(b.content.as_bytes()[at..].to_vec()).unwrap();
        text.trim().to_owned()
    };
    let filled = ops(&mut b, &|b| {
        b.draw_rect((1, 1), (4, 5), &RED, true).unwrap()
    });
    assert!(
        filled.starts_with("q\n") && filled.ends_with(" re\nf\nQ"),
        "{filled}"
    );
    let outline = ops(&mut b, &|b| {
        b.draw_rect((1, 1), (4, 5), &RED, false).unwrap()
    });
    assert!(
        outline.contains(" w\n") && outline.ends_with(" re\nS\nQ"),
        "{outline}"
    );
    let disc = ops(&mut b, &|b| b.draw_circle((5, 5), 3, &RED, true).unwrap());
    assert!(
        disc.starts_with("q\n") && disc.ends_with(" c\nf\nQ"),
        "{disc}"
    );
    let ring = ops(&mut b, &|b| b.draw_circle((5, 5), 3, &RED, false).unwrap());
    assert!(
        ring.contains(" w\n") && ring.ends_with(" c\nS\nQ"),
        "{ring}"
    );
    let pts = [(1, 1), (8, 2), (4, 7)];
    let path = ops(&mut b, &|b| b.draw_path(pts, &RED).unwrap());
    assert!(path.contains(" w\n1 1 m\n8 2 l\n4 7 l\nS\nQ"), "{path}");
    let polygon = ops(&mut b, &|b| b.fill_polygon(pts, &RED).unwrap());
    assert!(
        polygon.ends_with(" rg\n1 1 m\n8 2 l\n4 7 l\nh\nf\nQ"),
        "{polygon}"
    );
    for fill in [true, false] {
        let none = ops(&mut b, &|b| {
            b.draw_rect((1, 1), (4, 5), &TRANSPARENT, fill).unwrap();
            b.draw_circle((5, 5), 3, &TRANSPARENT, fill).unwrap();
        });
        assert_eq!(none, "");
    }
    // No points, or nothing to paint with: nothing drawn, nothing saved.
    let none = ops(&mut b, &|b| {
        b.draw_path([], &RED).unwrap();
        b.fill_polygon([], &RED).unwrap();
        b.draw_path(pts, &TRANSPARENT).unwrap();
        b.fill_polygon(pts, &TRANSPARENT).unwrap();
    });
    assert_eq!(none, "");
}
