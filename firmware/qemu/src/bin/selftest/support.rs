//! What the test groups share: a fresh device over one static store, the
//! test layout and sequence, upload and message helpers, a frame recorder.

use lm_fw_core::{Device, OutputDriver, OutputFrame};
use lm_fw_qemu::{ARRAY_TRANSDUCERS, STORE_BYTES, Timer, config};
use lm_proto::{
    BeginRig, BeginUpload, Centroid, Chunk, Commit, Crc32, Encoding, Geometry, MAX_CHUNK,
    MAX_GEOMETRY_POSITIONS, Message, POSITION_LEN, Play, PlayAt, Positions, UploadHeader,
};
use static_cell::ConstStaticCell;

/// Sequence memory for the devices the tests build (one at a time): taken
/// once by `main`, lent to each test.
pub static STORE: ConstStaticCell<[u8; STORE_BYTES]> = ConstStaticCell::new([0; STORE_BYTES]);

/// A fresh device over `mem` (the test's loan of [`STORE`]).
pub fn device(mem: &mut [u8]) -> Device<'_> {
    match Device::new(config(), mem) {
        Ok(d) => d,
        Err(e) => panic!("device setup: {e}"),
    }
}

/// Test transducer layout: a 36 × 28 grid at AUTD3's 10.16 mm pitch, µm.
pub fn position_um(i: usize) -> [i32; 3] {
    let (x, y) = ((i % 36) as i32, (i / 36) as i32);
    [(2 * x - 35) * 5_080, (2 * y - 27) * 5_080, 0]
}

/// Test sequence: phase of transducer `i` at step `s`.
pub fn phase(s: usize, i: usize) -> u8 {
    (s * 37 + i * 13 + (i * i) / 7) as u8
}

/// Planned centre of the test sequences: 150 mm above the array.
pub const CENTER_UM: [i32; 3] = [0, 0, 150_000];

/// Speed of sound the test sequences are uploaded with (20 °C air rather
/// than the usual 340 m/s), so the correction check shows the core uses the
/// uploaded value.
pub const SOUND_SPEED_MM_S: u32 = 343_200;

/// CRC-32 of the test rig's first `t` positions.
pub fn rig_crc32(t: usize) -> u32 {
    let mut crc = Crc32::new();
    for i in 0..t {
        let mut rec = [0u8; POSITION_LEN];
        for (d, c) in rec.chunks_exact_mut(4).zip(position_um(i)) {
            d.copy_from_slice(&c.to_le_bytes());
        }
        crc.update(&rec);
    }
    crc.finish()
}

/// Sends the test rig of `t` transducers (acked again when the device
/// holds it already); returns the first reply that is not an ack.
pub fn rig(dev: &mut Device<'_>, t: usize) -> Message<'static> {
    let begin = BeginRig {
        transducers: t as u16,
        crc32: rig_crc32(t),
    };
    let r = dev.handle(&Message::BeginRig(begin), 0);
    if r != Message::Ack {
        return r;
    }
    let mut pts = [[0i32; 3]; MAX_GEOMETRY_POSITIONS];
    for first in (0..t).step_by(MAX_GEOMETRY_POSITIONS) {
        let n = (t - first).min(MAX_GEOMETRY_POSITIONS);
        for (j, p) in pts[..n].iter_mut().enumerate() {
            *p = position_um(first + j);
        }
        let g = Geometry {
            first: first as u16,
            positions: Positions::from_points(&pts[..n]),
        };
        let r = dev.handle(&Message::Geometry(g), 0);
        if r != Message::Ack {
            return r;
        }
    }
    dev.handle(&Message::CommitRig, 0)
}

/// The header of a test sequence of `steps` × `t`.
pub fn header(steps: usize, t: usize, period_us: u32) -> UploadHeader {
    UploadHeader {
        steps: steps as u16,
        transducers: t as u16,
        period_us,
        center_um: CENTER_UM,
        foci_per_step: 1,
        sound_speed_mm_s: SOUND_SPEED_MM_S,
        max_offset_um: 20_000,
        intensity: 255,
    }
}

/// `Ok` for an ack, else the reply: requests sent in a row stop at the
/// first refusal with `?`.
pub fn acked(reply: Message<'static>) -> Result<(), Message<'static>> {
    if reply == Message::Ack {
        Ok(())
    } else {
        Err(reply)
    }
}

/// Sends the test rig for `header`'s transducers, then `BeginUpload` into
/// `slot` of `encoded_len` bytes; `Err` holds the first reply that is not
/// an ack.
pub fn begin_upload(
    dev: &mut Device<'_>,
    slot: u8,
    header: UploadHeader,
    encoding: Encoding,
    encoded_len: usize,
    intensity_table: bool,
) -> Result<(), Message<'static>> {
    let t = usize::from(header.transducers);
    acked(rig(dev, t))?;
    let begin = BeginUpload {
        slot,
        header,
        encoding,
        encoded_len: encoded_len as u32,
        rig_crc32: rig_crc32(t),
        intensity_table,
    };
    acked(dev.handle(&Message::BeginUpload(begin), 0))
}

/// Sends `data` at `offset` of `slot`'s encoded stream.
fn chunk(
    dev: &mut Device<'_>,
    slot: u8,
    offset: usize,
    data: &[u8],
) -> Result<(), Message<'static>> {
    let c = Chunk {
        slot,
        offset: offset as u32,
        data,
    };
    acked(dev.handle(&Message::Chunk(c), 0))
}

