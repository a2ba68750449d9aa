use super::*;
use crate::plan::sequence::Plan;
use lm_proto::Encoding;
use lm_proto::MessageType;
use lm_proto::codec::CodecError;

/// The `Info` of a simulated-device-like firmware with `slots` slots
/// (also for the backend's tests).
pub(crate) fn info(slots: u8) -> Info {
    Info {
        proto_version: lm_proto::PROTOCOL_VERSION,
        fw_version: [0, 1, 0],
        max_transducers: 996,
        slot_bytes: 200 * 996,
        slots,
        timer_hz: 1_000_000,
        min_dwell_us: 1000,
        max_chunk: 1024,
        rig_transducers: 0,
        rig_crc32: 0,
        library_free: 200 * 996,
        clock: lm_proto::ClockSource::Emulated,
    }
}

#[test]
fn spec_carries_the_bytes_sequence_encode_made_and_the_device_check() {
    let plan = Plan::paper_lm_m().unwrap();
    let spec = UploadSpec::from_plan(&plan, Encoding::Delta).unwrap();
    assert_eq!(spec.encoded, plan.sequence.encode(Encoding::Delta).unwrap());
    assert_eq!(spec.crc32, lm_proto::crc32(&plan.sequence.phases));
    assert_eq!(spec.header, plan.sequence.header);
    let b = spec.begin(1);
    assert_eq!((b.slot, b.encoded_len as usize), (1, spec.encoded.len()));
    assert_eq!(spec.check_fits(&info(2), 1), Ok(()));
    assert_eq!(
        spec.check_fits(&info(2), 2).map_err(|e| e.nack()),
        Err(NackCode::BadSlot)
    );
    let small = Info {
        slot_bytes: 10 * 996,
        ..info(2)
    };
    assert_eq!(
        spec.check_fits(&small, 0).map_err(|e| e.nack()),
        Err(NackCode::TooLarge)
    );
    let slow = Info {
        min_dwell_us: 5000,
        ..info(2)
    };
    let e = spec.check_fits(&slow, 0).unwrap_err();
    assert_eq!(e.nack(), NackCode::DwellTooShort);
    assert!(e.to_string().contains("minimum 5000 µs"), "{e}");
}

#[test]
fn inconsistent_sequences_are_a_typed_codec_error() {
    let plan = Plan::paper_lm_m().unwrap();
    let e = UploadSpec::new(&plan.sequence, vec![[0; 3]; 3], Encoding::Raw).unwrap_err();
    assert!(matches!(e, LinkError::Codec(CodecError::BadShape)), "{e}");
    let mut seq = plan.sequence.clone();
    seq.phases.truncate(10);
    let pos = plan.positions_um().unwrap();
    let e = UploadSpec::new(&seq, pos, Encoding::Delta).unwrap_err();
    assert!(matches!(e, LinkError::Codec(CodecError::BadShape)), "{e}");
}

/// A scripted port: `reply` turns each frame the client sends into the
/// bytes that come back, there to read at once.
struct Scripted<F> {
    name: &'static str,
    reply: F,
    pending: Vec<u8>,
}

impl<F: FnMut(&[u8], &mut Vec<u8>) + Send> Scripted<F> {
    fn new(name: &'static str, reply: F) -> Self {
        Scripted {
            name,
            reply,
            pending: Vec::new(),
        }
    }
}

