//! A plotters [`DrawingBackend`] that writes a one-page PDF 1.4: lines,
//! paths, rectangles, circles and polygons as vectors, text as real text
//! in the embedded DejaVu Sans (the font the PNG and SVG figures use, so
//! layouts agree), and bitmaps (the heatmaps) as Flate-compressed RGB
//! images, as the SVG embeds them.
//!
//! Coordinates are backend units with y down; `unit_pt` points per unit
//! give the page size. Text sizes follow plotters' SVG backend: a style's
//! size / 1.24 is the em, so a layout made for SVG is right for PDF too.
//! Text is WinAnsi-encoded; a character outside WinAnsi is drawn as `?`.
//! The font is embedded as a subset (module `subset`): only the glyphs the page
//! draws keep their outlines.
//! Nothing depends on the clock, so the same figure gives the same bytes.

mod subset;

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::io::Write as _;

use ab_glyph::{Font, FontRef};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontTransform,
};

/// A style's size per em, as plotters' SVG backend writes it.
const SIZE_PER_EM: f64 = 1.24;

/// Drawing a PDF failed (a bitmap of the wrong size, a font that is not
/// TrueType).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct PdfError(String);

/// One page, drawn into memory and written to `out` by `present`.
pub struct PdfBackend<'a> {
    out: &'a mut Vec<u8>,
    size: (u32, u32),
    unit_pt: f64,
    font: FontMetrics,
    content: String,
    /// RGB images: width, height, pixels.
    images: Vec<(u32, u32, Vec<u8>)>,
    /// Distinct alpha values below 1 (in thousandths), one ExtGState each.
    alphas: Vec<u16>,
    /// WinAnsi codes the text uses.
    used: [bool; 256],
    presented: bool,
}

/// What the page needs of the embedded TrueType font.
struct FontMetrics {
    bytes: &'static [u8],
    /// Advance of WinAnsi codes 32..=255, in 1/1000 em.
    widths: Vec<f64>,
    ascent: f64,
    descent: f64,
    bbox: [i32; 4],
}

impl FontMetrics {
    fn new(bytes: &'static [u8]) -> Result<Self, PdfError> {
        let font = FontRef::try_from_slice(bytes)
            .map_err(|_| PdfError("the embedded font is not a TrueType font".into()))?;
        let upem = f64::from(font.units_per_em().unwrap_or(1000.0));
        let per_mille = |v: f32| f64::from(v) * 1000.0 / upem;
        let widths = (32u8..=255)
            .map(|b| per_mille(font.h_advance_unscaled(font.glyph_id(win_ansi_char(b)))))
            .collect();
        let bbox = head_bbox(bytes)
            .map(|b| b.map(|v| (f64::from(v) * 1000.0 / upem).round() as i32))
            .unwrap_or([-1000, -300, 2000, 1000]);
        Ok(Self {
            bytes,
            widths,
            ascent: per_mille(font.ascent_unscaled()),
            descent: per_mille(font.descent_unscaled()),
            bbox,
        })
    }

    /// Width of `text` at `em` units per em, as the PDF draws it (no kerning).
    fn width(&self, text: &str, em: f64) -> f64 {
        encode(text)
            .iter()
            .map(|&b| self.widths[usize::from(b.max(32) - 32)])
            .sum::<f64>()
            * em
            / 1000.0
    }
}

/// The font bounding box from the TrueType `head` table (font units).
fn head_bbox(ttf: &[u8]) -> Option<[i16; 4]> {
    let u16_at = |at: usize| Some(u16::from_be_bytes(ttf.get(at..at + 2)?.try_into().ok()?));
    let u32_at = |at: usize| Some(u32::from_be_bytes(ttf.get(at..at + 4)?.try_into().ok()?));
    let tables = usize::from(u16_at(4)?);
    for i in 0..tables {
        let rec = 12 + 16 * i;
        if ttf.get(rec..rec + 4)? == b"head" {
            let off = u32_at(rec + 8)? as usize;
            let at = |k: usize| u16_at(off + k).map(|v| v as i16);
            return Some([at(36)?, at(38)?, at(40)?, at(42)?]);
        }
    }
    None
}

