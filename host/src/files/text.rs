//! Text as other tools and platforms write it, read one way: every text
//! input lmhost reads (whole files and line streams) goes through here.
//!
//! - A UTF-8 byte-order mark opening the text (Notepad, Excel's "CSV
//!   UTF-8", PowerShell 7's `utf8BOM`, many MATLAB and C# writers) is
//!   skipped; one opening a later line (a second file joined on) is
//!   refused, never read as part of a value.
//! - CRLF and a lone CR (classic Mac, Excel for Mac's CSV) end a line as
//!   LF does, so line numbers in messages are those an editor shows.
//! - UTF-16 and UTF-32 (PowerShell 5's `Out-File` and `>`; found by their
//!   byte-order mark or by the NUL bytes of their ASCII) are refused,
//!   saying what the text is and what to do; so is any other text that is
//!   not UTF-8, and a NUL byte, which no text holds.
//! - A CSV line separated by `;` or tabs (a European-locale spreadsheet,
//!   where `3,5` is 3.5) is refused naming what was found
//!   ([`foreign_csv`]), never read with its numbers split at the comma.

/// The encoding `bytes` are in when it is UTF-16 or UTF-32: by a
/// byte-order mark, else by the NUL bytes ASCII text has in it.
pub fn wide_encoding(bytes: &[u8]) -> Option<&'static str> {
    const BOMS: [(&[u8], &str); 4] = [
        (b"\xff\xfe\0\0", "UTF-32 (little-endian)"),
        (b"\0\0\xfe\xff", "UTF-32 (big-endian)"),
        (b"\xff\xfe", "UTF-16 (little-endian)"),
        (b"\xfe\xff", "UTF-16 (big-endian)"),
    ];
    if let Some((_, name)) = BOMS.iter().find(|(bom, _)| bytes.starts_with(bom)) {
        return Some(name);
    }
    let nul = |i: usize| bytes.get(i).map(|&b| b == 0);
    // Two characters' worth: ASCII in UTF-32 is 3 NULs to a byte, in
    // UTF-16 one.
    match [nul(0), nul(1), nul(2), nul(3)] {
        [Some(false), Some(true), Some(true), Some(true)] => Some("UTF-32 (little-endian)"),
        [Some(true), Some(true), Some(true), Some(false)] => Some("UTF-32 (big-endian)"),
        [Some(false), Some(true), Some(false), Some(true)] => Some("UTF-16 (little-endian)"),
        [Some(true), Some(false), Some(true), Some(false)] => Some("UTF-16 (big-endian)"),
        _ => None,
    }
}

/// Why `bytes` (a whole file) are not text as lmhost reads it, or the
/// text: its byte-order mark skipped, every CRLF and lone CR read as LF.
/// The reason completes "cannot read FILE: …".
pub fn decode(bytes: Vec<u8>) -> Result<String, String> {
    if let Some(enc) = wide_encoding(&bytes) {
        return Err(format!("it is {enc} text, not UTF-8: save it as UTF-8"));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = line_at(e.as_bytes(), at);
        format!("it is not UTF-8 text (line {line}); save it as UTF-8")
    })?;
    let text = match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_owned(),
        None => text,
    };
    let text = if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text
    };
    if let Some(at) = text.find('\0') {
        return Err(format!(
            "line {} holds a NUL byte, which no text file has",
            line_at(text.as_bytes(), at)
        ));
    }
    if let Some(n) = text.split('\n').position(|l| l.starts_with('\u{feff}')) {
        return Err(bom_inside(n + 1));
    }
    Ok(text)
}

