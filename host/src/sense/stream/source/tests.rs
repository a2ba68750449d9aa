//! Tests of the centroid sources.

use super::*;

/// `line`, as line 1 of a stream, parsed to a sample.
fn parsed(line: &str) -> Sample {
    parse_line(line, 1).unwrap().unwrap()
}

/// The sample stamped `t_s` at `pos_mm`, with a finger `present` or not.
fn sample(t_s: f64, pos_mm: [f64; 3], present: bool) -> Sample {
    Sample {
        t_s,
        pos_mm,
        present,
    }
}

#[test]
fn a_paced_recording_takes_as_long_as_its_time_stamps_say() {
    let clock = crate::clock::Clock::manual_at_us(5_000_000);
    // 20 s of samples at 2 Hz, starting at t = 100 s.
    let text: String = (0..=40)
        .map(|i| format!("{},0,0,200,1\n", 100.0 + i as f64 * 0.5))
        .collect();
    let mut seen = Vec::new();
    for s in paced(replay_lines(text.as_bytes()), clock.clone()) {
        let s = s.unwrap();
        seen.push((s.t_s, clock.now_us()));
    }
    assert_eq!(seen.len(), 41);
    // Each sample out when its stamp is due, not before.
    for (t_s, at_us) in &seen {
        let due = 5_000_000 + ((t_s - 100.0) * 1e6) as u64;
        assert_eq!(*at_us, due, "{t_s}");
    }
    assert_eq!(clock.now_us(), 25_000_000);
    // An error passes through and waits for nothing.
    let bad = "0,0,0,200,1\nx\n";
    let v: Vec<_> = paced(replay_lines(bad.as_bytes()), clock.clone()).collect();
    assert!(v[1].is_err());
}

#[test]
fn a_wild_stamp_in_a_paced_recording_is_passed_on_not_slept_for() {
    let clock = crate::clock::Clock::manual();
    // 2 s at 10 Hz with one stamp 50 s ahead (within the replay's gap
    // bound) in the middle.
    let text: String = (0..=20)
        .map(|i| if i == 10 { 51.0 } else { i as f64 * 0.1 })
        .map(|t| format!("{t},0,0,200,1\n"))
        .collect();
    let seen: Vec<(f64, u64)> = paced(replay_lines(text.as_bytes()), clock.clone())
        .map(|s| (s.unwrap().t_s, clock.now_us()))
        .collect();
    assert_eq!(seen.len(), 21, "{seen:?}");
    // Passed on when the one before it was due; the rest on time after it.
    assert_eq!(seen[10], (51.0, 900_000));
    assert_eq!(seen[11], (1.1, 1_100_000));
    // It took as long as the recording, not 51 s.
    assert_eq!(clock.now_us(), 2_000_000);
}

