//! NumPy `.npy` files, the one module that reads and writes them: the
//! header writer every output uses ([`header`], [`encode_f64`],
//! [`encode_u8`]), and recordings as `.npy`: depth as `uint16` (frames,
//! height, width), colour as `uint8` (frames, height, width, 3) RGB, and
//! `float64` (frames,) time stamps.
//!
//! The reader is strict: NPY versions 1–3, `'<u2'` / `'|u1'` / `'<f8'` only, C order,
//! header ≤ 64 KiB, and the data must be exactly as long as the shape says.
//! Frames are read one at a time, so memory is one frame however long the
//! recording; nothing is allocated before the file's size has confirmed it.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

use crate::InputError;

/// Largest accepted header (bytes).
pub const MAX_HEADER: usize = 64 * 1024;
/// Largest accepted frame side (pixels).
pub const MAX_SIDE: u64 = 8192;

/// A parsed NPY header.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// `descr`, e.g. `<u2`.
    pub descr: String,
    /// Shape.
    pub shape: Vec<u64>,
    /// Offset of the data (bytes).
    pub data_offset: u64,
}

fn bad(path: &Path, msg: impl std::fmt::Display) -> InputError {
    InputError::new(format!("{}: {msg}", path.display()))
}

/// Parse the header of an NPY file of `file_len` bytes from `r`.
pub fn read_header(r: &mut impl Read, file_len: u64, path: &Path) -> Result<Header, InputError> {
    let mut pre = [0u8; 8];
    r.read_exact(&mut pre)
        .map_err(|_| bad(path, "not an .npy file (shorter than its magic)"))?;
    if &pre[..6] != b"\x93NUMPY" {
        return Err(bad(path, "not an .npy file (bad magic)"));
    }
    // The header length: a u16 in version 1, a u32 from version 2 on
    // (both little-endian, read into the low bytes of a u32).
    let width = match pre[6] {
        1 => 2,
        2 | 3 => 4,
        v => {
            return Err(bad(
                path,
                format!(".npy version {v} is not supported (1–3)"),
            ));
        }
    };
    let mut l = [0u8; 4];
    r.read_exact(&mut l[..width])
        .map_err(|_| bad(path, "truncated .npy header"))?;
    let (len, prefix) = (u32::from_le_bytes(l) as usize, pre.len() + width);
    if len > MAX_HEADER || (prefix + len) as u64 > file_len {
        return Err(bad(
            path,
            format!(".npy header of {len} bytes is longer than the file or {MAX_HEADER} bytes"),
        ));
    }
    let mut h = vec![0u8; len];
    r.read_exact(&mut h)
        .map_err(|_| bad(path, "truncated .npy header"))?;
    let text = std::str::from_utf8(&h).map_err(|_| bad(path, ".npy header is not text"))?;
    for key in ["descr", "fortran_order", "shape"] {
        if text.matches(&format!("'{key}'")).count() > 1 {
            return Err(bad(path, format!(".npy header gives '{key}' twice")));
        }
    }
    // numpy writes these three keys and refuses a header with others; a
    // key we would not read is never ignored.
    if let Some(k) = dict_keys(text)
        .into_iter()
        .find(|k| !["descr", "fortran_order", "shape"].contains(k))
    {
        return Err(bad(
            path,
            format!(
                ".npy header has key '{}': only 'descr', 'fortran_order' and 'shape' belong there",
                excerpt(k)
            ),
        ));
    }
    // A key present with a value of the wrong kind is said so, not that
    // the key is missing.
    let wrong = |key: &str, want: &str, v: &str| {
        bad(
            path,
            format!(
                ".npy header's '{key}' must be {want}, got `{}`",
                excerpt(value_text(v))
            ),
        )
    };
    let v = dict_value(text, "descr").ok_or_else(|| bad(path, ".npy header has no 'descr'"))?;
    let descr = v
        .strip_prefix('\'')
        .and_then(|v| v.split_once('\''))
        .filter(|(_, rest)| ends_value(rest))
        .ok_or_else(|| wrong("descr", "a quoted type such as '<u2'", v))?
        .0
        .to_string();
    let is = |v: &str, word: &str| v.strip_prefix(word).is_some_and(ends_value);
    match dict_value(text, "fortran_order") {
        Some(v) if is(v, "False") => {}
        Some(v) if is(v, "True") => {
            return Err(bad(
                path,
                "Fortran-order arrays are not supported; save in C order",
            ));
        }
        Some(v) => return Err(wrong("fortran_order", "False or True", v)),
        None => return Err(bad(path, ".npy header has no 'fortran_order'")),
    }
    let v = dict_value(text, "shape").ok_or_else(|| bad(path, ".npy header has no 'shape'"))?;
    let shape_txt = v
        .strip_prefix('(')
        .and_then(|v| v.split_once(')'))
        .filter(|(_, rest)| ends_value(rest))
        .ok_or_else(|| wrong("shape", "a tuple of sizes", v))?
        .0;
    let shape = shape_txt
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<u64>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| {
            bad(
                path,
                format!(
                    ".npy shape `({})` is not a tuple of sizes",
                    excerpt(shape_txt)
                ),
            )
        })?;
    if shape.len() > MAX_DIMS {
        return Err(bad(
            path,
            format!(
                ".npy shape has {} dimensions; numpy writes at most {MAX_DIMS}",
                shape.len()
            ),
        ));
    }
    Ok(Header {
        descr,
        shape,
        data_offset: (prefix + len) as u64,
    })
}