/// The 1-based line of byte `at` of `bytes` (lines end at LF, CRLF or CR).
fn line_at(bytes: &[u8], at: usize) -> usize {
    let head = &bytes[..at.min(bytes.len())];
    let lf = head.iter().filter(|&&b| b == b'\n').count();
    let lone_cr = (0..head.len())
        .filter(|&i| bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n'))
        .count();
    1 + lf + lone_cr
}

/// The refusal of a byte-order mark opening line `line_no` (> 1).
pub fn bom_inside(line_no: usize) -> String {
    format!(
        "line {line_no} starts with a byte-order mark (U+FEFF), which only the first line may \
         (were two files joined?)"
    )
}

/// One line of a line stream (stdin, a pipe, a socket, a file read line
/// by line), as [`super::lines::LineReader`] splits it (its line end, LF,
/// CRLF or a lone CR, already cut): as [`decode`] reads a file, the first
/// line's byte-order mark skipped, and the first line refused when it is
/// UTF-16 or UTF-32. The error completes "line N …" messages: it starts
/// with `line {line_no}`.
pub fn stream_line(bytes: &[u8], line_no: usize) -> Result<&str, String> {
    if line_no == 1
        && let Some(enc) = wide_encoding(bytes)
    {
        return Err(format!(
            "line 1 is {enc} text, not UTF-8: send or save it as UTF-8"
        ));
    }
    let text =
        std::str::from_utf8(bytes).map_err(|_| format!("line {line_no} is not UTF-8 text"))?;
    if text.contains('\0') {
        return Err(format!(
            "line {line_no} holds a NUL byte, which no text line has"
        ));
    }
    match (line_no, text.strip_prefix('\u{feff}')) {
        (1, Some(rest)) => Ok(rest),
        (_, Some(_)) => Err(bom_inside(line_no)),
        (_, None) => Ok(text),
    }
}

/// Why a CSV line that is not ours (fields separated by `;` or tabs, as a
/// European-locale spreadsheet or a tab-separated export writes them, its
/// decimal mark perhaps a comma) cannot be read, or `None` when it may be
/// ours. `want` says what a line holds (`5 fields t,x,y,z,present`).
pub fn foreign_csv(line: &str, want: &str) -> Option<String> {
    let sep = [(';', "`;`"), ('\t', "tabs")]
        .into_iter()
        .find(|(c, _)| line.contains(*c))?;
    let decimal = line
        .split(sep.0)
        .find(|f| {
            let f = f.trim();
            f.contains(',') && f.replacen(',', ".", 1).parse::<f64>().is_ok()
        })
        .map(|f| format!(" and decimal commas (`{}`)", f.trim().escape_debug()))
        .unwrap_or_default();
    Some(format!(
        "fields separated by {}{decimal}, not a CSV lmhost reads: give {want} separated by `,` with `.` \
         as the decimal mark (a European-locale spreadsheet writes `;`: export with `,` separators)",
        sep.1
    ))
}

/// How a text file is laid out on disk beyond its text: a byte-order
/// mark, its line ends. What [`decode`] reads away, so a file lmhost
/// rewrites (`calibrate --write`: every other line kept) is written back
/// as its editor saved it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Layout {
    /// It opens with a UTF-8 byte-order mark.
    pub bom: bool,
    /// Its line end: its first one (`\n`, `\r\n` or `\r`).
    pub line_end: &'static str,
}

impl Layout {
    /// The layout of `bytes` (a whole file).
    pub fn of(bytes: &[u8]) -> Self {
        let line_end = match bytes.iter().position(|&b| b == b'\n' || b == b'\r') {
            Some(i) if bytes[i] == b'\r' && bytes.get(i + 1) == Some(&b'\n') => "\r\n",
            Some(i) if bytes[i] == b'\r' => "\r",
            _ => "\n",
        };
        Self {
            bom: bytes.starts_with(b"\xef\xbb\xbf"),
            line_end,
        }
    }

    /// `text` (as [`decode`] gives it: LF line ends) laid out so.
    pub fn encode(&self, text: &str) -> Vec<u8> {
        let mut out = Vec::with_capacity(text.len() + 3);
        if self.bom {
            out.extend_from_slice("\u{feff}".as_bytes());
        }
        match self.line_end {
            "\n" | "" => out.extend_from_slice(text.as_bytes()),
            end => out.extend_from_slice(text.replace('\n', end).as_bytes()),
        }
        out
    }
}