impl<F: FnMut(&[u8], &mut Vec<u8>) + Send> Transport for Scripted<F> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        (self.reply)(bytes, &mut self.pending);
        Ok(())
    }
    fn recv(&mut self, buf: &mut [u8], _timeout: Duration) -> std::io::Result<usize> {
        let n = self.pending.len().min(buf.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
    fn describe(&self) -> String {
        self.name.into()
    }
}

/// A scripted device: `answer` sees each frame the client sends and gives
/// the head and message of its reply (`None`: no reply).
fn device(
    name: &'static str,
    mut answer: impl FnMut(&lm_proto::Frame<'_>) -> Option<(lm_proto::Head, Message<'static>)> + Send,
) -> Scripted<impl FnMut(&[u8], &mut Vec<u8>) + Send> {
    Scripted::new(name, move |sent: &[u8], out: &mut Vec<u8>| {
        let mut d = FrameDecoder::new();
        let FeedResult::Frame { frame, .. } = d.feed(sent) else {
            panic!("the client sends whole frames");
        };
        if let Some((head, reply)) = answer(&frame) {
            let mut buf = [0u8; MAX_ENCODED_FRAME];
            let n = encode_frame(head, &reply, &mut buf).unwrap();
            out.extend_from_slice(&buf[..n]);
        }
    })
}

/// A request nothing answers says what came instead: its own frames, or
/// bytes that are no frame; and it names the port.
#[test]
fn a_timeout_says_what_came_instead_of_the_reply() {
    for (junk, want) in [
        (None, "the port echoed lmhost's own frames back"),
        (
            Some(&b"AT\r\nOK\r\n"[..]),
            "24 bytes came, none an LM protocol frame",
        ),
    ] {
        // A port that sends back what it is sent (a loopback, an adapter
        // with nothing behind it), or `junk` in its place.
        let mut c = Client::new(Scripted::new(
            "mirror",
            move |sent: &[u8], out: &mut Vec<u8>| out.extend_from_slice(junk.unwrap_or(sent)),
        ));
        c.timeout = Duration::from_millis(5);
        c.tries = 3;
        let e = c.info().unwrap_err();
        assert!(matches!(e, LinkError::Timeout { .. }), "{e}");
        let e = e.to_string();
        assert!(
            e.starts_with("no response from mirror to info after 3 tries"),
            "{e}"
        );
        assert!(e.contains(want), "{e}");
    }
}

/// A centroid resent after its ack was lost is the one the device took:
/// its `OutOfOrder` for the copy is not a refusal; for a first copy it is.
#[test]
fn a_centroid_resent_after_a_lost_ack_is_accepted() {
    let centroid = Centroid {
        seq: 7,
        pos_um: [0, 0, 200_000],
        present: true,
        host_time_us: 1,
    };
    for lose_first in [true, false] {
        // A device that took each centroid, but whose ack of its first copy
        // was lost (`lose_first`), so it answers the resent copy as firmware
        // does: `OutOfOrder`, it holds that update already.
        let mut last_seq = None;
        let mut c = Client::new(device("lossy", move |frame| {
            let resend = last_seq == Some(frame.seq);
            last_seq = Some(frame.seq);
            (!lose_first || resend)
                .then(|| (frame.reply_head(), Message::Nack(NackCode::OutOfOrder)))
        }));
        c.timeout = Duration::from_millis(5);
        let r = c.centroid(centroid);
        if lose_first {
            r.unwrap();
            assert_eq!(c.stats.retries, 1);
        } else {
            let e = r.unwrap_err();
            assert!(
                matches!(
                    e,
                    LinkError::Nack {
                        code: NackCode::OutOfOrder,
                        ..
                    }
                ),
                "{e}"
            );
        }
    }
}

/// A reply with the request's seq that echoes another request (replayed,
/// or made up before the request was written) is refused in one line
/// naming the port and what was wrong; the echo of the request written is
/// taken.
#[test]
fn a_reply_that_echoes_another_request_is_refused() {
    for (forge, kind) in [(true, "ack"), (false, "")] {
        let mut c = Client::new(device("forger", move |frame| {
            // The seq is right; the echo is a Renew's with that seq,
            // which the forger guessed came next.
            let head = if forge {
                lm_proto::Head::reply(
                    frame.seq,
                    lm_proto::Echo::of_request(frame.seq, &Message::Renew).unwrap(),
                )
            } else {
                frame.reply_head()
            };
            Some((head, Message::Ack))
        }));
        c.timeout = Duration::from_millis(5);
        let r = c.stop();
        if !forge {
            r.unwrap();
            continue;
        }
        let e = r.unwrap_err();
        assert!(matches!(e, LinkError::BadReply { .. }), "{e}");
        let e = e.to_string();
        assert!(e.starts_with(&format!("the {kind} from forger")), "{e}");
        assert!(e.contains("answers a request of type 0x0c"), "{e}");
        assert!(
            e.contains("the stop request lmhost wrote has type 0x07"),
            "{e}"
        );
        assert!(!e.contains('\n'), "one line: {e}");
        // The same forger's Renew ack echoes the Renew written: taken.
        c.renew().unwrap();
    }
}

/// A decoded frame of `msg_type` answering `req` (its seq and echo) with
/// `fields` after the echo, framed for the wire: any length, any type.
fn raw_reply(req: &lm_proto::Frame<'_>, msg_type: u8, fields: &[u8]) -> Vec<u8> {
    let echo = req.reply_head().echo.unwrap();
    let mut d = vec![lm_proto::PROTOCOL_VERSION, msg_type];
    d.extend_from_slice(&req.seq.to_le_bytes());
    d.push(echo.request_type);
    d.extend_from_slice(&echo.request_crc32.to_le_bytes());
    d.extend_from_slice(fields);
    d.extend_from_slice(&lm_proto::crc32(&d).to_le_bytes());
    let mut w = vec![0u8; d.len() + d.len() / 254 + 3];
    let n = lm_proto::cobs::encode(&d, &mut w[1..]).unwrap();
    w[0] = 0;
    w.truncate(n + 2);
    w[n + 1] = 0;
    w
}

/// A buggy device (SPEC section 3, "Hosts hold a device to these
/// tables"): every reply a request cannot get (another kind, a length the
/// type does not have, a code no firmware sends, a self-test whose counts
/// contradict) fails the request in one line naming the port, as a
/// failed operation (never bad input, never a panic); none is taken.
#[test]
fn a_buggy_devices_replies_fail_in_one_line_naming_the_port() {
    type Answer = Box<dyn FnMut(&lm_proto::Frame<'_>) -> Vec<u8> + Send>;
    let framed = |msg: Message<'static>| -> Answer {
        Box::new(move |req| {
            let mut buf = [0u8; MAX_ENCODED_FRAME];
            let n = encode_frame(req.reply_head(), &msg, &mut buf).unwrap();
            buf[..n].to_vec()
        })
    };
    let failed = SelfTest::Failed {
        bytes: 1024,
        mismatches: 0,
        first_mismatch: 0,
        sent: 1,
        got: 2,
    };
    let mut status_bytes = [0u8; 52];
    status_bytes[1] = 0xFF;
    status_bytes[40] = 0xFF;
    let cases: Vec<(&str, Answer, &str)> = vec![
        (
            "stop",
            framed(Message::Info(info(32))),
            "answered stop with an info",
        ),
        ("info", framed(Message::Ack), "answered info with an ack"),
        (
            "self test",
            framed(Message::SelfTestResult(failed)),
            "0 mismatches",
        ),
        (
            "self test",
            framed(Message::SelfTestResult(SelfTest::Passed { bytes: 0 })),
            "passed over 0 bytes",
        ),
        ("stop", framed(Message::Nack(NackCode::Other(200))), "200"),
        // A status one byte short, one byte long, then an ack with a byte:
        // no frame of their type, so nothing answers.
        (
            "status",
            Box::new(move |req: &lm_proto::Frame<'_>| {
                raw_reply(req, MessageType::Status as u8, &status_bytes[..51])
            }),
            "no response",
        ),
        (
            "status",
            Box::new(move |req: &lm_proto::Frame<'_>| {
                raw_reply(
                    req,
                    MessageType::Status as u8,
                    &[status_bytes.as_slice(), &[0]].concat(),
                )
            }),
            "no response",
        ),
        (
            "stop",
            Box::new(|req: &lm_proto::Frame<'_>| raw_reply(req, MessageType::Ack as u8, &[0])),
            "no response",
        ),
        (
            "stop",
            Box::new(|req: &lm_proto::Frame<'_>| raw_reply(req, 0xFE, &[])),
            "no response",
        ),
    ];
    for (what, mut answer, want) in cases {
        let mut c = Client::new(Scripted::new(
            "buggy",
            move |sent: &[u8], out: &mut Vec<u8>| {
                let mut d = FrameDecoder::new();
                let FeedResult::Frame { frame, .. } = d.feed(sent) else {
                    panic!("the client sends whole frames");
                };
                // The Info the status check needs comes whole.
                if frame.message == Message::GetInfo && what != "info" {
                    let mut buf = [0u8; MAX_ENCODED_FRAME];
                    let n = encode_frame(frame.reply_head(), &Message::Info(info(32)), &mut buf)
                        .unwrap();
                    out.extend_from_slice(&buf[..n]);
                    return;
                }
                out.extend_from_slice(&answer(&frame));
            },
        ));
        c.timeout = Duration::from_millis(5);
        c.tries = 2;
        let e = match what {
            "stop" => c.stop().unwrap_err(),
            "info" => c.info().unwrap_err(),
            "status" => c.status().unwrap_err(),
            _ => c.self_test().unwrap_err(),
        };
        let line = e.to_string();
        assert!(line.contains(want), "{what}: {line}");
        assert!(line.contains("buggy"), "{what}: names the port: {line}");
        assert!(!line.contains('\n'), "{what}: one line: {line}");
        // A device's fault: a failed operation (exit 1), never bad input.
        assert!(
            matches!(
                e,
                LinkError::BadReply { .. }
                    | LinkError::Unexpected { .. }
                    | LinkError::Nack { .. }
                    | LinkError::Timeout { .. }
            ),
            "{what}: {line}"
        );
    }
}
