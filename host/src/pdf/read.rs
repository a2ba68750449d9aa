//! Reading back the PDFs [`super`] writes, for the tests of the figures
//! that use it: objects, streams (inflated) and the text shown, as
//! Unicode through the font's ToUnicode map.

use std::io::Read as _;

/// Object `n`'s bytes, between `n 0 obj` and `endobj`.
pub(crate) fn object(pdf: &[u8], n: usize) -> &[u8] {
    let head = format!("\n{n} 0 obj\n");
    let at = pdf
        .windows(head.len())
        .position(|w| w == head.as_bytes())
        .unwrap_or_else(|| panic!("object {n}"))
        + head.len();
    let end = pdf[at..].windows(6).position(|w| w == b"endobj").unwrap();
    &pdf[at..at + end]
}

/// Every stream of `pdf`, inflated where it is Flate.
pub(crate) fn streams(pdf: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut from = 0;
    // `stream` after a dictionary, not the `endstream` before the next.
    while let Some(at) = pdf[from..]
        .windows(8)
        .position(|w| w == b">>stream" || w == b"\nstream\n")
    {
        let start = from + at + 8 + usize::from(pdf[from + at] == b'>');
        let head = String::from_utf8_lossy(&pdf[from..from + at]);
        let len: usize = head
            .rsplit("/Length ")
            .next()
            .unwrap()
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let raw = &pdf[start..start + len];
        let mut data = Vec::new();
        if flate2::read::ZlibDecoder::new(raw)
            .read_to_end(&mut data)
            .is_err()
        {
            data = raw.to_vec();
        }
        out.push(data);
        from = start + len;
    }
    out
}

/// The PDF literal string opening at `s[0]` (`(`): its bytes, and the
/// index after its closing `)`. Parentheses nest; `\` escapes.
fn literal(s: &[u8]) -> (Vec<u8>, usize) {
    let mut out = Vec::new();
    let (mut i, mut depth) = (1, 1);
    while i < s.len() {
        match s[i] {
            b'\\' => {
                i += 1;
                let digits = s[i..]
                    .iter()
                    .take(3)
                    .take_while(|c| (b'0'..=b'7').contains(c))
                    .count();
                if digits > 0 {
                    let oct = std::str::from_utf8(&s[i..i + digits]).unwrap();
                    out.push(u8::from_str_radix(oct, 8).unwrap());
                    i += digits;
                    continue;
                }
                out.push(match s[i] {
                    b'n' => b'\n',
                    b'r' => b'\r',
                    b't' => b'\t',
                    b'b' => 8,
                    b'f' => 12,
                    c => c,
                });
            }
            b'(' => {
                depth += 1;
                out.push(b'(');
            }
            b')' => {
                depth -= 1;
                if depth == 0 {
                    return (out, i + 1);
                }
                out.push(b')');
            }
            c => out.push(c),
        }
        i += 1;
    }
    panic!("an unterminated string");
}

/// Each text the PDF shows, as Unicode through its ToUnicode map, in
/// drawing order.
pub(crate) fn texts(pdf: &[u8]) -> Vec<String> {
    let all = streams(pdf);
    let cmap = all
        .iter()
        .map(|s| String::from_utf8_lossy(s).into_owned())
        .find(|s| s.contains("beginbfchar"))
        .expect("a ToUnicode map");
    let mut map = std::collections::HashMap::new();
    for line in cmap.lines() {
        let hex: Vec<&str> = line
            .split(['<', '>'])
            .filter(|t| !t.trim().is_empty())
            .collect();
        if let [g, u] = hex[..]
            && let (Ok(g), Ok(u)) = (u16::from_str_radix(g, 16), u32::from_str_radix(u, 16))
        {
            map.insert(g, char::from_u32(u).unwrap());
        }
    }
    let content = all
        .iter()
        .find(|s| s.windows(3).any(|w| w == b"BT\n") && s.windows(3).any(|w| w == b"Tj\n"))
        .expect("a content stream");
    let mut texts = Vec::new();
    let mut i = 0;
    while i < content.len() {
        if content[i] != b'(' {
            i += 1;
            continue;
        }
        let (bytes, end) = literal(&content[i..]);
        i += end;
        if content[i..].trim_ascii_start().starts_with(b"Tj") {
            texts.push(
                bytes
                    .chunks(2)
                    .map(|g| map[&u16::from_be_bytes([g[0], g[1]])])
                    .collect(),
            );
        }
    }
    texts
}