/// Most dimensions a shape may have (numpy's `NPY_MAXDIMS`): a longer
/// one is no recording, and would be echoed whole by the messages after.
const MAX_DIMS: usize = 64;

/// The keys of the header's dict literal: each quoted word followed by
/// `:` (splitting at `'`, the odd parts are the quoted ones).
fn dict_keys(text: &str) -> Vec<&str> {
    let parts: Vec<&str> = text.split('\'').collect();
    parts
        .windows(2)
        .enumerate()
        .filter(|(i, w)| i % 2 == 1 && w[1].trim_start().starts_with(':'))
        .map(|(_, w)| w[0])
        .collect()
}

/// Whether `rest`, what follows a value, ends it: a value with anything
/// after it (`'<u2'*2`, `Falsey`) is not the value it starts with.
fn ends_value(rest: &str) -> bool {
    rest.trim_start().starts_with([',', '}'])
}

/// A value's text up to the next `,` or `}` (what a message quotes).
fn value_text(v: &str) -> &str {
    v.split([',', '}']).next().unwrap_or(v).trim()
}

/// `s` cut to a readable length for a message.
fn excerpt(s: &str) -> String {
    const MAX: usize = 40;
    match s.char_indices().nth(MAX) {
        Some((at, _)) => format!("{}…({} characters)", &s[..at], s.chars().count()),
        None => s.to_string(),
    }
}

/// The text after `'key':` in a Python dict literal.
fn dict_value<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    let pat = format!("'{key}'");
    // A key given twice is ambiguous (Python keeps the last, a careless
    // reader the first): treated as missing, so the header is refused.
    if text.matches(&pat).count() != 1 {
        return None;
    }
    let at = text.find(&pat)? + pat.len();
    Some(text[at..].trim_start().strip_prefix(':')?.trim_start())
}

fn check_descr(path: &Path, h: &Header, want: &str, what: &str) -> Result<(), InputError> {
    if h.descr == want {
        return Ok(());
    }
    let hint = if h.descr.starts_with('>') {
        " (big-endian)"
    } else {
        ""
    };
    Err(bad(
        path,
        format!("dtype `{}`{hint}, expected {what} `{want}`", h.descr),
    ))
}

fn check_len(path: &Path, h: &Header, file_len: u64, item: u64) -> Result<(), InputError> {
    let want = h
        .shape
        .iter()
        .try_fold(item, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| bad(path, format!("shape {:?} is too large", h.shape)))?;
    let have = file_len - h.data_offset;
    if have < want {
        return Err(bad(
            path,
            format!(
                "truncated: shape {:?} needs {want} bytes of data, the file has {have}",
                h.shape
            ),
        ));
    }
    if have > want {
        return Err(bad(
            path,
            format!(
                "{} bytes after the data of shape {:?}",
                have - want,
                h.shape
            ),
        ));
    }
    Ok(())
}

