//! A TrueType subset for embedding: the glyphs a page uses (and the
//! components of composite glyphs) keep their outlines, every other glyph
//! becomes empty, and the tables a PDF viewer does not read (layout,
//! kerning, glyph names) are dropped. Glyph ids, the `cmap` and the metrics
//! are unchanged, so the page's text and widths need nothing else.
//!
//! Any structure this reader does not expect gives `None`, and the caller
//! embeds the whole font instead.

use std::collections::BTreeSet;

/// Tables kept (besides `glyf` and `loca`, which are rebuilt, and `post`,
/// cut to its header).
const KEEP: [&[u8; 4]; 9] = [
    b"cmap", b"cvt ", b"fpgm", b"head", b"hhea", b"hmtx", b"maxp", b"OS/2", b"prep",
];

fn be16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes(b.get(at..at + 2)?.try_into().ok()?))
}

fn be32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_be_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

/// The font's tables: tag → bytes.
fn tables(ttf: &[u8]) -> Option<Vec<([u8; 4], &[u8])>> {
    let n = usize::from(be16(ttf, 4)?);
    (0..n)
        .map(|i| {
            let rec = 12 + 16 * i;
            let tag: [u8; 4] = ttf.get(rec..rec + 4)?.try_into().ok()?;
            let off = be32(ttf, rec + 8)? as usize;
            let len = be32(ttf, rec + 12)? as usize;
            Some((tag, ttf.get(off..off.checked_add(len)?)?))
        })
        .collect()
}

fn checksum(data: &[u8]) -> u32 {
    data.chunks(4).fold(0u32, |s, c| {
        let mut w = [0u8; 4];
        w[..c.len()].copy_from_slice(c);
        s.wrapping_add(u32::from_be_bytes(w))
    })
}

/// `ttf` with only `used` glyph ids (plus glyph 0 and the components of
/// composite glyphs) keeping their outlines.
pub fn subset(ttf: &[u8], used: &BTreeSet<u16>) -> Option<Vec<u8>> {
    let tabs = tables(ttf)?;
    let get = |t: &[u8; 4]| tabs.iter().find(|(tag, _)| tag == t).map(|(_, d)| *d);
    let head = get(b"head")?;
    let glyf = get(b"glyf")?;
    let loca = get(b"loca")?;
    let glyphs = usize::from(be16(get(b"maxp")?, 4)?);
    let long = be16(head, 50)? == 1;
    let offset = |g: usize| -> Option<usize> {
        if long {
            be32(loca, 4 * g).map(|v| v as usize)
        } else {
            be16(loca, 2 * g).map(|v| 2 * usize::from(v))
        }
    };
    let outline = |g: usize| -> Option<&[u8]> {
        let (a, b) = (offset(g)?, offset(g + 1)?);
        glyf.get(a..b)
    };

    // Used glyphs and, transitively, the components of composites.
    let mut keep: BTreeSet<u16> = used
        .iter()
        .copied()
        .filter(|&g| usize::from(g) < glyphs)
        .collect();
    keep.insert(0);
    let mut todo: Vec<u16> = keep.iter().copied().collect();
    while let Some(g) = todo.pop() {
        let data = outline(usize::from(g))?;
        if data.len() < 10 || (be16(data, 0)? as i16) >= 0 {
            continue;
        }
        let mut at = 10;
        loop {
            let flags = be16(data, at)?;
            let comp = be16(data, at + 2)?;
            if usize::from(comp) >= glyphs {
                return None;
            }
            if keep.insert(comp) {
                todo.push(comp);
            }
            at += 4 + if flags & 0x0001 != 0 { 4 } else { 2 };
            at += match flags {
                f if f & 0x0008 != 0 => 2,
                f if f & 0x0040 != 0 => 4,
                f if f & 0x0080 != 0 => 8,
                _ => 0,
            };
            if flags & 0x0020 == 0 {
                break;
            }
        }
    }

    let mut new_glyf = Vec::new();
    let mut new_loca = Vec::with_capacity(4 * (glyphs + 1));
    for g in 0..glyphs {
        new_loca.extend_from_slice(&u32::try_from(new_glyf.len()).ok()?.to_be_bytes());
        if keep.contains(&u16::try_from(g).ok()?) {
            new_glyf.extend_from_slice(outline(g)?);
            while new_glyf.len() % 4 != 0 {
                new_glyf.push(0);
            }
        }
    }
    new_loca.extend_from_slice(&u32::try_from(new_glyf.len()).ok()?.to_be_bytes());
    let mut new_head = head.to_vec();
    new_head.get_mut(8..12)?.copy_from_slice(&[0; 4]);
    new_head
        .get_mut(50..52)?
        .copy_from_slice(&1u16.to_be_bytes());
    // post format 3: no glyph names.
    let mut post = get(b"post")?.get(..32)?.to_vec();
    post[..4].copy_from_slice(&0x0003_0000u32.to_be_bytes());

    let mut out_tabs: Vec<([u8; 4], Vec<u8>)> = Vec::new();
    for t in KEEP {
        if let Some(d) = get(t) {
            let d = if t == b"head" {
                new_head.clone()
            } else {
                d.to_vec()
            };
            out_tabs.push((*t, d));
        }
    }
    out_tabs.push((*b"glyf", new_glyf));
    out_tabs.push((*b"loca", new_loca));
    out_tabs.push((*b"post", post));
    out_tabs.sort_by_key(|t| t.0);

    // The table directory, then the tables, each 4-byte aligned.
    let n = out_tabs.len() as u16;
    let mut pow = 1u16;
    let mut log = 0u16;
    while pow * 2 <= n {
        pow *= 2;
        log += 1;
    }
    let mut font = Vec::new();
    font.extend_from_slice(&0x0001_0000u32.to_be_bytes());
    for v in [n, pow * 16, log, n * 16 - pow * 16] {
        font.extend_from_slice(&v.to_be_bytes());
    }
    let mut at = 12 + 16 * out_tabs.len();
    let mut head_at = 0;
    for (tag, d) in &out_tabs {
        if tag == b"head" {
            head_at = at;
        }
        font.extend_from_slice(tag);
        font.extend_from_slice(&checksum(d).to_be_bytes());
        font.extend_from_slice(&u32::try_from(at).ok()?.to_be_bytes());
        font.extend_from_slice(&u32::try_from(d.len()).ok()?.to_be_bytes());
        at += d.len().div_ceil(4) * 4;
    }
    for (_, d) in &out_tabs {
        font.extend_from_slice(d);
        font.resize(font.len().div_ceil(4) * 4, 0);
    }
    let adjust = 0xB1B0_AFBAu32.wrapping_sub(checksum(&font));
    font.get_mut(head_at + 8..head_at + 12)?
        .copy_from_slice(&adjust.to_be_bytes());
    Some(font)
}