/// The character WinAnsiEncoding gives byte `b` (`b` ≥ 32).
fn win_ansi_char(b: u8) -> char {
    const HIGH: [char; 32] = [
        '€', '\u{FFFD}', '‚', 'ƒ', '„', '…', '†', '‡', 'ˆ', '‰', 'Š', '‹', 'Œ', '\u{FFFD}', 'Ž',
        '\u{FFFD}', '\u{FFFD}', '‘', '’', '“', '”', '•', '–', '—', '˜', '™', 'š', '›', 'œ',
        '\u{FFFD}', 'ž', 'Ÿ',
    ];
    match b {
        0x80..=0x9F => HIGH[usize::from(b - 0x80)],
        _ => char::from(b),
    }
}

/// `text` in WinAnsiEncoding; characters it lacks become `?`.
fn encode(text: &str) -> Vec<u8> {
    text.chars()
        .map(|c| match u32::from(c) {
            0x20..=0x7E | 0xA0..=0xFF => c as u8,
            _ => (0x80u8..=0x9F)
                .find(|&b| win_ansi_char(b) == c && c != '\u{FFFD}')
                .unwrap_or(b'?'),
        })
        .collect()
}

/// A PDF literal string's body: `(`, `)` and `\` escaped, the rest as is.
fn literal(bytes: &[u8]) -> Vec<u8> {
    let mut s = Vec::with_capacity(bytes.len() + 2);
    for &b in bytes {
        if matches!(b, b'(' | b')' | b'\\') {
            s.push(b'\\');
        }
        s.push(b);
    }
    s
}

fn deflate(data: &[u8]) -> Vec<u8> {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    // Writing to a Vec cannot fail.
    let _ = z.write_all(data);
    z.finish().unwrap_or_default()
}

/// `m` to the first point, `l` to the others: a path's operators.
fn path_ops(points: impl IntoIterator<Item = BackendCoord>) -> String {
    let mut ops = String::new();
    for (i, (x, y)) in points.into_iter().enumerate() {
        let _ = write!(ops, "{x} {y} {} ", if i == 0 { "m" } else { "l" });
    }
    ops
}