/// Opens a recording and reads its header, whose type must be `descr`
/// (`what` in the error); returns the reader at its data, the file's
/// length and the header.
fn open(
    path: &Path,
    descr: &str,
    what: &str,
) -> Result<(BufReader<File>, u64, Header), InputError> {
    // Checked before it is opened: a FIFO, a directory or a device node is
    // refused at once, and the file is remembered as an input.
    let f = crate::files::open_input("recording", path)?;
    let len = f
        .metadata()
        .map_err(|_| bad(path, "cannot read its size"))?
        .len();
    let mut reader = BufReader::new(f);
    let h = read_header(&mut reader, len, path)?;
    check_descr(path, &h, descr, what)?;
    Ok((reader, len, h))
}

/// Frames of a recording (`K`: depth or colour), read one at a time.
pub struct NpyFrames<K: FrameKind> {
    path: PathBuf,
    reader: BufReader<File>,
    /// Number of frames.
    pub frames: u64,
    /// Frame height (rows).
    pub height: u32,
    /// Frame width (columns).
    pub width: u32,
    next: u64,
    kind: std::marker::PhantomData<K>,
}

/// Frames of a `uint16` (frames, height, width) `.npy`.
pub type DepthNpy = NpyFrames<Depth>;
/// Colour frames of a `uint8` (frames, height, width, 3) `.npy` (RGB).
pub type ColourNpy = NpyFrames<Rgb>;

impl<K: FrameKind> NpyFrames<K> {
    /// Open and check a recording.
    pub fn open(path: &Path) -> Result<Self, InputError> {
        let (reader, len, h) = open(path, K::DESCR, K::TYPE_NAME)?;
        let (frames, height, width) = match h.shape[..] {
            [f, hh, w] if K::PER_PIXEL == 1 => (f, hh, w),
            [f, hh, w, c] if K::PER_PIXEL > 1 && c == K::PER_PIXEL => (f, hh, w),
            _ => {
                let axes = if K::PER_PIXEL > 1 {
                    format!("(frames, height, width, {})", K::PER_PIXEL)
                } else {
                    "(frames, height, width)".to_string()
                };
                return Err(bad(path, format!("shape {:?} must be {axes}", h.shape)));
            }
        };
        if !(1..=MAX_SIDE).contains(&height) || !(1..=MAX_SIDE).contains(&width) {
            return Err(bad(
                path,
                format!("frame size {width}×{height} must be 1..={MAX_SIDE} on each side"),
            ));
        }
        check_len(path, &h, len, K::ITEM_BYTES)?;
        Ok(Self {
            path: path.to_owned(),
            reader,
            frames,
            height: height as u32,
            width: width as u32,
            next: 0,
            kind: std::marker::PhantomData,
        })
    }

    /// Read the next frame into `buf` (resized to width × height pixels);
    /// `false` after the last frame.
    pub fn read_into(&mut self, buf: &mut Vec<K::Value>) -> Result<bool, InputError> {
        if self.next >= self.frames {
            return Ok(false);
        }
        let n = self.width as usize * self.height as usize * K::PER_PIXEL as usize;
        let mut bytes = vec![0u8; n * K::ITEM_BYTES as usize];
        self.reader
            .read_exact(&mut bytes)
            .map_err(|_| bad(&self.path, format!("frame {} is truncated", self.next)))?;
        buf.clear();
        K::decode(&bytes, buf);
        self.next += 1;
        Ok(true)
    }
}

impl NpyFrames<Rgb> {
    /// The next frame (width × height × 3 bytes), `None` after the last.
    pub fn read(&mut self) -> Result<Option<Vec<u8>>, InputError> {
        let mut frame = Vec::new();
        Ok(self.read_into(&mut frame)?.then_some(frame))
    }
}

