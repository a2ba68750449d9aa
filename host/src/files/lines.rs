//! The one way lmhost splits a byte stream into lines (stdin, a pipe, a
//! socket, a file read as it comes): LF, CRLF and a lone CR each end a
//! line (a classic Mac file, Excel for Mac's CSV, a terminal in raw mode,
//! a serial tool sending CR), and a line longer than the reader's limit
//! is refused as soon as it is, without reading the rest of it into
//! memory. What a line says is [`super::text::stream_line`]'s to check.
//!
//! A line is handed over as soon as its end arrives: a CR ends it at once
//! (no wait for a LF that may never come), and a LF right after that CR,
//! read later, is taken as part of the same line end.

use std::io::BufRead;

/// What [`LineReader::next_line`] read.
#[derive(Debug, PartialEq, Eq)]
pub enum Line<'a> {
    /// A whole line (the last one may end with the input instead), without
    /// its line end.
    Text(&'a [u8]),
    /// A line longer than the limit: refused before its end. Its rest is
    /// still in the input; [`LineReader::skip_rest`] reads past it.
    TooLong,
}

/// Lines of `R`, each at most `max` bytes (its line end not counted).
#[derive(Debug)]
pub struct LineReader<R> {
    reader: R,
    max: usize,
    buf: Vec<u8>,
    /// The last line ended at a CR: a LF first in the input is its end too.
    after_cr: bool,
    line_no: usize,
}

impl<R: BufRead> LineReader<R> {
    /// Reads lines of at most `max` bytes from `reader`.
    pub fn new(reader: R, max: usize) -> Self {
        Self {
            reader,
            max,
            buf: Vec::new(),
            after_cr: false,
            line_no: 0,
        }
    }

    /// The 1-based number of the line [`Self::next_line`] last read.
    pub fn line_no(&self) -> usize {
        self.line_no
    }

    /// The next line, `None` at the end of the input. A read interrupted
    /// by a signal is retried; any other read error is returned.
    pub fn next_line(&mut self) -> std::io::Result<Option<Line<'_>>> {
        self.buf.clear();
        let mut started = false;
        loop {
            if !more(&mut self.reader)? {
                if !started {
                    return Ok(None);
                }
                self.line_no += 1;
                return Ok(Some(Line::Text(&self.buf)));
            }
            let avail = self.reader.fill_buf()?;
            if std::mem::take(&mut self.after_cr) && avail[0] == b'\n' {
                self.reader.consume(1);
                continue;
            }
            started = true;
            let (take, end) = match avail.iter().position(|&b| b == b'\n' || b == b'\r') {
                Some(i) => {
                    self.after_cr = avail[i] == b'\r';
                    (i, true)
                }
                None => (avail.len(), false),
            };
            if self.buf.len() + take > self.max {
                self.after_cr = false;
                self.line_no += 1;
                return Ok(Some(Line::TooLong));
            }
            self.buf.extend_from_slice(&avail[..take]);
            self.reader.consume(take + usize::from(end));
            if end {
                self.line_no += 1;
                return Ok(Some(Line::Text(&self.buf)));
            }
        }
    }

    /// After [`Line::TooLong`]: reads past the rest of that line, to its
    /// end (or the input's), holding none of it.
    pub fn skip_rest(&mut self) -> std::io::Result<()> {
        loop {
            if !more(&mut self.reader)? {
                return Ok(());
            }
            let avail = self.reader.fill_buf()?;
            match avail.iter().position(|&b| b == b'\n' || b == b'\r') {
                Some(i) => {
                    self.after_cr = avail[i] == b'\r';
                    self.reader.consume(i + 1);
                    return Ok(());
                }
                None => {
                    let n = avail.len();
                    self.reader.consume(n);
                }
            }
        }
    }
}