/// A number for the content stream: at most 3 decimals, no `-0`.
fn num(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    if r == 0.0 {
        "0".into()
    } else {
        let s = format!("{r:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

impl<'a> PdfBackend<'a> {
    /// A page of `size` units at `unit_pt` points per unit, text in the
    /// TrueType font `font`; `present` writes the PDF into `out`.
    pub fn new(
        out: &'a mut Vec<u8>,
        size: (u32, u32),
        unit_pt: f64,
        font: &'static [u8],
    ) -> Result<Self, PdfError> {
        Ok(Self {
            out,
            size,
            unit_pt,
            font: FontMetrics::new(font)?,
            content: String::new(),
            images: Vec::new(),
            alphas: Vec::new(),
            used: [false; 256],
            presented: false,
        })
    }

    /// Sets the colour (fill or stroke) and returns the ExtGState to use
    /// for its alpha, if any; `None` when fully transparent (draw nothing).
    fn paint(&mut self, c: BackendColor, stroke: bool) -> Option<()> {
        if c.alpha <= 0.0 {
            return None;
        }
        let (r, g, b) = c.rgb;
        let op = if stroke { "RG" } else { "rg" };
        let k = |v: u8| num(f64::from(v) / 255.0);
        let _ = write!(self.content, "{} {} {} {op} ", k(r), k(g), k(b));
        if c.alpha < 1.0 {
            let a = (c.alpha * 1000.0).round().clamp(1.0, 999.0) as u16;
            let i = match self.alphas.iter().position(|&x| x == a) {
                Some(i) => i,
                None => {
                    self.alphas.push(a);
                    self.alphas.len() - 1
                }
            };
            let _ = write!(self.content, "/GS{i} gs ");
        }
        Some(())
    }

    fn stroke_setup<S: BackendStyle>(&mut self, style: &S) -> Option<()> {
        self.content.push_str("q ");
        if self.paint(style.color(), true).is_none() {
            self.content.truncate(self.content.len() - 2);
            return None;
        }
        let _ = write!(self.content, "{} w ", style.stroke_width());
        Some(())
    }

    fn fill_setup(&mut self, color: BackendColor) -> Option<()> {
        self.content.push_str("q ");
        if self.paint(color, false).is_none() {
            self.content.truncate(self.content.len() - 2);
            return None;
        }
        Some(())
    }

    /// The embedded font: the subset of the glyphs the text uses, or the
    /// whole font if it cannot be cut.
    fn font_file(&self) -> Vec<u8> {
        let Ok(font) = FontRef::try_from_slice(self.font.bytes) else {
            return self.font.bytes.to_vec();
        };
        let used: BTreeSet<u16> = (32u8..=255)
            .filter(|&b| self.used[usize::from(b)])
            .map(|b| font.glyph_id(win_ansi_char(b)).0)
            .collect();
        subset::subset(self.font.bytes, &used).unwrap_or_else(|| self.font.bytes.to_vec())
    }

    /// The whole file.
    fn build(&self) -> Vec<u8> {
        let (w, h) = self.size;
        let (wpt, hpt) = (f64::from(w) * self.unit_pt, f64::from(h) * self.unit_pt);
        // Units to points, y down.
        let content = format!(
            "{} 0 0 {} 0 {} cm 1 j 1 J\n{}",
            num(self.unit_pt),
            num(-self.unit_pt),
            num(hpt),
            self.content
        );
        let mut objects: Vec<Vec<u8>> = Vec::new();
        let stream = |dict: String, data: &[u8]| {
            let mut o = format!("<< {dict} /Length {} >>\nstream\n", data.len()).into_bytes();
            o.extend_from_slice(data);
            o.extend_from_slice(b"\nendstream");
            o
        };
        // 1 catalog, 2 pages, 3 page, 4 content, 5 font, 6 descriptor,
        // 7 font file, 8 info, 9.. images.
        let image_ids: Vec<usize> = (0..self.images.len()).map(|i| 9 + i).collect();
        objects.push(b"<< /Type /Catalog /Pages 2 0 R >>".to_vec());
        objects.push(b"<< /Type /Pages /Kids [3 0 R] /Count 1 >>".to_vec());
        let mut res = String::from("/Font << /F1 5 0 R >>");
        if !image_ids.is_empty() {
            res.push_str(" /XObject <<");
            for (i, id) in image_ids.iter().enumerate() {
                let _ = write!(res, " /Im{i} {id} 0 R");
            }
            res.push_str(" >>");
        }
        if !self.alphas.is_empty() {
            res.push_str(" /ExtGState <<");
            for (i, a) in self.alphas.iter().enumerate() {
                let a = num(f64::from(*a) / 1000.0);
                let _ = write!(res, " /GS{i} << /CA {a} /ca {a} >>");
            }
            res.push_str(" >>");
        }
        objects.push(
            format!(
                "<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {} {}] /Resources << {res} >> /Contents 4 0 R >>",
                num(wpt),
                num(hpt)
            )
            .into_bytes(),
        );
        // Text bytes ≥ 0x80 are held as chars U+0080..=U+00FF (see
        // `draw_text`); everything else is ASCII.
        let content: Vec<u8> = content
            .chars()
            .map(|c| u8::try_from(u32::from(c)).unwrap_or(b'?'))
            .collect();
        objects.push(stream("/Filter /FlateDecode".into(), &deflate(&content)));
        let f = &self.font;
        let widths: Vec<String> = f.widths.iter().map(|&w| num(w.round())).collect();
        objects.push(
            format!(
                "<< /Type /Font /Subtype /TrueType /BaseFont /DejaVuSans /FirstChar 32 /LastChar 255 \
                 /Widths [{}] /Encoding /WinAnsiEncoding /FontDescriptor 6 0 R >>",
                widths.join(" ")
            )
            .into_bytes(),
        );
        let [x0, y0, x1, y1] = f.bbox;
        objects.push(
            format!(
                "<< /Type /FontDescriptor /FontName /DejaVuSans /Flags 32 /FontBBox [{x0} {y0} {x1} {y1}] \
                 /ItalicAngle 0 /Ascent {} /Descent {} /CapHeight {} /StemV 80 /FontFile2 7 0 R >>",
                num(f.ascent.round()),
                num(f.descent.round()),
                num((f.ascent * 0.8).round())
            )
            .into_bytes(),
        );
        let file = self.font_file();
        objects.push(stream(
            format!("/Filter /FlateDecode /Length1 {}", file.len()),
            &deflate(&file),
        ));
        objects.push(b"<< /Producer (lmhost) >>".to_vec());
        for (iw, ih, px) in &self.images {
            objects.push(stream(
                format!(
                    "/Type /XObject /Subtype /Image /Width {iw} /Height {ih} /ColorSpace /DeviceRGB \
                     /BitsPerComponent 8 /Filter /FlateDecode"
                ),
                &deflate(px),
            ));
        }
        let mut pdf = b"%PDF-1.4\n%\xE2\xE3\xCF\xD3\n".to_vec();
        let mut offsets = Vec::with_capacity(objects.len());
        for (i, o) in objects.iter().enumerate() {
            offsets.push(pdf.len());
            pdf.extend_from_slice(format!("{} 0 obj\n", i + 1).as_bytes());
            pdf.extend_from_slice(o);
            pdf.extend_from_slice(b"\nendobj\n");
        }
        let xref = pdf.len();
        let mut table = format!("xref\n0 {}\n0000000000 65535 f \n", objects.len() + 1);
        for off in offsets {
            let _ = writeln!(table, "{off:010} 00000 n ");
        }
        let _ = write!(
            table,
            "trailer\n<< /Size {} /Root 1 0 R /Info 8 0 R >>\nstartxref\n{xref}\n%%EOF\n",
            objects.len() + 1
        );
        pdf.extend_from_slice(table.as_bytes());
        pdf
    }
}

type R<'a> = Result<(), DrawingErrorKind<PdfError>>;

impl<'a> DrawingBackend for PdfBackend<'a> {
    type ErrorType = PdfError;

    fn get_size(&self) -> (u32, u32) {
        self.size
    }

    fn ensure_prepared(&mut self) -> R<'a> {
        Ok(())
    }

    fn present(&mut self) -> R<'a> {
        if !self.presented {
            *self.out = self.build();
            self.presented = true;
        }
        Ok(())
    }

    fn draw_pixel(&mut self, (x, y): BackendCoord, color: BackendColor) -> R<'a> {
        if self.fill_setup(color).is_some() {
            let _ = writeln!(self.content, "{x} {y} 1 1 re f Q");
        }
        Ok(())
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> R<'a> {
        if self.stroke_setup(style).is_some() {
            let _ = writeln!(
                self.content,
                "{} {} m {} {} l S Q",
                from.0, from.1, to.0, to.1
            );
        }
        Ok(())
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        ul: BackendCoord,
        br: BackendCoord,
        style: &S,
        fill: bool,
    ) -> R<'a> {
        let (w, h) = (br.0 - ul.0, br.1 - ul.1);
        if fill {
            if self.fill_setup(style.color()).is_some() {
                let _ = writeln!(self.content, "{} {} {w} {h} re f Q", ul.0, ul.1);
            }
        } else if self.stroke_setup(style).is_some() {
            let _ = writeln!(self.content, "{} {} {w} {h} re S Q", ul.0, ul.1);
        }
        Ok(())
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> R<'a> {
        let ops = path_ops(path);
        if !ops.is_empty() && self.stroke_setup(style).is_some() {
            self.content.push_str(&ops);
            self.content.push_str("S Q\n");
        }
        Ok(())
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        (cx, cy): BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> R<'a> {
        let on = if fill {
            self.fill_setup(style.color())
        } else {
            self.stroke_setup(style)
        };
        if on.is_none() {
            return Ok(());
        }
        // Four cubic Béziers, the usual 0.5523 handle.
        let (x, y, r) = (f64::from(cx), f64::from(cy), f64::from(radius));
        let k = 0.552_284_75 * r;
        let p = |a: f64, b: f64| format!("{} {}", num(a), num(b));
        let _ = writeln!(
            self.content,
            "{} m {} {} {} c {} {} {} c {} {} {} c {} {} {} c {} Q",
            p(x + r, y),
            p(x + r, y + k),
            p(x + k, y + r),
            p(x, y + r),
            p(x - k, y + r),
            p(x - r, y + k),
            p(x - r, y),
            p(x - r, y - k),
            p(x - k, y - r),
            p(x, y - r),
            p(x + k, y - r),
            p(x + r, y - k),
            p(x + r, y),
            if fill { "f" } else { "S" }
        );
        Ok(())
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> R<'a> {
        let ops = path_ops(vert);
        if !ops.is_empty() && self.fill_setup(style.color()).is_some() {
            self.content.push_str(&ops);
            self.content.push_str("h f Q\n");
        }
        Ok(())
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> R<'a> {
        let em = style.size() / SIZE_PER_EM;
        let w = self.font.width(text, em);
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0.0,
            HPos::Center => -w / 2.0,
            HPos::Right => -w,
        };
        // Baseline below the anchor, y down: the top at the ascent, the
        // centre at half the cap height, the bottom at the descent.
        let dy = match anchor.v_pos {
            VPos::Top => self.font.ascent * em / 1000.0,
            VPos::Center => 0.35 * em,
            VPos::Bottom => self.font.descent * em / 1000.0,
        };
        // Text-local (right, down) to page units, as plotters turns text.
        let turn = |x: f64, y: f64| match style.transform() {
            FontTransform::None => (x, y),
            FontTransform::Rotate90 => (-y, x),
            FontTransform::Rotate180 => (-x, -y),
            FontTransform::Rotate270 => (y, -x),
        };
        let (ox, oy) = turn(dx, dy);
        let (ax, ay) = turn(1.0, 0.0);
        let (ux, uy) = turn(0.0, -1.0);
        let bytes = encode(text);
        for &b in &bytes {
            self.used[usize::from(b)] = true;
        }
        let body = literal(&bytes);
        if self.fill_setup(style.color()).is_none() {
            return Ok(());
        }
        let _ = write!(
            self.content,
            "BT /F1 {} Tf {} {} {} {} {} {} Tm (",
            num(em),
            num(ax),
            num(ay),
            num(ux),
            num(uy),
            num(f64::from(pos.0) + ox),
            num(f64::from(pos.1) + oy)
        );
        // WinAnsi bytes ≥ 0x80 are not UTF-8: the content holds them as
        // chars U+0080..=U+00FF and `build` writes them back as bytes.
        self.content.extend(body.iter().map(|&b| char::from(b)));
        self.content.push_str(") Tj ET Q\n");
        Ok(())
    }

    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        text: &str,
        style: &T,
    ) -> Result<(u32, u32), DrawingErrorKind<PdfError>> {
        let em = style.size() / SIZE_PER_EM;
        Ok((self.font.width(text, em).round() as u32, em.round() as u32))
    }

    fn blit_bitmap(&mut self, (x, y): BackendCoord, (iw, ih): (u32, u32), src: &[u8]) -> R<'a> {
        let n = iw as usize * ih as usize * 3;
        let Some(px) = src.get(..n) else {
            return Err(DrawingErrorKind::DrawingError(PdfError(format!(
                "a {iw} × {ih} bitmap needs {n} bytes, got {}",
                src.len()
            ))));
        };
        let i = self.images.len();
        self.images.push((iw, ih, px.to_vec()));
        let _ = writeln!(
            self.content,
            "q {iw} 0 0 {} {x} {} cm /Im{i} Do Q",
            -i64::from(ih),
            i64::from(y) + i64::from(ih)
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::io::Read as _;

    use plotters::prelude::*;

    use super::*;
    use crate::field::ObservationPlane;
    use crate::field::plot::{self, Figure, Format, Labels, Overlay, Panel};

    /// Object `n`'s bytes (after `n 0 obj`), found through the xref table,
    /// which must point exactly at it.
    fn object(pdf: &[u8], n: usize) -> &[u8] {
        let tail = std::str::from_utf8(&pdf[pdf.len() - 40..]).unwrap();
        let sx: usize = tail
            .split("startxref\n")
            .nth(1)
            .unwrap()
            .lines()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            pdf[sx..].starts_with(b"xref\n0 "),
            "startxref points at the table"
        );
        // Entries are 20 bytes; entry 0 (the free list head) ends " f \n".
        let first = sx + pdf[sx..].windows(4).position(|w| w == b" f \n").unwrap() + 4;
        let entry = first + 20 * (n - 1);
        let off: usize = std::str::from_utf8(&pdf[entry..entry + 10])
            .unwrap()
            .parse()
            .unwrap();
        let head = format!("{n} 0 obj\n");
        assert!(pdf[off..].starts_with(head.as_bytes()), "xref entry {n}");
        let body = &pdf[off + head.len()..];
        let end = body.windows(7).position(|w| w == b"endobj\n").unwrap();
        &body[..end]
    }

    /// The inflated data of a stream object.
    fn stream_data(obj: &[u8]) -> Vec<u8> {
        let s = obj.windows(7).position(|w| w == b"stream\n").unwrap() + 7;
        let e = obj.windows(10).rposition(|w| w == b"\nendstream").unwrap();
        let mut out = Vec::new();
        flate2::read::ZlibDecoder::new(&obj[s..e])
            .read_to_end(&mut out)
            .unwrap();
        out
    }

    fn contains(hay: &[u8], needle: &str) -> bool {
        hay.windows(needle.len()).any(|w| w == needle.as_bytes())
    }

    #[test]
    fn figure_pdf_is_well_formed_sized_and_carries_real_text() {
        let dir = std::env::temp_dir().join(format!("lmhost-pdf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let plane = ObservationPlane {
            center_mm: [0.0, 0.0, 200.0],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            width_mm: 10.0,
            height_mm: 8.0,
            step_mm: 1.0,
        };
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
            y: "b (mm)".into(),
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
        assert!(pdf.starts_with(b"%PDF-1.4\n") && pdf.ends_with(b"%%EOF\n"));

        // The page is the figure's printed width.
        let page = std::str::from_utf8(object(&pdf, 3)).unwrap().to_string();
        let mb = page.split("/MediaBox [0 0 ").nth(1).unwrap();
        let w_pt: f64 = mb.split(' ').next().unwrap().parse().unwrap();
        assert!((w_pt - 120.0 / 25.4 * 72.0).abs() < 0.5, "{w_pt} pt");
        // One embedded image: the heatmap, at its size in units.
        assert!(page.contains("/Im0 9 0 R") && !page.contains("/Im1"));
        // The overlays' alpha (the disk is drawn at 0.9).
        assert!(page.contains("/CA 0.9 /ca 0.9"), "{page}");

        // Text is text: the axis names, the legend, the rotated y name.
        let content = stream_data(object(&pdf, 4));
        for t in ["(a \\(mm\\)) Tj", "(orbit) Tj", "(6 mm gauge disk) Tj"] {
            assert!(contains(&content, t), "{t}");
        }
        // The y name reads upwards: advance (0, -1), glyph up (-1, 0).
        let text = String::from_utf8_lossy(&content);
        let y_name = text
            .lines()
            .find(|l| l.contains("(b \\(mm\\)) Tj"))
            .unwrap();
        assert!(y_name.contains(" Tf 0 -1 -1 0 "), "{y_name}");

        // The font file is DejaVu Sans cut to the glyphs drawn: the
        // letters of the labels have outlines, others do not.
        let font = std::str::from_utf8(object(&pdf, 5)).unwrap();
        assert!(font.contains("/Encoding /WinAnsiEncoding"));
        let file = stream_data(object(&pdf, 7));
        assert!(file.len() * 4 < plot::FONT.len(), "{} bytes", file.len());
        let sub = FontRef::try_from_slice(&file).unwrap();
        for (c, drawn) in [('o', true), ('b', true), ('Z', false), ('Q', false)] {
            assert_eq!(sub.outline(sub.glyph_id(c)).is_some(), drawn, "{c}");
        }
        // The image is the map's pixels, RGB.
        let img = object(&pdf, 9);
        let head = String::from_utf8_lossy(&img[..200]);
        let iw: usize = head
            .split("/Width ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let ih: usize = head
            .split("/Height ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(stream_data(img).len(), iw * ih * 3);
    }

    #[test]
    fn text_is_win_ansi_and_measured_as_drawn() {
        assert_eq!(encode("µ×°–é"), vec![0xB5, 0xD7, 0xB0, 0x96, 0xE9]);
        assert_eq!(encode("a中b"), b"a?b".to_vec());
        assert_eq!(literal(b"f(x) \\ y"), b"f\\(x\\) \\\\ y".to_vec());
        let m = FontMetrics::new(plot::FONT).unwrap();
        // Widths from the font: a wide letter is wider than a narrow one,
        // a digit is a digit wide, and a string is the sum of its letters.
        let w = |s: &str| m.width(s, 1000.0);
        assert!(w("W") > 1.5 * w("i"));
        assert!((w("0") - w("8")).abs() < 1e-9);
        assert!((w("Wi") - w("W") - w("i")).abs() < 1e-9);
        assert!(
            m.ascent > 700.0 && m.descent < -100.0,
            "{} {}",
            m.ascent,
            m.descent
        );
        let [x0, y0, x1, y1] = m.bbox;
        assert!(x0 < 0 && y0 < 0 && x1 > 1000 && y1 > 900, "{:?}", m.bbox);
        // A non-TrueType font is an error, not a panic.
        assert!(FontMetrics::new(b"not a font").is_err());
    }

    #[test]
    fn a_short_bitmap_is_an_error() {
        let mut out = Vec::new();
        let mut b = PdfBackend::new(&mut out, (10, 10), 1.0, plot::FONT).unwrap();
        assert!(b.blit_bitmap((0, 0), (4, 4), &[0; 47]).is_err());
        b.blit_bitmap((0, 0), (4, 4), &[0; 48]).unwrap();
        b.present().unwrap();
        assert!(out.starts_with(b"%PDF"));
        // Nothing is drawn in full transparency.
        let mut out2 = Vec::new();
        let mut b = PdfBackend::new(&mut out2, (10, 10), 1.0, plot::FONT).unwrap();
        b.draw_line((0, 0), (5, 5), &TRANSPARENT).unwrap();
        assert!(b.content.is_empty());
    }
}