/// Read a `float64` (n,) `.npy` of time stamps (s): finite, non-decreasing,
/// 0 to [`crate::limits::MAX_TIME_STAMP_S`], at most
/// [`crate::limits::MAX_REPLAY_GAP_S`] apart.
pub fn read_timestamps(path: &Path) -> Result<Vec<f64>, InputError> {
    let (mut reader, len, h) = open(path, "<f8", "float64")?;
    if h.shape.len() != 1 {
        return Err(bad(path, format!("shape {:?} must be (frames,)", h.shape)));
    }
    check_len(path, &h, len, 8)?;
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|_| bad(path, "read error"))?;
    let t: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
        .collect();
    if let Some(i) = t.iter().position(|v| !v.is_finite()) {
        return Err(bad(path, format!("time stamp {i} is not finite")));
    }
    if let Some(i) = t.windows(2).position(|w| w[1] < w[0]) {
        return Err(bad(path, format!("time stamp {} goes backwards", i + 1)));
    }
    // A stream's bounds (`lmhost stream` reads what `track --json` prints),
    // here where the file is named: no negative or absurd stamp, no gap a
    // replay would sleep through.
    use crate::limits::{MAX_REPLAY_GAP_S, MAX_TIME_STAMP_S, show, show_beside};
    if let Some(i) = t.windows(2).position(|w| w[1] - w[0] > MAX_REPLAY_GAP_S) {
        return Err(bad(
            path,
            format!(
                "frame {}: time stamp {} s is {} s after the previous frame's; at most {MAX_REPLAY_GAP_S} s between frames",
                i + 1,
                show(t[i + 1]),
                show(t[i + 1] - t[i])
            ),
        ));
    }
    if let Some(i) = t.iter().position(|v| !(0.0..=MAX_TIME_STAMP_S).contains(v)) {
        return Err(bad(
            path,
            format!(
                "frame {i}: time stamp {} s is out of range: give 0 to {} s",
                show_beside(t[i], 0.0, MAX_TIME_STAMP_S),
                show(MAX_TIME_STAMP_S)
            ),
        ));
    }
    Ok(t)
}

/// An NPY 1.0 header for a C-order array of `descr` and `shape`, padded
/// with spaces to a multiple of 64 bytes and at least `min_len` bytes long
/// (a writer that rewrites the shape later reserves room with `min_len`).
/// The one NPY header writer: every `.npy` lmhost writes starts here.
pub fn header(descr: &str, shape: &[u64], min_len: usize) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(u64::to_string).collect();
    let shape = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut h = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + header length (2) + header + '\n'.
    let unpadded = 10 + h.len() + 1;
    let total = unpadded.max(min_len).next_multiple_of(64);
    h.push_str(&" ".repeat(total - unpadded));
    h.push('\n');
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(h.as_bytes());
    out
}

/// Bytes of a C-order `rows × cols` f64 array as `.npy`; an error when
/// `data.len()` is not `rows × cols`.
pub fn encode_f64(rows: usize, cols: usize, data: &[f64]) -> std::io::Result<Vec<u8>> {
    if data.len() != rows.saturating_mul(cols) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("map has {} values, not {rows} × {cols}", data.len()),
        ));
    }
    let mut out = header("<f8", &[rows as u64, cols as u64], 0);
    out.reserve(data.len() * 8);
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(out)
}

/// Bytes of a C-order `rows × cols` u8 array as `.npy` (`data` must hold
/// `rows × cols` values).
pub fn encode_u8(rows: usize, cols: usize, data: &[u8]) -> Vec<u8> {
    debug_assert_eq!(data.len(), rows * cols);
    let mut out = header("|u1", &[rows as u64, cols as u64], 0);
    out.extend_from_slice(data);
    out
}

/// Write a `rows × cols` f64 map to `path` as `.npy`, whole or not at all.
pub fn write_f64(path: &Path, rows: usize, cols: usize, data: &[f64]) -> anyhow::Result<()> {
    let bytes = encode_f64(rows, cols, data).map_err(|e| crate::files::WriteError::new(path, e))?;
    crate::files::write_whole(path, &bytes)
}

/// Fixed header size of written recordings: room for any shape, 64-aligned.
const WRITE_HEADER: usize = 128;

/// What a recording's frame is made of: its `.npy` type, the trailing
/// axes after (frames, height, width), and its little-endian bytes.
pub trait FrameKind {
    /// One value of a frame.
    type Value: Copy;
    /// The `.npy` type string.
    const DESCR: &'static str;
    /// Its name in errors.
    const TYPE_NAME: &'static str;
    /// Bytes per value.
    const ITEM_BYTES: u64 = std::mem::size_of::<Self::Value>() as u64;
    /// Values per pixel (a last axis when more than one).
    const PER_PIXEL: u64;
    /// What the size error calls a frame.
    const NAME: &'static str;
    /// The frame's bytes as the file holds them.
    fn bytes(frame: &[Self::Value]) -> std::borrow::Cow<'_, [u8]>;
    /// The values of a frame's bytes, appended to `out`.
    fn decode(bytes: &[u8], out: &mut Vec<Self::Value>);
}

