//! A plotters [`DrawingBackend`] that draws a one-page PDF through
//! `pdf-writer`: lines, paths, rectangles, circles and polygons as
//! vectors, bitmaps (the heatmaps) as Flate-compressed RGB images, as the
//! SVG embeds them, and text as real text in the embedded TrueType font
//! (DejaVu Sans, the font of the PNG and SVG figures, so layouts agree).
//!
//! Text is Unicode: each character is its glyph, shown through a CID font
//! (`Identity-H`) with a `ToUnicode` map, so it can be searched and copied.
//! The font is embedded as a subset cut by `subsetter` to the glyphs the
//! page draws, named `TAG+PostScriptName` as PDF wants a subset to be; the
//! tag comes from the glyphs, so the same figure gives the same bytes (no
//! clock, no random IDs).
//!
//! Coordinates are backend units with y down; `unit_pt` points per unit
//! give the page size. Text sizes follow plotters' SVG backend: a style's
//! size / 1.24 is the em, so a layout made for SVG is right for PDF too.

use std::collections::BTreeMap;
use std::io::Write as _;

use pdf_writer::types::{CidFontType, FontFlags, LineCapStyle, LineJoinStyle, SystemInfo};
use pdf_writer::{Content, Filter, Finish as _, Name, Pdf, Rect, Ref, Str, TextStr};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontTransform,
};

/// A style's size per em, as plotters' SVG backend writes it.
const SIZE_PER_EM: f64 = 1.24;

/// Drawing a PDF failed (a bitmap of the wrong size, a font that cannot be
/// read or cut).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct PdfError(String);

/// One page, drawn into memory and written to `out` by `present`.
pub struct PdfBackend<'a> {
    out: &'a mut Vec<u8>,
    size: (u32, u32),
    unit_pt: f64,
    font: Face,
    content: Content,
    /// RGB images: width, height, pixels.
    images: Vec<(u32, u32, Vec<u8>)>,
    /// Distinct alpha values below 1 (in thousandths), one ExtGState each.
    alphas: Vec<u16>,
    /// The font's glyphs the text uses, numbered in the subset.
    glyphs: subsetter::GlyphRemapper,
    /// What each subset glyph stands for (the `ToUnicode` map).
    chars: BTreeMap<u16, char>,
    presented: bool,
}

/// What the page needs of the embedded TrueType font.
struct Face {
    bytes: &'static [u8],
    face: ttf_parser::Face<'static>,
    /// The PostScript name (`DejaVuSans`).
    name: String,
    /// Per mille of an em.
    per_mille: f64,
    ascent: f64,
    descent: f64,
    cap_height: f64,
    bbox: Rect,
}

impl Face {
    fn new(bytes: &'static [u8]) -> Result<Self, PdfError> {
        let f = ttf_parser::Face::parse(bytes, 0)
            .map_err(|e| PdfError(format!("the embedded font cannot be read: {e}")))?;
        let per_mille = 1000.0 / f64::from(f.units_per_em());
        let name = f
            .names()
            .into_iter()
            .filter(|n| n.name_id == ttf_parser::name_id::POST_SCRIPT_NAME)
            .filter_map(|n| n.to_string())
            .find(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_graphic()))
            .unwrap_or_else(|| "Font".into());
        let b = f.global_bounding_box();
        let k = |v: i16| (f64::from(v) * per_mille) as f32;
        let bbox = Rect::new(k(b.x_min), k(b.y_min), k(b.x_max), k(b.y_max));
        let ascent = f64::from(f.ascender()) * per_mille;
        let descent = f64::from(f.descender()) * per_mille;
        let cap_height = f64::from(f.capital_height().unwrap_or(f.ascender())) * per_mille;
        Ok(Self {
            bytes,
            face: f,
            name,
            per_mille,
            ascent,
            descent,
            cap_height,
            bbox,
        })
    }

    /// Each character's glyph and advance (per mille); a character the
    /// font lacks is glyph 0, the font's "missing" box.
    fn shape(&self, text: &str) -> Vec<(char, u16, f64)> {
        let f = &self.face;
        text.chars()
            .map(|c| {
                let g = f.glyph_index(c).unwrap_or(ttf_parser::GlyphId(0));
                let adv = f64::from(f.glyph_hor_advance(g).unwrap_or(0)) * self.per_mille;
                (c, g.0, adv)
            })
            .collect()
    }

    /// Width of `text` at `em` units per em, as the PDF draws it (no kerning).
    fn width(&self, text: &str, em: f64) -> f64 {
        self.shape(text).iter().map(|g| g.2).sum::<f64>() * em / 1000.0
    }
}