#[cfg(test)]
mod tests {
    use ab_glyph::{Font, FontRef};

    use super::*;
    use crate::field::plot::FONT;

    #[test]
    fn subset_keeps_used_outlines_metrics_and_composites_only() {
        let full = FontRef::try_from_slice(FONT).unwrap();
        let gid = |c: char| full.glyph_id(c).0;
        // 'é' is a composite of 'e' and the acute in DejaVu Sans.
        let used: BTreeSet<u16> = "a(m)é".chars().map(gid).collect();
        let sub = subset(FONT, &used).unwrap();
        assert!(
            sub.len() * 4 < FONT.len(),
            "{} of {}",
            sub.len(),
            FONT.len()
        );
        let f = FontRef::try_from_slice(&sub).unwrap();
        for c in "a(m)éXz".chars() {
            let (g0, g1) = (full.glyph_id(c), f.glyph_id(c));
            assert_eq!(g0, g1, "{c}: the cmap is kept");
            assert_eq!(full.h_advance_unscaled(g0), f.h_advance_unscaled(g1), "{c}");
            let kept = f.outline(g1).is_some();
            assert_eq!(kept, "a(m)é".contains(c), "{c}: outline kept only if used");
            if kept {
                let (a, b) = (full.outline(g0).unwrap(), f.outline(g1).unwrap());
                assert_eq!(a.curves.len(), b.curves.len(), "{c}");
            }
        }
        // The composite's component came along (its outline is drawn).
        assert!(f.outline(f.glyph_id('e')).is_some() || f.outline(f.glyph_id('é')).is_some());
        // The whole-file checksum is what the head table says it is.
        assert_eq!(checksum(&sub), 0xB1B0_AFBA);
        // Not a font: no subset.
        assert!(subset(b"nonsense", &used).is_none());
    }
}