/// What a value refused as a number in `field` looks like, when it looks
/// like one written another way: ` (a decimal comma? write `3.5`)`, a unit
/// after it (`3mm`), digits other than 0-9 (`١٢`, full-width `５`), a
/// hexadecimal literal (`0x10`), digit separators (`1_000`); else
/// nothing. One hint for every reader of numbers: a number flag, a number
/// in a flag's list, a CSV field, an answer.
pub fn number_hint(field: &str) -> String {
    let f = field.trim();
    let reads = |s: &str| s.parse::<f64>().is_ok();
    let hex = f.strip_prefix(['-', '+']).unwrap_or(f);
    if f.contains(',') && reads(&f.replacen(',', ".", 1)) {
        format!(" (a decimal comma? write `{}`)", f.replacen(',', ".", 1))
    } else if f.chars().any(|c| c.is_numeric() && !c.is_ascii_digit()) {
        " (digits other than 0-9: write it with 0-9)".into()
    } else if hex.len() > 2 && hex.get(..2).is_some_and(|p| p.eq_ignore_ascii_case("0x")) {
        " (a hexadecimal number? write it in decimal)".into()
    } else if f.contains('_') && reads(&f.replace('_', "")) {
        format!(" (digit separators? write `{}`)", f.replace('_', ""))
    } else if let Some(at) = f.find(|c: char| c.is_alphabetic() && c != 'e' && c != 'E')
        && at > 0
        && reads(f[..at].trim_end())
    {
        format!(
            " (a unit after it? give the number alone: `{}`)",
            f[..at].trim_end()
        )
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_number_hint_takes_any_text_whole_characters_first() {
        // Two-byte and three-byte characters where a `0x` would be: no
        // cut inside them, and no hint for what is no number at all.
        for s in [
            "\u{feff}1.6",
            "2\u{202e}evil_x\u{202c}5.",
            "é",
            "€0x",
            "-\u{feff}",
        ] {
            assert_eq!(number_hint(s), "", "{s:?}");
        }
        assert_eq!(
            number_hint("0X1f"),
            " (a hexadecimal number? write it in decimal)"
        );
        assert_eq!(number_hint("2,5"), " (a decimal comma? write `2.5`)");
    }

    #[test]
    fn one_reading_whatever_wrote_it() {
        let want = "a = 1\nb = 2\n";
        let crlf = want.replace('\n', "\r\n");
        for text in [
            want.to_owned(),
            format!("\u{feff}{want}"),
            crlf.clone(),
            format!("\u{feff}{crlf}"),
            want.replace('\n', "\r"),
        ] {
            assert_eq!(decode(text.clone().into_bytes()).unwrap(), want, "{text:?}");
        }
        // No final newline, blank lines after: as they were.
        assert_eq!(decode(b"a\r\n\r\n\r\n".to_vec()).unwrap(), "a\n\n\n");
        assert_eq!(decode(b"a".to_vec()).unwrap(), "a");
    }

    #[test]
    fn a_layout_read_away_is_written_back() {
        // Each mark and line end, with a final line end and without.
        for bom in ["", "\u{feff}"] {
            for end in ["\n", "\r\n", "\r"] {
                for last in [end, ""] {
                    let bytes = format!("{bom}a = 1{end}b = 2{last}").into_bytes();
                    let text = decode(bytes.clone()).unwrap();
                    assert_eq!(Layout::of(&bytes).encode(&text), bytes, "{bytes:?}");
                }
            }
        }
    }

    #[test]
    fn wide_text_is_named() {
        let s = "{\"a\": 1}\n";
        let utf16le: Vec<u8> = s.encode_utf16().flat_map(u16::to_le_bytes).collect();
        let utf16be: Vec<u8> = s.encode_utf16().flat_map(u16::to_be_bytes).collect();
        let utf32le: Vec<u8> = s.chars().flat_map(|c| (c as u32).to_le_bytes()).collect();
        let utf32be: Vec<u8> = s.chars().flat_map(|c| (c as u32).to_be_bytes()).collect();
        let bom = |b: &[u8], v: &[u8]| [b, v].concat();
        for (bytes, enc) in [
            (bom(b"\xff\xfe", &utf16le), "UTF-16 (little-endian)"),
            (bom(b"\xfe\xff", &utf16be), "UTF-16 (big-endian)"),
            (utf16le.clone(), "UTF-16 (little-endian)"),
            (utf16be.clone(), "UTF-16 (big-endian)"),
            (bom(b"\xff\xfe\0\0", &utf32le), "UTF-32 (little-endian)"),
            (utf32le.clone(), "UTF-32 (little-endian)"),
            (utf32be.clone(), "UTF-32 (big-endian)"),
        ] {
            assert_eq!(
                decode(bytes.clone()).unwrap_err(),
                format!("it is {enc} text, not UTF-8: save it as UTF-8")
            );
            assert!(stream_line(&bytes, 1).unwrap_err().contains(enc));
        }
    }

    #[test]
    fn lines_are_counted_as_an_editor_shows_them() {
        // Not UTF-8 on line 3, however the lines end.
        for bytes in [
            &b"a\nb\n\xff\n"[..],
            b"a\r\nb\r\n\xff",
            b"a\rb\r\xff",
            b"\ra\r\xff",
        ] {
            assert_eq!(
                decode(bytes.to_vec()).unwrap_err(),
                "it is not UTF-8 text (line 3); save it as UTF-8"
            );
        }
        assert_eq!(
            decode(b"\xef\xbb\xbfa\r\nb\0".to_vec()).unwrap_err(),
            "line 2 holds a NUL byte, which no text file has"
        );
        // A second file joined on.
        assert!(
            decode(b"\xef\xbb\xbfa\n\xef\xbb\xbfb\n".to_vec())
                .unwrap_err()
                .starts_with("line 2 starts with a byte-order mark")
        );
    }

    #[test]
    fn stream_lines() {
        assert_eq!(stream_line(b"\xef\xbb\xbfa,b", 1).unwrap(), "a,b");
        assert_eq!(stream_line(b"a,b", 2).unwrap(), "a,b");
        for (bytes, n, says) in [
            (
                &b"\xef\xbb\xbfa"[..],
                2,
                "line 2 starts with a byte-order mark",
            ),
            (b"a\0b", 3, "line 3 holds a NUL byte"),
            (b"a\xff", 4, "line 4 is not UTF-8 text"),
        ] {
            let e = stream_line(bytes, n).unwrap_err();
            assert!(e.starts_with(says), "{e}");
        }
        // Only the first line is looked at for UTF-16 (a later line of
        // NULs is a NUL byte).
        assert!(stream_line(b"a\0b\0", 2).unwrap_err().contains("NUL"));
    }

    #[test]
    fn foreign_csv_is_named() {
        let e = foreign_csv("0;3,5;0;200;1", "5 fields").unwrap();
        assert!(
            e.starts_with("fields separated by `;` and decimal commas (`3,5`)"),
            "{e}"
        );
        let e = foreign_csv("0\t3.5\t0\t200\t1", "5 fields").unwrap();
        assert!(e.starts_with("fields separated by tabs, not"), "{e}");
        assert_eq!(foreign_csv("0,3.5,0,200,1", "5 fields"), None);
        assert_eq!(number_hint("3,5"), " (a decimal comma? write `3.5`)");
        assert_eq!(number_hint("3,5,1"), "");
        assert_eq!(number_hint("abc"), "");
        assert_eq!(number_hint("1e"), "");
        for (v, want) in [
            ("١٢", " (digits other than 0-9: write it with 0-9)"),
            ("５", " (digits other than 0-9: write it with 0-9)"),
            ("0x10", " (a hexadecimal number? write it in decimal)"),
            ("-0X1f", " (a hexadecimal number? write it in decimal)"),
            ("1_000", " (digit separators? write `1000`)"),
            ("3mm", " (a unit after it? give the number alone: `3`)"),
            ("2.5 Hz", " (a unit after it? give the number alone: `2.5`)"),
        ] {
            assert_eq!(number_hint(v), want, "{v}");
        }
    }
}