fn deflate(data: &[u8]) -> Vec<u8> {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    // Writing to a Vec cannot fail.
    let _ = z.write_all(data);
    z.finish().unwrap_or_default()
}

/// Six capital letters from the glyphs a subset keeps: its tag, the same
/// for the same glyphs (FNV-1a).
fn subset_tag(glyphs: impl IntoIterator<Item = u16>) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for g in glyphs {
        for b in g.to_be_bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    (0..6)
        .map(|_| {
            let c = char::from(b'A' + (h % 26) as u8);
            h /= 26;
            c
        })
        .collect()
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
            font: Face::new(font)?,
            content: Content::new(),
            images: Vec::new(),
            alphas: Vec::new(),
            glyphs: subsetter::GlyphRemapper::new(),
            chars: BTreeMap::new(),
            presented: false,
        })
    }

    /// Saves the state and sets the colour (fill or stroke) and its alpha;
    /// `None` when fully transparent (nothing to draw, nothing saved).
    fn paint(&mut self, c: BackendColor, stroke: bool) -> Option<()> {
        if c.alpha <= 0.0 {
            return None;
        }
        let (r, g, b) = c.rgb;
        let k = |v: u8| f32::from(v) / 255.0;
        self.content.save_state();
        if stroke {
            self.content.set_stroke_rgb(k(r), k(g), k(b));
        } else {
            self.content.set_fill_rgb(k(r), k(g), k(b));
        }
        if c.alpha < 1.0 {
            let a = (c.alpha * 1000.0).round().clamp(1.0, 999.0) as u16;
            let i = match self.alphas.iter().position(|&x| x == a) {
                Some(i) => i,
                None => {
                    self.alphas.push(a);
                    self.alphas.len() - 1
                }
            };
            self.content
                .set_parameters(Name(format!("GS{i}").as_bytes()));
        }
        Some(())
    }

    fn stroke_setup<S: BackendStyle>(&mut self, style: &S) -> Option<()> {
        self.paint(style.color(), true)?;
        self.content.set_line_width(style.stroke_width() as f32);
        Some(())
    }

    /// The font file: the subset of the glyphs drawn.
    fn font_file(&self) -> Result<Vec<u8>, PdfError> {
        subsetter::subset(self.font.bytes, 0, &self.glyphs)
            .map_err(|e| PdfError(format!("cannot cut the font to the glyphs drawn: {e}")))
    }

    /// The whole file.
    fn build(&self) -> Result<Vec<u8>, PdfError> {
        let (w, h) = self.size;
        let (wpt, hpt) = (f64::from(w) * self.unit_pt, f64::from(h) * self.unit_pt);
        let id = Ref::new;
        let (catalog, pages, page, content, font, cid_font, descriptor, file, cmap, info) = (
            id(1),
            id(2),
            id(3),
            id(4),
            id(5),
            id(6),
            id(7),
            id(8),
            id(9),
            id(10),
        );
        let gs = |i: usize| id(11 + i as i32);
        let im = |i: usize| id(11 + (self.alphas.len() + i) as i32);
        let mut pdf = Pdf::new();
        pdf.set_version(1, 4);
        pdf.catalog(catalog).pages(pages);
        pdf.pages(pages).kids([page]).count(1);
        let mut p = pdf.page(page);
        p.parent(pages)
            .media_box(Rect::new(0.0, 0.0, wpt as f32, hpt as f32))
            .contents(content);
        let mut res = p.resources();
        res.fonts().pair(Name(b"F1"), font);
        if !self.images.is_empty() {
            let mut x = res.x_objects();
            for i in 0..self.images.len() {
                x.pair(Name(format!("Im{i}").as_bytes()), im(i));
            }
        }
        if !self.alphas.is_empty() {
            let mut g = res.ext_g_states();
            for i in 0..self.alphas.len() {
                g.pair(Name(format!("GS{i}").as_bytes()), gs(i));
            }
        }
        res.finish();
        p.finish();

        // Units to points, y down; then what was drawn.
        let mut head = Content::new();
        let u = self.unit_pt as f32;
        head.transform([u, 0.0, 0.0, -u, 0.0, hpt as f32])
            .set_line_join(LineJoinStyle::RoundJoin)
            .set_line_cap(LineCapStyle::RoundCap);
        let mut stream = head.finish().into_vec();
        stream.push(b'\n');
        stream.extend_from_slice(self.content.as_bytes());
        pdf.stream(content, &deflate(&stream))
            .filter(Filter::FlateDecode);

        // The font: Type 0 over a CID TrueType font, glyph = CID in the subset.
        let f = &self.font;
        let tag = subset_tag(self.glyphs.remapped_gids());
        let base = format!("{tag}+{}", f.name);
        pdf.type0_font(font)
            .base_font(Name(base.as_bytes()))
            .encoding_predefined(Name(b"Identity-H"))
            .descendant_font(cid_font)
            .to_unicode(cmap);
        let face = &f.face;
        let widths: Vec<f32> = self
            .glyphs
            .remapped_gids()
            .map(|g| {
                let adv = face.glyph_hor_advance(ttf_parser::GlyphId(g)).unwrap_or(0);
                (f64::from(adv) * f.per_mille).round() as f32
            })
            .collect();
        let system = SystemInfo {
            registry: Str(b"Adobe"),
            ordering: Str(b"Identity"),
            supplement: 0,
        };
        let mut cid = pdf.cid_font(cid_font);
        cid.subtype(CidFontType::Type2)
            .base_font(Name(base.as_bytes()))
            .system_info(system)
            .font_descriptor(descriptor)
            .cid_to_gid_map_predefined(Name(b"Identity"));
        cid.widths().consecutive(0, widths);
        cid.finish();
        pdf.font_descriptor(descriptor)
            .name(Name(base.as_bytes()))
            .flags(FontFlags::SYMBOLIC)
            .bbox(f.bbox)
            .italic_angle(0.0)
            .ascent(f.ascent.round() as f32)
            .descent(f.descent.round() as f32)
            .cap_height(f.cap_height.round() as f32)
            .stem_v(80.0)
            .font_file2(file);
        let sub = self.font_file()?;
        pdf.stream(file, &deflate(&sub))
            .filter(Filter::FlateDecode)
            .pair(Name(b"Length1"), sub.len() as i32);
        let mut map = pdf_writer::types::UnicodeCmap::new(Name(b"Custom"), system);
        for (&g, &c) in &self.chars {
            map.pair(g, c);
        }
        pdf.cmap(cmap, &deflate(map.finish().as_slice()))
            .filter(Filter::FlateDecode);
        pdf.document_info(info).producer(TextStr("lmhost"));
        for (i, a) in self.alphas.iter().enumerate() {
            let a = f32::from(*a) / 1000.0;
            pdf.ext_graphics(gs(i))
                .stroking_alpha(a)
                .non_stroking_alpha(a);
        }
        for (i, (iw, ih, px)) in self.images.iter().enumerate() {
            let data = deflate(px);
            let mut x = pdf.image_xobject(im(i), &data);
            x.width(*iw as i32).height(*ih as i32).bits_per_component(8);
            x.color_space().device_rgb();
            x.filter(Filter::FlateDecode);
        }
        // A line end after `%%EOF`, as most writers leave one.
        let mut bytes = pdf.finish();
        bytes.push(b'\n');
        Ok(bytes)
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
            *self.out = self.build().map_err(DrawingErrorKind::DrawingError)?;
            self.presented = true;
        }
        Ok(())
    }

    fn draw_pixel(&mut self, (x, y): BackendCoord, color: BackendColor) -> R<'a> {
        if self.paint(color, false).is_some() {
            self.content
                .rect(x as f32, y as f32, 1.0, 1.0)
                .fill_nonzero()
                .restore_state();
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
            self.content
                .move_to(from.0 as f32, from.1 as f32)
                .line_to(to.0 as f32, to.1 as f32)
                .stroke()
                .restore_state();
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
        let (w, h) = ((br.0 - ul.0) as f32, (br.1 - ul.1) as f32);
        if self.shape_setup(style, fill).is_some() {
            self.content.rect(ul.0 as f32, ul.1 as f32, w, h);
            self.shape_end(fill);
        }
        Ok(())
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> R<'a> {
        self.polyline(path, style, false);
        Ok(())
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        (cx, cy): BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> R<'a> {
        if self.shape_setup(style, fill).is_none() {
            return Ok(());
        }
        // Four cubic Béziers, the usual 0.5523 handle.
        let (x, y, r) = (cx as f32, cy as f32, radius as f32);
        let k = 0.552_284_8 * r;
        let c = &mut self.content;
        c.move_to(x + r, y)
            .cubic_to(x + r, y + k, x + k, y + r, x, y + r)
            .cubic_to(x - k, y + r, x - r, y + k, x - r, y)
            .cubic_to(x - r, y - k, x - k, y - r, x, y - r)
            .cubic_to(x + k, y - r, x + r, y - k, x + r, y);
        self.shape_end(fill);
        Ok(())
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> R<'a> {
        self.polyline(vert, style, true);
        Ok(())
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> R<'a> {
        let em = style.size() / SIZE_PER_EM;
        let shaped = self.font.shape(text);
        let w = shaped.iter().map(|g| g.2).sum::<f64>() * em / 1000.0;
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
        // Two bytes a glyph, its number in the subset (Identity-H).
        let mut cids = Vec::with_capacity(2 * shaped.len());
        for (c, g, _) in shaped {
            let new = self.glyphs.remap(g);
            if g != 0 {
                self.chars.entry(new).or_insert(c);
            }
            cids.extend_from_slice(&new.to_be_bytes());
        }
        if self.paint(style.color(), false).is_none() {
            return Ok(());
        }
        let f = |v: f64| v as f32;
        self.content
            .begin_text()
            .set_font(Name(b"F1"), f(em))
            .set_text_matrix([
                f(ax),
                f(ay),
                f(ux),
                f(uy),
                f(f64::from(pos.0) + ox),
                f(f64::from(pos.1) + oy),
            ])
            .show(Str(&cids))
            .end_text()
            .restore_state();
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
        self.content
            .save_state()
            .transform([
                iw as f32,
                0.0,
                0.0,
                -(ih as f32),
                x as f32,
                (i64::from(y) + i64::from(ih)) as f32,
            ])
            .x_object(Name(format!("Im{i}").as_bytes()))
            .restore_state();
        Ok(())
    }
}

