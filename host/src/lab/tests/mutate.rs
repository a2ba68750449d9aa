//! The mutations the readers' fuzz run makes of its seeds: byte flips,
//! spans inserted, deleted and duplicated, two seeds spliced, numbers
//! and strings replaced by edge values, lines duplicated and swapped
//! (keys given twice), keys renamed, nesting deepened, little-endian
//! fields overwritten (binary formats), truncation. Every mutant is at
//! most [`MAX_MUTANT`] bytes: inputs are bounded by construction.

use crate::rng::SplitMix64;

/// The longest mutant (bytes).
pub const MAX_MUTANT: usize = 256 << 10;

/// Numbers a number in a seed is replaced by: zeros, extremes,
/// underflows, non-numbers, integers past 2^53, 2^63 and 2^64, other
/// radixes and spellings.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "-0.0",
    "1",
    "-1",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e309",
    "1e-320",
    "1e-400",
    "5e-324",
    "NaN",
    "nan",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    "9007199254740993",
    "18446744073709551616",
    "-9223372036854775809",
    "9223372036854775807",
    "4294967296",
    "2147483648",
    "65536",
    "65535",
    "256",
    "255",
    "8193",
    "0x10",
    "0o7",
    "0b1",
    "1_000",
    "+1",
    "00",
    ".5",
    "5.",
    "1e",
    "1.5",
    "3,5",
    "1e5",
    "99999999999999999999999999999999999999999999999999999999999999999",
];

/// Strings a string in a seed is replaced by: empty, long, control and
/// escape sequences (JSON and TOML escapes of a line feed, a NUL, a lone
/// surrogate), bidirectional overrides, zero-width marks, byte-order marks.
fn strings(rng: &mut SplitMix64) -> Vec<u8> {
    let long = |n: usize, c: &str| c.repeat(n).into_bytes();
    match rng.below(22) {
        0 => Vec::new(),
        1 => long(70, "a"),
        2 => long(600, "x"),
        3 => long(5000, "y"),
        4 => long(300, "a b "),
        5 => b"\x01\x02\x1b[31m".to_vec(),
        6 => b"\\n".to_vec(),
        7 => b"a\\nb\\r\\nc".to_vec(),
        8 => b"\\u0000".to_vec(),
        9 => b"\\ud800".to_vec(),
        10 => "\u{202e}evil\u{202c}".as_bytes().to_vec(),
        11 => "\u{200b}".as_bytes().to_vec(),
        12 => "\u{feff}".as_bytes().to_vec(),
        13 => b"\xff\xfe".to_vec(),
        14 => b"\xc3".to_vec(),
        15 => b"\t".to_vec(),
        16 => b"\\".to_vec(),
        17 => b"\\u00e9\\u2028".to_vec(),
        18 => "é漢字🙂".repeat(40).into_bytes(),
        19 => b"../../etc/passwd".to_vec(),
        20 => b"{level}{x}{".to_vec(),
        _ => long(200, "\\n"),
    }
}

/// Short spans inserted anywhere: the syntax of the formats read.
const TOKENS: &[&str] = &[
    "[", "]", "{", "}", "[[", "]]", "\"", "'", "=", ",", ":", "\n", "\r", "\r\n", "#", ".", "-",
    "\\", " ", "\t", "\0", "\u{feff}", "\"\"\"", "'''", "true", "false", "null", "=\n",
];

/// A mutant of one of `seeds`: one to four mutations of it.
pub fn mutant(rng: &mut SplitMix64, seeds: &[Vec<u8>]) -> Vec<u8> {
    let mut b = seeds[rng.below(seeds.len() as u64) as usize].clone();
    let n = 1 + rng.below(4) as usize;
    for _ in 0..n {
        mutate(rng, &mut b, seeds);
        if b.len() > MAX_MUTANT {
            b.truncate(MAX_MUTANT);
        }
    }
    b
}

fn at(rng: &mut SplitMix64, len: usize) -> usize {
    rng.below(len as u64 + 1) as usize
}

/// A span `[i, j)` of `b`, mostly short.
fn span(rng: &mut SplitMix64, len: usize) -> (usize, usize) {
    let i = at(rng, len);
    let max = match rng.below(4) {
        0 => len - i,
        _ => (len - i).min(16),
    };
    (i, i + at(rng, max))
}

