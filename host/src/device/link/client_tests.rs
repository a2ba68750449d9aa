use super::*;
use crate::plan::sequence::Plan;
use lm_proto::Encoding;
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
