//! The control protocol's parsing and messages.

use super::*;

#[test]
fn commands_parse_and_bad_ones_say_what_is_accepted() {
    assert_eq!(
        Command::parse(
            r#"{"cmd":"present","stimulus":"a","gate":"untracked","on_s":2,"off_s":2,"repeat":3}"#
        )
        .unwrap(),
        Command::Present(Present {
            stimulus: "a".into(),
            gate: Some(Gate::Untracked),
            on_s: Some(2.0),
            off_s: Some(2.0),
            repeat: Some(3),
        })
    );
    assert_eq!(Command::parse(r#"{"cmd":"stop"}"#).unwrap(), Command::Stop);
    assert_eq!(
        Command::parse(r#"{"cmd":"auth","token":"t"}"#).unwrap(),
        Command::Auth { token: "t".into() }
    );
    for (line, needle) in [
        ("", "bad command"),
        ("{}", "missing field `cmd`"),
        (
            r#"{"cmd":"present","stimulus":"a","on_s":1,"off_s":2}"#,
            "`off_s` is the silence between on-phases: give `repeat` 2 or more",
        ),
        (
            r#"{"cmd":"present","stimulus":"a","on_s":1,"off_s":0,"repeat":1}"#,
            "give `repeat` 2 or more",
        ),
        (r#"{"cmd":"dance"}"#, "unknown command `dance`"),
        (r#"{"cmd":7}"#, "`cmd` is not a string"),
        ("[1,2]", "not a JSON object"),
        (
            r#"{"cmd":"stop","stimulus":"x"}"#,
            "unknown field `stimulus`: `stop` takes no fields",
        ),
        (
            r#"{"cmd":"status","verbose":true}"#,
            "`status` takes no fields",
        ),
        (r#"{"cmd":"quit","now":1}"#, "`quit` takes no fields"),
        (
            r#"{"cmd":"prepare","stimulus":"a","gate":"tracked"}"#,
            "`prepare` takes stimulus",
        ),
        (
            r#"{"cmd":"prepare","stimulus":3}"#,
            "`stimulus` is not a string",
        ),
        (r#"{"cmd":"auth"}"#, "missing field `token`"),
        (r#"{"cmd":"stop","cmd":"quit"}"#, "duplicate key `cmd`"),
        (
            r#"{"cmd":"present","stimulus":"a","on_s":1,"on_s":1000}"#,
            "duplicate key `on_s`",
        ),
        (r#"{"cmd":"present"}"#, "missing field `stimulus`"),
        (
            r#"{"cmd":"present","stimulus":"a","gate":"loose"}"#,
            "unknown variant `loose`",
        ),
        (
            r#"{"cmd":"present","stimulus":"a","colour":1}"#,
            "unknown field `colour`",
        ),
        (
            r#"{"cmd":"present","stimulus":"a","repeat":-1}"#,
            "repeat -1 is out of range: allowed 1..=10000",
        ),
    ] {
        let e = Command::parse(line).unwrap_err().to_string();
        assert!(e.contains(needle), "{line}: {e}");
        assert!(e.starts_with("bad command: ") && !e.contains('\n'), "{e}");
    }
    // The reply says the field's rule, not its Rust type's range.
    let e = Command::parse(r#"{"cmd":"present","stimulus":"a","repeat":-1}"#).unwrap_err();
    let r = Reply::error("present", e.to_string());
    let said = r.0["error"].as_str().unwrap();
    assert!(
        said.ends_with("repeat -1 is out of range: allowed 1..=10000") && !said.contains("u32"),
        "{said}"
    );
    // A refusal names the command it refuses, where the line names one.
    for (line, name) in [
        (r#"{"cmd":"present","stimulus":"a","on_s":"x"}"#, "present"),
        (r#"{"cmd":"stop","now":1}"#, "stop"),
        (r#"{"cmd":"dance"}"#, ""),
        (r#"{"cmd":"stop","cmd":"quit"}"#, ""),
        ("[1]", ""),
        (r#"["stop"]"#, ""),
        (
            r#"{"cmd":"present","stimulus":"a","on_s":1e999}"#,
            "present",
        ),
        (
            r#"{"cmd":"present","stimulus":"a","off_s":-1e-320}"#,
            "present",
        ),
    ] {
        assert!(Command::parse(line).is_err(), "{line}");
        assert_eq!(Command::named_in(line), name, "{line}");
    }
    // A number no float holds is refused as itself with its key, not as
    // a line that is no JSON object.
    for (line, said) in [
        (
            r#"{"cmd":"present","stimulus":"a","on_s":1e999}"#,
            "bad command: `on_s`: 1e999 is too large to represent (it would be read as inf): \
             give a magnitude of at most 1.79769e308",
        ),
        (
            r#"{"cmd":"present","stimulus":"a","repeat":-1e400}"#,
            "bad command: `repeat`: -1e400 is too large to represent (it would be read as -inf): \
             give a magnitude of at most 1.79769e308",
        ),
    ] {
        assert_eq!(Command::parse(line).unwrap_err().to_string(), said);
    }
    let long = format!(r#"{{"cmd":"present","stimulus":"{}"}}"#, "a".repeat(5000));
    assert!(
        Command::parse(&long)
            .unwrap_err()
            .to_string()
            .contains("longer than")
    );
}

#[test]
fn values_repeated_in_messages_are_bounded() {
    let long = "z".repeat(4000);
    for line in [
        format!(r#"{{"cmd":"{long}"}}"#),
        format!(r#"{{"cmd":"stop","{long}":1}}"#),
        format!(r#"{{"cmd":"present","stimulus":"a","gate":"{long}"}}"#),
        // serde names a string of the wrong type in double quotes.
        format!(r#"{{"cmd":"present","stimulus":"a","on_s":"{long}"}}"#),
    ] {
        let e = Command::parse(&line).unwrap_err().to_string();
        assert!(e.len() < 400, "{} bytes: {e}", e.len());
        assert!(e.contains("(4000 bytes)"), "{e}");
    }
    // A `repeat` is judged by its rule, its value not repeated.
    let e = Command::parse(&format!(
        r#"{{"cmd":"present","stimulus":"a","repeat":"{long}"}}"#
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.ends_with("`repeat` is a string, not a number: allowed 1..=10000"),
        "{e}"
    );
    assert_eq!(clip("short"), "short");
    assert_eq!(clip("a\nb"), "a\\nb");
    let c = clip(&"é".repeat(100));
    assert!(c.ends_with("(200 bytes)") && c.chars().count() < 70, "{c}");
}

#[test]
fn events_are_flat_json_with_their_name() {
    let e = Event {
        t_host_us: 7,
        kind: EventKind::Switch {
            from: Some("a".into()),
            to: "b".into(),
            latency_ms: 1.5,
            detected_ms: 2.0,
        },
    };
    assert_eq!(
        serde_json::to_string(&e).unwrap(),
        r#"{"t_host_us":7,"event":"switch","from":"a","to":"b","latency_ms":1.5,"detected_ms":2.0}"#
    );
    assert_eq!(
        mute_name(MuteReason::CentroidOutOfRange),
        "centroid_out_of_range"
    );
    assert!(Reply::ok("x").is_ok());
    assert!(!Reply::error("x", "no").is_ok());
}

#[test]
fn a_null_is_refused_naming_its_key_never_taken_for_a_key_left_out() {
    // Left out, each optional key takes its default.
    let p = Command::parse(r#"{"cmd":"present","stimulus":"a"}"#).unwrap();
    assert_eq!(
        p,
        Command::Present(Present {
            stimulus: "a".into(),
            gate: None,
            on_s: None,
            off_s: None,
            repeat: None,
        })
    );
    // As `null`, each is refused by its name: a `null` on_s is not a
    // play until stopped, nor a `null` repeat one on-phase.
    for key in ["gate", "on_s", "off_s", "repeat"] {
        let line = format!(r#"{{"cmd":"present","stimulus":"a","on_s":1,"{key}":null}}"#);
        let line = line.replace(r#""on_s":1,"on_s":null"#, r#""on_s":null"#);
        let e = Command::parse(&line).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("bad command: `{key}`: {}", crate::json::NULL_REFUSED),
            "{line}"
        );
    }
    // A required key's `null` is a value of the wrong kind.
    let e = Command::parse(r#"{"cmd":"prepare","stimulus":null}"#)
        .unwrap_err()
        .to_string();
    assert_eq!(e, "bad command: `stimulus` is not a string");
}
