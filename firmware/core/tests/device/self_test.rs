//! `SelfTest` through the wire.

use super::*;

/// An output with a loopback jumper (or without one).
struct Loopback(Option<u8>);

impl lm_fw_core::OutputDriver for Loopback {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, _: &lm_fw_core::OutputFrame<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
    fn self_test(&mut self) -> lm_proto::SelfTest {
        let stuck = self.0;
        lm_fw_core::output::loopback_test(|sent: &[u8], got: &mut [u8]| {
            for (g, s) in got.iter_mut().zip(sent) {
                *g = stuck.unwrap_or(*s);
            }
            Ok::<(), ()>(())
        })
    }
}

/// `SelfTest` through the wire: the board's result, `Unsupported` where it
/// has none, `Busy` while a slot plays or is queued.
#[test]
fn self_test_reports_the_boards_loopback_and_waits_for_silence() {
    let (mut dev, _) = device_with_a();
    let mut wire = [0u8; lm_proto::MAX_ENCODED_FRAME];
    let n = lm_proto::encode_frame(9, &Message::SelfTest, &mut wire).unwrap();
    let run = |dev: &mut lm_fw_core::Device<'_>, out: &mut Loopback| {
        let mut bytes = Vec::new();
        dev.feed(&wire[..n], 0, out, &mut |b: &[u8]| {
            bytes.extend_from_slice(b)
        });
        let mut d = lm_proto::FrameDecoder::new();
        match d.feed(&bytes) {
            lm_proto::FeedResult::Frame { frame, .. } => {
                assert_eq!(frame.seq, 9);
                match frame.message {
                    Message::SelfTestResult(t) => Ok(t),
                    Message::Nack(c) => Err(c),
                    m => panic!("{m:?}"),
                }
            }
            _ => panic!("no reply"),
        }
    };
    assert_eq!(
        run(&mut dev, &mut Loopback(None)),
        Ok(lm_proto::SelfTest::Passed { bytes: 1024 })
    );
    match run(&mut dev, &mut Loopback(Some(0xFF))) {
        Ok(lm_proto::SelfTest::Failed {
            bytes: 1024,
            first_mismatch: 0,
            sent: 0,
            got: 0xFF,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // Without an output (`handle`), and with a recorder: unsupported.
    assert_eq!(
        request(&mut dev, 3, &Message::SelfTest, 0),
        Reply::SelfTest(lm_proto::SelfTest::Unsupported)
    );
    assert_eq!(
        dev.handle(&Message::SelfTest, 0),
        Message::SelfTestResult(lm_proto::SelfTest::Unsupported)
    );
    acks(&mut dev, 4, &play_untracked(0), 0);
    assert_eq!(run(&mut dev, &mut Loopback(None)), Err(NackCode::Busy));
    acks(&mut dev, 5, &Message::Stop, 0);
    assert!(run(&mut dev, &mut Loopback(None)).is_ok());
}