/// Sends the test sequence's phases (Raw, `steps` × `t`, built chunk by
/// chunk: no buffer of the whole) into `slot`; returns their CRC-32 so
/// far, for the commit.
pub fn send_raw_phases(
    dev: &mut Device<'_>,
    slot: u8,
    steps: usize,
    t: usize,
) -> Result<Crc32, Message<'static>> {
    let mut crc = Crc32::new();
    let mut buf = [0u8; MAX_CHUNK];
    let total = steps * t;
    for offset in (0..total).step_by(MAX_CHUNK) {
        let n = (total - offset).min(MAX_CHUNK);
        for (j, b) in buf[..n].iter_mut().enumerate() {
            let k = offset + j;
            *b = phase(k / t, k % t);
        }
        crc.update(&buf[..n]);
        chunk(dev, slot, offset, &buf[..n])?;
    }
    Ok(crc)
}

/// Commits the upload into `slot`; returns the reply.
pub fn commit(dev: &mut Device<'_>, slot: u8, crc32: u32) -> Message<'static> {
    dev.handle(&Message::Commit(Commit { slot, crc32 }), 0)
}

/// Uploads an encoded `stream` into `slot` after the rig; returns the
/// first reply that is not an ack (or the commit's).
pub fn upload_stream(
    dev: &mut Device<'_>,
    slot: u8,
    header: UploadHeader,
    encoding: Encoding,
    stream: &[u8],
    crc32: u32,
) -> Message<'static> {
    let sent = begin_upload(dev, slot, header, encoding, stream.len(), false).and_then(|()| {
        stream
            .chunks(MAX_CHUNK)
            .enumerate()
            .try_for_each(|(i, data)| chunk(dev, slot, i * MAX_CHUNK, data))
    });
    sent.map_or_else(|r| r, |()| commit(dev, slot, crc32))
}

/// Uploads the test sequence (Raw, `steps` × `t`) into `slot` after the
/// rig; returns the commit's reply. `corrupt` flips the commit CRC.
pub fn upload(
    dev: &mut Device<'_>,
    slot: u8,
    steps: usize,
    t: usize,
    period_us: u32,
    corrupt: bool,
) -> Message<'static> {
    let h = header(steps, t, period_us);
    let sent = begin_upload(dev, slot, h, Encoding::Raw, steps * t, false)
        .and_then(|()| send_raw_phases(dev, slot, steps, t));
    sent.map_or_else(
        |r| r,
        |crc| commit(dev, slot, crc.finish() ^ u32::from(corrupt)),
    )
}

pub fn play_now(slot: u8) -> Message<'static> {
    Message::Play(Play {
        slot,
        at: PlayAt::Immediate,
        untracked: false,
        steps: 0,
        lease_ms: lm_proto::DEFAULT_LEASE_MS,
    })
}

/// An untracked play of `slot` with a `lease_ms` host lease.
pub fn play_leased(slot: u8, lease_ms: u16) -> Message<'static> {
    Message::Play(Play {
        slot,
        at: PlayAt::Immediate,
        untracked: true,
        steps: 0,
        lease_ms,
    })
}

pub fn centroid(seq: u32, pos_um: [i32; 3], present: bool) -> Message<'static> {
    Message::Centroid(Centroid {
        seq,
        pos_um,
        present,
        host_time_us: 0,
    })
}

/// Keeps the frames a test looks at: due time, time written (TIMER0),
/// step, amplitude, and the phases of the last frame.
pub struct Recorder<'t> {
    timer: &'t Timer,
    pub n: usize,
    pub due: [u64; 64],
    pub written: [u32; 64],
    pub step: [u16; 64],
    pub amplitude: [u8; 64],
    pub phases: [u8; ARRAY_TRANSDUCERS as usize],
}

impl<'t> Recorder<'t> {
    pub fn new(timer: &'t Timer) -> Self {
        Recorder {
            timer,
            n: 0,
            due: [0; 64],
            written: [0; 64],
            step: [0; 64],
            amplitude: [0; 64],
            phases: [0; ARRAY_TRANSDUCERS as usize],
        }
    }
}

impl OutputDriver for Recorder<'_> {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), Self::Error> {
        let written = self.timer.now();
        if self.n < self.due.len() {
            self.due[self.n] = f.due;
            self.written[self.n] = written;
            self.step[self.n] = f.step;
            self.amplitude[self.n] = f.amplitude;
        }
        self.n += 1;
        self.phases[..f.phases.len()].copy_from_slice(f.phases);
        Ok(())
    }
}