#[test]
fn a_time_stamp_outside_0_to_1e10_s_is_refused_in_every_form() {
    for t in ["1e300", "-1", "-1e-9", "10000000001"] {
        for line in [
            format!("{t},0,0,200,1"),
            format!(r#"{{"t":{t},"x":0,"y":0,"z":200}}"#),
            format!(r#"{{"t_s":{t},"present":false,"centroid_mm":null}}"#),
        ] {
            let e = parse_line(&line, 3).unwrap_err().to_string();
            assert!(e.starts_with("line 3: time stamp"), "{line}: {e}");
            assert!(e.contains("give 0 to 1e10 s") && e.len() < 100, "{e}");
        }
    }
    // Unix-epoch seconds, as a tracker's `time.time()` gives them.
    assert!(parse_line("1800000000.5,0,0,200,1", 1).unwrap().is_some());
    assert!(parse_line("0,0,0,200,1", 1).unwrap().is_some());
}

#[test]
fn a_number_that_underflows_is_refused_in_every_form() {
    for line in [
        "1e-400,0,0,200,1",
        "0,0,5e-320,200,1",
        r#"{"t":1e-400,"x":0,"y":0,"z":200}"#,
        r#"{"t_s":0,"present":true,"centroid_mm":[1e-400,0,200]}"#,
    ] {
        let e = parse_line(line, 3).unwrap_err().to_string();
        assert!(
            e.starts_with("line 3: ") && e.contains("too small to represent"),
            "{line}: {e}"
        );
    }
    assert!(parse_line("0.0e-400,0,0,200,1", 1).unwrap().is_some());
}

#[test]
fn a_line_is_refused_for_what_it_is() {
    // Only the exact header is skipped.
    assert!(parse_line("T, X,y,z,Present", 4).unwrap().is_none());
    for (line, needle) in [
        ("t,whatever", "line 2: expected 5 CSV fields"),
        ("t,0,0,200,1", "line 2: `t`: t is not a number"),
        (
            "\u{feff}{\"t\":0,\"x\":0,\"y\":0,\"z\":200}",
            "line 2 starts with a byte-order mark",
        ),
        (
            "[0,0,0,200,1]",
            "line 2: not a centroid JSON object (a JSON array",
        ),
    ] {
        let e = parse_line(line, 2).unwrap_err().to_string();
        assert!(e.contains(needle), "{line}: {e}");
    }
}

#[test]
fn parses_track_json_lines() {
    // Raw centroid (no filter): `present` and `centroid_mm`.
    let raw = r#"{"t_s":0.25,"points":310,"present":true,"centroid_mm":[1.5,2,200],"truth_present":true,"truth_mm":[1,2,3],"z_profile_mm":null,"replan":false}"#;
    assert_eq!(parsed(raw), sample(0.25, [1.5, 2.0, 200.0], true));
    // The presence gate wins over the frame's presence when the line has
    // one; the filtered centre over the raw one.
    let f = r#"{"t_s":0.5,"points":3,"present":true,"centroid_mm":[1,2,3],"gated_present":false,"filtered_mm":null}"#;
    assert_eq!(parsed(f), sample(0.5, [1.0, 2.0, 3.0], false));
    // An unfiltered `track --json` line (every line carries the gate):
    // gated present, at its raw centroid.
    let g = r#"{"t_s":0.75,"points":40,"present":true,"centroid_mm":[1,2,3],"gated_present":true}"#;
    assert_eq!(parsed(g), sample(0.75, [1.0, 2.0, 3.0], true));
    let f = r#"{"t_s":0.5,"points":3,"present":true,"centroid_mm":[1,2,3],"gated_present":true,"filtered_mm":[4,5,6]}"#;
    assert_eq!(parsed(f).pos_mm, [4.0, 5.0, 6.0]);
    let absent = r#"{"t_s":0.5,"points":0,"present":false,"centroid_mm":null}"#;
    assert!(!parsed(absent).present);
    for (bad, says) in [
        (
            r#"{"t_s":0.5,"present":true,"centroid_mm":[1,2,3],"colour":1}"#,
            "unknown field `colour`",
        ),
        (
            r#"{"t_s":0.5,"present":true,"centroid_mm":null}"#,
            "needs its centre",
        ),
        (
            r#"{"t_s":0.5,"centroid_mm":[1,2,3]}"#,
            "missing field `present`",
        ),
        (
            r#"{"t_s":0.5,"present":true,"centroid_mm":[1,2]}"#,
            "line 3",
        ),
    ] {
        let e = parse_line(bad, 3).unwrap_err().to_string();
        assert!(e.contains(says) && e.starts_with("line 3"), "{bad}: {e}");
    }
}

#[test]
fn parses_json_and_csv() {
    assert_eq!(
        parsed(r#"{"t":0.5,"x":1,"y":2,"z":3}"#),
        sample(0.5, [1.0, 2.0, 3.0], true)
    );
    assert_eq!(
        parsed("0.5, 1, 2, 3, 0"),
        sample(0.5, [1.0, 2.0, 3.0], false)
    );
    assert_eq!(parse_line("t,x,y,z,present", 1).unwrap(), None);
    assert_eq!(
        parse_line("\u{feff}0.5,1,2,3,0", 1).unwrap(),
        parse_line("0.5,1,2,3,0", 1).unwrap()
    );
    assert!(parse_line("\u{feff}0.5,1,2,3,0", 2).is_err());
    assert_eq!(parse_line("  # note", 1).unwrap(), None);
}

#[test]
fn present_takes_the_same_values_in_json_and_csv() {
    for (v, want) in [("true", true), ("false", false), ("1", true), ("0", false)] {
        let json = format!(r#"{{"t":0.5,"x":1,"y":2,"z":3,"present":{v}}}"#);
        assert_eq!(parsed(&json).present, want, "{json}");
        assert_eq!(parsed(&format!("0.5,1,2,3,{v}")).present, want, "{v}");
        let track = format!(r#"{{"t_s":0.5,"present":{v},"centroid_mm":[1,2,3]}}"#);
        assert_eq!(parsed(&track).present, want, "{track}");
    }
    // CSV from a spreadsheet: any case.
    for (v, want) in [("TRUE", true), ("False", false)] {
        assert_eq!(parsed(&format!("0.5,1,2,3,{v}")).present, want, "{v}");
    }
    let said =
        |v: &str| format!("line 4: `{v}` is not a `present` value: give true, false, 1 or 0");
    // JSON's other values, shown as JSON: a string, a fraction, a null.
    for v in [r#""true""#, r#""1""#, "1.0", "2", "-1", "null", "[true]"] {
        for line in [
            format!(r#"{{"t":0.5,"x":1,"y":2,"z":3,"present":{v}}}"#),
            format!(r#"{{"t_s":0.5,"present":{v},"centroid_mm":[1,2,3],"gated_present":true}}"#),
        ] {
            let e = parse_line(&line, 4).unwrap_err().to_string();
            assert_eq!(e, said(v), "{line}");
        }
    }
    // CSV's, in the same words: no yes/no, no fraction, no quotes.
    for v in ["yes", "2", "1.0", "\"1\"", "truth"] {
        let e = parse_line(&format!("0.5,1,2,3,{v}"), 4)
            .unwrap_err()
            .to_string();
        assert_eq!(e, said(v), "{v}");
    }
}

#[test]
fn bad_lines_say_what_is_wrong() {
    let e = parse_line("0.5,1,2", 7).unwrap_err().to_string();
    assert!(e.contains("line 7") && e.contains("5 CSV fields"), "{e}");
    let e = parse_line("0.5,1,2,x,1", 3).unwrap_err().to_string();
    assert_eq!(e, "line 3: `z`: x is not a number");
    let e = parse_line(r#"{"t":1,"x":1}"#, 2).unwrap_err().to_string();
    assert!(e.starts_with("line 2: not a centroid JSON"), "{e}");
    assert!(parse_line("0,1,2,nan,1", 1).is_err());
    assert!(!e.contains('\n'));
}

#[test]
fn reads_lines_with_errors_in_place() {
    let text = "t,x,y,z,present\n0,1,2,3,1\nbad\n";
    let v: Vec<_> = read_lines(text.as_bytes()).collect();
    assert_eq!(v.len(), 2);
    assert!(v[0].is_ok() && v[1].is_err());
}

#[test]
fn long_lines_are_refused_without_reading_them_whole() {
    let mut text = "0,0,0,200,1\n".to_string();
    text.push_str(&"9".repeat(MAX_LINE_BYTES + 1));
    let v: Vec<_> = read_lines(text.as_bytes()).collect();
    assert!(v[0].is_ok());
    let e = v[1].as_ref().unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("4096 bytes"), "{e}");
    // An endless stream of zero bytes ends with the same error.
    let zeros = std::io::BufReader::new(std::io::repeat(0));
    let e = read_lines(zeros).next().unwrap().unwrap_err();
    assert!(e.downcast_ref::<InputError>().is_some(), "{e}");
}

#[test]
fn replay_gaps_and_bad_bytes_are_errors_naming_the_line() {
    let text = "0,0,0,200,1\n1000,0,0,200,1\n";
    let v: Vec<_> = replay_lines(text.as_bytes()).collect();
    let e = v[1].as_ref().unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("at most 60 s"), "{e}");
    // Live streams do not pace, so a gap is fine there.
    assert!(read_lines(text.as_bytes()).all(|r| r.is_ok()));
    let bytes: &[u8] = b"0,0,0,200,1\n\xff\xfe\n";
    let v: Vec<_> = read_lines(bytes).collect();
    assert!(v[1].as_ref().unwrap_err().to_string().contains("not UTF-8"));
}

#[test]
fn udp_port_zero_is_refused_as_input() {
    let idle = std::time::Duration::from_millis(10);
    let err = udp(0, idle, Default::default())
        .err()
        .expect("port 0 refused");
    assert!(err.is::<crate::InputError>(), "{err}");
    assert!(err.to_string().contains("--udp 0"), "{err}");
}

#[test]
fn a_replayed_file_names_itself_in_its_errors() {
    let path = std::env::temp_dir().join(format!("lmhost-replay-{}.csv", std::process::id()));
    std::fs::write(&path, "0,0,0,200,1\n\u{1}garbage\n").unwrap();
    let v: Vec<_> = replay_file("--stream", &path).unwrap().collect();
    let _ = std::fs::remove_file(&path);
    let err = v
        .into_iter()
        .find_map(Result::err)
        .expect("the garbage line refused");
    let msg = crate::error::one_line(&err);
    assert!(err.chain().any(|c| c.is::<InputError>()), "{msg}");
    let want = format!("--stream file {}: line 2: ", path.display());
    assert!(msg.starts_with(&want), "{msg}");
}

#[test]
fn datagrams_the_kernel_dropped_are_counted() {
    use std::sync::atomic::Ordering::Relaxed;
    let port = {
        let probe = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        probe.local_addr().unwrap().port()
    };
    let counts = std::sync::Arc::new(UdpCounts::default());
    let samples = udp(port, std::time::Duration::from_millis(500), counts.clone()).unwrap();
    // A burst far beyond the socket's buffer while nothing reads: the
    // kernel keeps what fits and drops the rest.
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    const BURST: usize = 20_000;
    for i in 0..BURST {
        tx.send_to(
            format!("{},0,0,200,1", i as f64 / 1000.0).as_bytes(),
            ("127.0.0.1", port),
        )
        .unwrap();
    }
    // The count comes with the next datagram after the drops: send one
    // more once the reader has made room.
    let last = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(200));
        tx.send_to(b"100,0,0,200,1", ("127.0.0.1", port)).unwrap();
    });
    let got = samples.filter(|s| s.is_ok()).count() as u64;
    last.join().unwrap();
    let lost = counts
        .lost()
        .expect("Linux counts a socket's dropped datagrams");
    assert!(
        lost > 0,
        "a {BURST}-datagram burst with no reader lost none"
    );
    assert_eq!(counts.datagrams.load(Relaxed), got);
    assert_eq!(got + lost, BURST as u64 + 1, "received {got}, lost {lost}");
}

#[test]
fn an_empty_or_blank_datagram_is_counted_bad_and_a_comment_is_not() {
    use std::sync::atomic::Ordering::Relaxed;
    let probe = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = probe.local_addr().unwrap().port();
    drop(probe);
    let counts = std::sync::Arc::new(UdpCounts::default());
    let samples = udp(port, std::time::Duration::from_millis(300), counts.clone()).unwrap();
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    for d in [
        &b""[..],
        b"0.0,0,0,200,1",
        b"\n \n",
        b"# a comment\nt,x,y,z,present",
        b"0.1,0,0,200,1",
        // Lines in a datagram end as a stream's do: LF, CRLF, a lone CR.
        b"0.2,0,0,200,1\r0.3,0,0,200,1\r\n0.4,0,0,200,1\r",
        // A bad line makes the datagram bad; the lines after it are read.
        b"bad\r0.5,0,0,200,1",
    ] {
        tx.send_to(d, ("127.0.0.1", port)).unwrap();
    }
    let got: Vec<_> = samples.map(|s| s.unwrap().t_s).collect();
    assert_eq!(got, [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]);
    assert_eq!(counts.datagrams.load(Relaxed), 7);
    assert_eq!(
        counts.bad_datagrams.load(Relaxed),
        3,
        "the empty, the blank and the bad one"
    );
}

#[test]
fn lines_read_the_same_whatever_wrote_them() {
    let times = |bytes: &[u8], buffer: usize| -> Vec<String> {
        let r = std::io::BufReader::with_capacity(buffer, bytes);
        read_lines(r)
            .map(|s| s.map_or_else(|e| format!("{e:#}"), |s| s.t_s.to_string()))
            .collect()
    };
    let want = ["0", "0.5", "1"];
    let lf = "0,0,0,200,1\n0.5,0,0,200,1\n1,0,0,200,1\n";
    for text in [
        lf.to_owned(),
        format!("\u{feff}{}", lf.replace('\n', "\r\n")),
        lf.replace('\n', "\r"),
        lf.trim_end().replace('\n', "\r"),
        format!("{lf}\n\r\n\n"),
    ] {
        // A CRLF split between two reads is one line end.
        for buffer in [1, 12, 13, 8192] {
            let got = times(text.as_bytes(), buffer);
            assert_eq!(got, want, "{text:?} in {buffer}-byte reads");
        }
    }
    // Line numbers count CR-ended lines as an editor does.
    let v = times(b"0,0,0,200,1\r0.5,0,0,200,1\rx\r", 8192);
    assert_eq!(
        v[2],
        "line 3: expected 5 CSV fields t,x,y,z,present, found 1"
    );
    let utf16: Vec<u8> = "0,0,0,200,1\n"
        .encode_utf16()
        .flat_map(u16::to_le_bytes)
        .collect();
    let v = times(&[&b"\xff\xfe"[..], &utf16].concat(), 8192);
    assert_eq!(
        v,
        ["line 1 is UTF-16 (little-endian) text, not UTF-8: send or save it as UTF-8"]
    );
    let v = times(b"0;3,5;0;200;1\n", 8192);
    assert!(
        v[0].starts_with("line 1: fields separated by `;` and decimal commas (`3,5`)"),
        "{v:?}"
    );
    let v = times(b"0,3,5,0,200,1\n0,x,0,200,1\n", 8192);
    assert_eq!(
        v[0],
        "line 1: expected 5 CSV fields t,x,y,z,present, found 6"
    );
    let v = times(b"0,3;5,0,200,1\n", 8192);
    assert!(v[0].starts_with("line 1: fields separated by `;`"), "{v:?}");
}

#[test]
fn a_json_key_with_a_line_break_is_refused_on_one_line() {
    for line in [
        r#"{"t": 1, "x": 0, "y": 0, "z": 0, "a\nb": 1}"#.to_owned(),
        format!(
            r#"{{"t": 1, "x": 0, "y": 0, "z": 0, "{}": 1}}"#,
            "k ".repeat(500)
        ),
    ] {
        let e = parse_line(&line, 3).unwrap_err().to_string();
        assert!(
            e.starts_with("line 3: not a centroid JSON object (unknown field `"),
            "{e}"
        );
        assert!(!e.contains(['\n', '\r']) && e.len() < 400, "{e}");
    }
}

#[test]
fn a_bad_value_in_a_centroid_object_is_refused_as_a_bad_value() {
    let too_large = "is too large to represent (it would be read as inf): give a magnitude of at most 1.79769e308";
    for (line, want) in [
        (
            r#"{"t":0,"x":1e999,"y":0,"z":200}"#,
            format!("line 3: `x`: 1e999 {too_large}"),
        ),
        (
            r#"{"t":0,"x":"a","y":0,"z":200}"#,
            r#"line 3: `x`: "a" is not a number"#.to_owned(),
        ),
        (
            r#"{"t":null,"x":0,"y":0,"z":200}"#,
            "line 3: `t`: null is not a number".to_owned(),
        ),
        (
            r#"{"t_s":0,"present":true,"centroid_mm":[0,200]}"#,
            "line 3: `centroid_mm`: [0,200] is not [x, y, z] (three numbers) or null".to_owned(),
        ),
        (
            r#"{"t_s":0,"present":true,"centroid_mm":[0,0,200],"gated_present":1}"#,
            "line 3: `gated_present`: 1 is not true or false".to_owned(),
        ),
        (
            r#"{"t_s":1e999,"present":true,"centroid_mm":[0,0,200]}"#,
            format!("line 3: `t_s`: 1e999 {too_large}"),
        ),
    ] {
        assert_eq!(parse_line(line, 3).unwrap_err().to_string(), want, "{line}");
    }
    // A line that is no object, or not whole JSON, is still said so,
    // a number beyond a float in it or not.
    for (line, starts) in [
        (
            r#"{"t":0,"x":1e999,"y":0"#,
            "line 3: not a centroid JSON object (EOF while parsing",
        ),
        (
            r#"{"t":0,"x":0,"y":0,"z":200} x"#,
            "line 3: not a centroid JSON object (trailing characters",
        ),
        (
            r#"{"t":0,"x":0,"y":0}"#,
            "line 3: not a centroid JSON object (missing field `z`",
        ),
    ] {
        let e = parse_line(line, 3).unwrap_err().to_string();
        assert!(e.starts_with(starts), "{line}: {e}");
    }
}

#[test]
fn null_is_a_value_only_where_track_writes_it() {
    // `track --json` writes `null` for no centroid and no filtered centre:
    // read as none.
    let none = r#"{"t_s":0.5,"present":false,"centroid_mm":null,"gated_present":false,"filtered_mm":null}"#;
    assert!(!parsed(none).present);
    // A key left out for its default is never given as `null`.
    let e = parse_line(
        r#"{"t_s":0.5,"present":true,"centroid_mm":[1,2,3],"gated_present":null}"#,
        3,
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        format!("line 3: `gated_present`: {}", crate::json::NULL_REFUSED)
    );
    // A plain line's `present`, left out a finger, is refused as null.
    let e = parse_line(r#"{"t":0,"x":0,"y":0,"z":200,"present":null}"#, 3)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("line 3: `null` is not a `present` value"),
        "{e}"
    );
}