/// Depth frames: `uint16` (frames, height, width), millimetres.
#[derive(Debug)]
pub enum Depth {}

impl FrameKind for Depth {
    type Value = u16;
    const DESCR: &'static str = "<u2";
    const TYPE_NAME: &'static str = "uint16";
    const PER_PIXEL: u64 = 1;
    const NAME: &'static str = "frame";
    fn bytes(frame: &[u16]) -> std::borrow::Cow<'_, [u8]> {
        frame.iter().flat_map(|v| v.to_le_bytes()).collect()
    }
    fn decode(bytes: &[u8], out: &mut Vec<u16>) {
        out.extend(
            bytes
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]])),
        );
    }
}

/// Colour frames: `uint8` (frames, height, width, 3), RGB.
#[derive(Debug)]
pub enum Rgb {}

impl FrameKind for Rgb {
    type Value = u8;
    const DESCR: &'static str = "|u1";
    const TYPE_NAME: &'static str = "uint8";
    const PER_PIXEL: u64 = 3;
    const NAME: &'static str = "colour frame";
    fn bytes(frame: &[u8]) -> std::borrow::Cow<'_, [u8]> {
        std::borrow::Cow::Borrowed(frame)
    }
    fn decode(bytes: &[u8], out: &mut Vec<u8>) {
        out.extend_from_slice(bytes);
    }
}

/// Writes a recording frame by frame into a [`crate::files::Output`]: the
/// header's frame count is written on [`NpyFrameWriter::finish`], which
/// renames the file into place, so the named file is whole or absent
/// (dropped unfinished, it never appears).
pub struct NpyFrameWriter<K: FrameKind> {
    out: crate::files::Output,
    height: u32,
    width: u32,
    frames: u64,
    kind: std::marker::PhantomData<K>,
}

/// A depth recording's writer.
pub type DepthNpyWriter = NpyFrameWriter<Depth>;
/// A colour recording's writer.
pub type ColourNpyWriter = NpyFrameWriter<Rgb>;

impl<K: FrameKind> NpyFrameWriter<K> {
    /// Start writing `path` for frames of `width` × `height`.
    pub fn create(path: &Path, width: u32, height: u32) -> anyhow::Result<Self> {
        let mut w = Self {
            out: crate::files::Output::create(path)?,
            height,
            width,
            frames: 0,
            kind: std::marker::PhantomData,
        };
        let h = w.header();
        w.out.write_bytes(&h)?;
        Ok(w)
    }

    fn header(&self) -> Vec<u8> {
        let mut shape = vec![self.frames, u64::from(self.height), u64::from(self.width)];
        if K::PER_PIXEL > 1 {
            shape.push(K::PER_PIXEL);
        }
        header(K::DESCR, &shape, WRITE_HEADER)
    }

    /// Append one frame (`width × height` pixels, row-major).
    pub fn push(&mut self, frame: &[K::Value]) -> anyhow::Result<()> {
        let want = u64::from(self.width) * u64::from(self.height) * K::PER_PIXEL;
        if frame.len() as u64 != want {
            anyhow::bail!(
                "{}: {} size changed while recording",
                self.out.path().display(),
                K::NAME
            );
        }
        self.out.write_bytes(&K::bytes(frame))?;
        self.frames += 1;
        Ok(())
    }

    /// Write the final header, sync and move the file into place; returns
    /// the frame count.
    pub fn finish(mut self) -> anyhow::Result<u64> {
        let h = self.header();
        self.out.write_at(0, &h)?;
        self.out.commit()?;
        Ok(self.frames)
    }
}

/// Write a `float64` (n,) `.npy`, whole or not at all.
pub fn write_f64_1d(path: &Path, data: &[f64]) -> anyhow::Result<()> {
    let mut out = header("<f8", &[data.len() as u64], WRITE_HEADER);
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    crate::files::write_whole(path, &out)
}

#[cfg(test)]
mod tests;