fn mutate(rng: &mut SplitMix64, b: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    match rng.below(16) {
        0 if !b.is_empty() => {
            let i = rng.below(b.len() as u64) as usize;
            match rng.below(3) {
                0 => b[i] ^= 1 << rng.below(8),
                1 => b[i] = rng.below(256) as u8,
                _ => {
                    const SYNTAX: &[u8] = b" \n\"'=[]{},:.-0a\\\x7f\xff";
                    b[i] = SYNTAX[rng.below(SYNTAX.len() as u64) as usize];
                }
            }
        }
        1 => {
            let i = at(rng, b.len());
            let t: Vec<u8> = match rng.below(3) {
                0 => (0..1 + rng.below(8))
                    .map(|_| rng.below(256) as u8)
                    .collect(),
                _ => TOKENS[rng.below(TOKENS.len() as u64) as usize]
                    .as_bytes()
                    .to_vec(),
            };
            b.splice(i..i, t);
        }
        2 => {
            let (i, j) = span(rng, b.len());
            b.drain(i..j);
        }
        3 => {
            let (i, j) = span(rng, b.len());
            let dup = b[i..j].to_vec();
            let k = at(rng, b.len());
            b.splice(k..k, dup);
        }
        4 => {
            let other = &seeds[rng.below(seeds.len() as u64) as usize];
            let (i, j) = (at(rng, b.len()), at(rng, other.len()));
            b.truncate(i);
            b.extend_from_slice(&other[j..]);
        }
        5 | 6 => replace_token(rng, b, Token::Number),
        7 => replace_token(rng, b, Token::String),
        8 => {
            let i = at(rng, b.len());
            b.truncate(i);
        }
        9 => line_op(rng, b),
        10 => rename_key(rng, b),
        11 => deepen(rng, b),
        12 => overwrite_field(rng, b),
        13 => {
            // A numeric field's bytes: a NaN or an extreme (binary).
            overwrite_field(rng, b);
            replace_token(rng, b, Token::Number);
        }
        14 => {
            // Line ends as other platforms write them.
            let to: &[u8] = [b"\r\n".as_slice(), b"\r", b"\n\n"][rng.below(3) as usize];
            let mut out = Vec::with_capacity(b.len() + 64);
            for &c in b.iter() {
                if c == b'\n' && rng.below(3) == 0 {
                    out.extend_from_slice(to);
                } else {
                    out.push(c);
                }
            }
            *b = out;
        }
        _ => {
            let (i, j) = span(rng, b.len());
            b.splice(i..j, strings(rng));
        }
    }
}

#[derive(Clone, Copy)]
enum Token {
    Number,
    String,
}

/// The spans of numbers or quoted strings in `b` (the contents between
/// the quotes).
fn tokens(b: &[u8], kind: Token) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        match kind {
            Token::Number => {
                let starts = b[i].is_ascii_digit()
                    || (b[i] == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit));
                let after_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
                if starts && !after_word {
                    let j = i
                        + 1
                        + b[i + 1..]
                            .iter()
                            .take_while(|c| c.is_ascii_digit() || b".eE+-_".contains(c))
                            .count();
                    out.push((i, j));
                    i = j;
                    continue;
                }
            }
            Token::String => {
                if b[i] == b'"' || b[i] == b'\'' {
                    let q = b[i];
                    if let Some(n) = b[i + 1..].iter().position(|&c| c == q || c == b'\n') {
                        out.push((i + 1, i + 1 + n));
                        i += n + 2;
                        continue;
                    }
                }
            }
        }
        i += 1;
    }
    out
}

fn replace_token(rng: &mut SplitMix64, b: &mut Vec<u8>, kind: Token) {
    let found = tokens(b, kind);
    if found.is_empty() {
        return;
    }
    let (i, j) = found[rng.below(found.len() as u64) as usize];
    let with = match kind {
        Token::Number => NUMBERS[rng.below(NUMBERS.len() as u64) as usize]
            .as_bytes()
            .to_vec(),
        Token::String => strings(rng),
    };
    b.splice(i..j, with);
}

/// Line starts of `b` (and its end).
fn lines(b: &[u8]) -> Vec<usize> {
    let mut v = vec![0];
    v.extend(
        b.iter()
            .enumerate()
            .filter(|(_, c)| **c == b'\n')
            .map(|(i, _)| i + 1),
    );
    if *v.last().unwrap() != b.len() {
        v.push(b.len());
    }
    v
}

