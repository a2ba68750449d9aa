//! Answers on stdin (a pipe, no `--responses`, or `--responses -`), read
//! as they arrive on a thread of their own.

use std::sync::mpsc::{Receiver, Sender, channel};

/// Reads stdin lines lazily (a pipe that is not a terminal, no
/// `--responses`): answers as they arrive, each line sent on once it has ended.
pub fn stdin_lines() -> anyhow::Result<Receiver<Result<String, String>>> {
    let (tx, rx) = channel();
    std::thread::Builder::new()
        .name("lmhost-answers".into())
        .spawn(move || send_lines(std::io::stdin().lock(), &tx))?;
    Ok(rx)
}

/// Sends `r`'s lines to `tx` as they arrive, split by
/// [`crate::files::lines::LineReader`] (LF, CRLF or a lone CR ends one: a
/// button box or a terminal program may send CR alone) and read as every
/// text line is (the first line's byte-order mark skipped, UTF-16 named;
/// said after "stdin line N:"). A line longer than
/// [`crate::limits::MAX_LINE_BYTES`], or one that is no text, is sent as
/// the refusal and ends the stream, read no further.
fn send_lines(r: impl std::io::BufRead, tx: &Sender<Result<String, String>>) {
    use crate::files::lines::{Line, LineReader};
    let max = crate::limits::MAX_LINE_BYTES;
    let mut lines = LineReader::new(r, max);
    loop {
        let n = lines.line_no() + 1;
        let item = match lines.next_line() {
            Ok(None) | Err(_) => break,
            Ok(Some(Line::TooLong)) => Err(format!("a line longer than {max} bytes")),
            Ok(Some(Line::Text(bytes))) => crate::files::text::stream_line(bytes, n)
                .map(str::to_owned)
                .map_err(|e| {
                    let head = format!("line {n} ");
                    e.strip_prefix(&head)
                        .map_or(e.clone(), |r| format!("the line {r}"))
                }),
        };
        let stop = item.is_err();
        if tx.send(item).is_err() || stop {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What [`send_lines`] sends for `input`.
    fn sent(input: &[u8]) -> Vec<Result<String, String>> {
        let (tx, rx) = channel();
        send_lines(input, &tx);
        drop(tx);
        rx.iter().collect()
    }

    #[test]
    fn stdin_answers_end_at_lf_crlf_or_a_lone_cr() {
        let ok = |v: &[&str]| -> Vec<Result<String, String>> {
            v.iter().map(|s| Ok(s.to_string())).collect()
        };
        assert_eq!(sent(b"7\r6\r\n5\nna"), ok(&["7", "6", "5", "na"]));
        assert_eq!(sent(b"\xef\xbb\xbf1\r\r2\r"), ok(&["1", "", "2"]));
        // An over-long line, whatever ends it, is refused at its limit and
        // ends the stream.
        let max = crate::limits::MAX_LINE_BYTES;
        let mut input = b"1\r".to_vec();
        input.extend(vec![b'x'; max + 1]);
        input.extend(b"\r2\r");
        assert_eq!(
            sent(&input),
            [
                Ok("1".into()),
                Err(format!("a line longer than {max} bytes"))
            ]
        );
        let mut input = vec![b'x'; max];
        input.extend(b"\r2");
        assert_eq!(sent(&input), ok(&[&"x".repeat(max), "2"]));
        // Not text: said, and the end.
        assert_eq!(
            sent(b"1\ra\0b\r2\r"),
            [
                Ok("1".into()),
                Err("the line holds a NUL byte, which no text line has".into())
            ]
        );
    }
}