/// Whether `reader` has bytes to read (false at the end of the input),
/// reading again where a signal interrupted the read; any other error is
/// returned. Then `fill_buf` hands them over without reading: it reads
/// only into an empty buffer.
fn more<R: BufRead>(reader: &mut R) -> std::io::Result<bool> {
    loop {
        match reader.fill_buf() {
            Ok(b) => return Ok(!b.is_empty()),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reader that hands out one byte per read, as a slow pipe may.
    struct Trickle<'a>(&'a [u8]);

    impl std::io::Read for Trickle<'_> {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            match (self.0.split_first(), out.first_mut()) {
                (Some((b, rest)), Some(o)) => {
                    *o = *b;
                    self.0 = rest;
                    Ok(1)
                }
                _ => Ok(0),
            }
        }
    }

    /// Every line of `r` as text, `!` for a refused one (its rest skipped).
    fn all<R: BufRead>(r: R, max: usize) -> Vec<String> {
        let mut lines = LineReader::new(r, max);
        let mut out = Vec::new();
        while let Some(l) = lines.next_line().unwrap() {
            match l {
                Line::Text(t) => out.push(String::from_utf8(t.to_vec()).unwrap()),
                Line::TooLong => {
                    out.push("!".into());
                    lines.skip_rest().unwrap();
                }
            }
        }
        out
    }

    #[test]
    fn lf_crlf_and_a_lone_cr_each_end_a_line() {
        for (name, input, want) in [
            ("LF", &b"a\nb\n"[..], &["a", "b"][..]),
            ("CRLF", b"a\r\nb\r\n", &["a", "b"]),
            ("lone CR", b"a\rb\r", &["a", "b"]),
            ("mixed", b"a\rb\r\nc\nd", &["a", "b", "c", "d"]),
            ("blank lines kept", b"a\r\r\n\nb", &["a", "", "", "b"]),
            ("CR then CRLF", b"a\r\r\nb", &["a", "", "b"]),
            ("no line end at the end", b"a", &["a"]),
            ("nothing", b"", &[]),
        ] {
            let want: Vec<String> = want.iter().map(|s| s.to_string()).collect();
            assert_eq!(all(input, 16), want, "{name}");
            // Byte by byte, a CR's LF coming in a later read: the same.
            let slow = std::io::BufReader::with_capacity(1, Trickle(input));
            assert_eq!(all(slow, 16), want, "{name}, one byte per read");
        }
    }

    #[test]
    fn a_line_over_the_limit_is_refused_and_the_next_one_read() {
        assert_eq!(all(&b"abcd\nabcde\nx\n"[..], 4), ["abcd", "!", "x"]);
        assert_eq!(all(&b"abcde\rx\r\ny"[..], 4), ["!", "x", "y"]);
        let slow = std::io::BufReader::with_capacity(1, Trickle(b"abcdefgh\r\nx"));
        assert_eq!(all(slow, 4), ["!", "x"]);
        // Line numbers count every line, refused ones too.
        let mut lines = LineReader::new(&b"a\rtoo long\nb\n"[..], 4);
        assert_eq!(lines.next_line().unwrap(), Some(Line::Text(b"a")));
        assert_eq!(lines.next_line().unwrap(), Some(Line::TooLong));
        assert_eq!(lines.line_no(), 2);
        lines.skip_rest().unwrap();
        assert_eq!(lines.next_line().unwrap(), Some(Line::Text(b"b")));
        assert_eq!(lines.line_no(), 3);
        assert_eq!(lines.next_line().unwrap(), None);
    }

    #[test]
    fn an_endless_line_is_refused_holding_at_most_the_limit() {
        let endless = std::io::Read::take(std::io::repeat(b'x'), 1 << 30);
        let mut lines = LineReader::new(std::io::BufReader::new(endless), 4096);
        assert_eq!(lines.next_line().unwrap(), Some(Line::TooLong));
        assert!(
            lines.buf.capacity() <= 2 * 4096 + 8192,
            "{}",
            lines.buf.capacity()
        );
    }
}