/// A line duplicated (a key or table given twice), dropped, or two
/// lines swapped.
fn line_op(rng: &mut SplitMix64, b: &mut Vec<u8>) {
    let l = lines(b);
    if l.len() < 2 {
        return;
    }
    let k = rng.below(l.len() as u64 - 1) as usize;
    let line = b[l[k]..l[k + 1]].to_vec();
    match rng.below(3) {
        0 => {
            let to = l[rng.below(l.len() as u64) as usize];
            let mut line = line;
            if line.last() != Some(&b'\n') {
                line.insert(0, b'\n');
            }
            b.splice(to..to, line);
        }
        1 => {
            b.drain(l[k]..l[k + 1]);
        }
        _ => {
            let m = rng.below(l.len() as u64 - 1) as usize;
            if m != k && line.ends_with(b"\n") && b[l[m]..l[m + 1]].ends_with(b"\n") {
                let (lo, hi) = (k.min(m), k.max(m));
                let a = b[l[lo]..l[lo + 1]].to_vec();
                let c = b[l[hi]..l[hi + 1]].to_vec();
                b.splice(l[hi]..l[hi + 1], a);
                b.splice(l[lo]..l[lo + 1], c);
            }
        }
    }
}

/// A word (a key, a type name, a table name) renamed: a letter changed,
/// a suffix added, upper case, or another word of the input.
fn rename_key(rng: &mut SplitMix64, b: &mut Vec<u8>) {
    let mut words = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphabetic() || b[i] == b'_' {
            let j = i + b[i..]
                .iter()
                .take_while(|c| c.is_ascii_alphanumeric() || **c == b'_')
                .count();
            words.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    if words.is_empty() {
        return;
    }
    let (i, j) = words[rng.below(words.len() as u64) as usize];
    let new: Vec<u8> = match rng.below(4) {
        0 => {
            let mut w = b[i..j].to_vec();
            let k = rng.below(w.len() as u64) as usize;
            w[k] = b'a' + rng.below(26) as u8;
            w
        }
        1 => [&b[i..j], b"_x".as_slice()].concat(),
        2 => b[i..j].to_ascii_uppercase(),
        _ => {
            let (p, q) = words[rng.below(words.len() as u64) as usize];
            b[p..q].to_vec()
        }
    };
    b.splice(i..j, new);
}

/// Nesting deepened: brackets or braces opened (and perhaps closed)
/// around a point, from a few to many levels.
fn deepen(rng: &mut SplitMix64, b: &mut Vec<u8>) {
    let depth = [2usize, 10, 100, 129, 1000, 20_000][rng.below(6) as usize];
    let (open, close): (&[u8], &[u8]) = match rng.below(3) {
        0 => (b"[", b"]"),
        1 => (b"{\"a\":", b"}"),
        _ => (b"{a=", b"}"),
    };
    let i = at(rng, b.len());
    let j = i + at(rng, (b.len() - i).min(32));
    if rng.below(2) == 0 {
        b.splice(j..j, close.repeat(depth));
    }
    b.splice(i..i, open.repeat(depth));
}

/// A little-endian field overwritten with an edge value: the binary
/// formats' sizes, shapes and floats.
fn overwrite_field(rng: &mut SplitMix64, b: &mut [u8]) {
    let v: Vec<u8> = match rng.below(10) {
        0 => 0u32.to_le_bytes().to_vec(),
        1 => u32::MAX.to_le_bytes().to_vec(),
        2 => (1u32 << 31).to_le_bytes().to_vec(),
        3 => u16::MAX.to_le_bytes().to_vec(),
        4 => 8193u32.to_le_bytes().to_vec(),
        5 => f64::NAN.to_le_bytes().to_vec(),
        6 => f64::INFINITY.to_le_bytes().to_vec(),
        7 => f64::MAX.to_le_bytes().to_vec(),
        8 => (-0.0f64).to_le_bytes().to_vec(),
        _ => 5e-324f64.to_le_bytes().to_vec(),
    };
    if b.len() < v.len() {
        return;
    }
    // Mostly near the start, where the headers are.
    let end = match rng.below(2) {
        0 => b.len().min(256),
        _ => b.len(),
    } - v.len();
    let i = at(rng, end);
    b[i..i + v.len()].copy_from_slice(&v);
}

/// Where a truncation sweep cuts `b`: every byte of a short seed, else
/// every line start and every change of character class (a token's edge).
pub fn boundaries(b: &[u8]) -> Vec<usize> {
    if b.len() <= 1024 {
        return (0..b.len()).collect();
    }
    let class = |c: u8| match c {
        b'0'..=b'9' | b'.' | b'-' | b'+' => 0,
        b'a'..=b'z' | b'A'..=b'Z' | b'_' => 1,
        b' ' | b'\t' => 2,
        b'\n' | b'\r' => 3,
        _ => 4 + u32::from(c),
    };
    (0..b.len())
        .filter(|&i| i == 0 || class(b[i]) != class(b[i - 1]))
        .collect()
}