impl PdfBackend<'_> {
    /// [`paint`](Self::paint) for a filled shape, [`stroke_setup`](Self::stroke_setup)
    /// for an outline (plotters' `fill` flag on rectangles and circles; a
    /// polygon is filled, a path outlined).
    fn shape_setup<S: BackendStyle>(&mut self, style: &S, fill: bool) -> Option<()> {
        if fill {
            self.paint(style.color(), false)
        } else {
            self.stroke_setup(style)
        }
    }

    /// Fills or strokes the shape just drawn, and restores the state its
    /// [`shape_setup`](Self::shape_setup) saved.
    fn shape_end(&mut self, fill: bool) {
        if fill {
            self.content.fill_nonzero();
        } else {
            self.content.stroke();
        }
        self.content.restore_state();
    }

    /// The points joined by lines (`m` to the first, `l` to the others):
    /// stroked as an open path, or closed and filled as a polygon. No
    /// points, nothing drawn.
    fn polyline<S: BackendStyle>(
        &mut self,
        pts: impl IntoIterator<Item = BackendCoord>,
        style: &S,
        fill: bool,
    ) {
        let mut pts = pts.into_iter().peekable();
        if pts.peek().is_none() || self.shape_setup(style, fill).is_none() {
            return;
        }
        for (i, (x, y)) in pts.enumerate() {
            if i == 0 {
                self.content.move_to(x as f32, y as f32);
            } else {
                self.content.line_to(x as f32, y as f32);
            }
        }
        if fill {
            self.content.close_path();
        }
        self.shape_end(fill);
    }
}

#[cfg(test)]
pub(crate) mod read;
#[cfg(test)]
mod tests;
