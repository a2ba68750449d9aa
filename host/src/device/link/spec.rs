//! A sequence in the form the link uploads it ([`UploadSpec`]: the
//! header, the encoded bytes, the rig's positions) and what an upload did
//! ([`UploadReport`]).

use lm_proto::codec::CodecError;
use lm_proto::{
    BeginUpload, DeviceLimits, Encoding, HeaderError, Info, Positions, UploadHeader, rig_crc32,
};

use super::error::LinkError;
use crate::plan::sequence::{Plan, Sequence};

/// A sequence ready to upload, in wire units: the header, the bytes
/// [`Sequence::encode`] produced (sent as they are) and the positions of
/// the rig it was planned for.
#[derive(Debug, Clone, PartialEq)]
pub struct UploadSpec {
    /// What the slot will play (checked by [`UploadSpec::check_fits`]).
    pub header: UploadHeader,
    /// Encoding of `encoded`.
    pub encoding: Encoding,
    /// The encoded sequence stream.
    pub encoded: Vec<u8>,
    /// CRC-32 of the raw sequence, then the intensity table (the `Commit`
    /// value).
    pub crc32: u32,
    /// One intensity level per step (amplitude modulation), sent in
    /// `Intensity` frames; `None`: every step at the header's intensity.
    pub intensity_table: Option<Vec<u8>>,
    /// Transducer positions in drive coordinates (µm), one per transducer.
    pub positions_um: Vec<[i32; 3]>,
    /// CRC-32 of the positions table ([`lm_proto::rig_crc32`]).
    pub rig_crc32: u32,
}

impl UploadSpec {
    /// `sequence` encoded as `encoding`, with its transducers' positions.
    /// Delta falls back to Raw for a sequence it would not shrink (a few
    /// large steps, e.g. 4 mm at 25 Hz): fewer bytes on the wire, and the
    /// device keeps such an entry raw anyway.
    pub fn new(
        sequence: &Sequence,
        positions_um: Vec<[i32; 3]>,
        encoding: Encoding,
    ) -> Result<Self, LinkError> {
        let steps = usize::from(sequence.header.steps);
        if positions_um.len() != usize::from(sequence.header.transducers)
            || sequence
                .intensity_table
                .as_ref()
                .is_some_and(|t| t.len() != steps)
        {
            return Err(LinkError::Codec(CodecError::BadShape));
        }
        let mut encoded = sequence.encode(encoding)?;
        let mut encoding = encoding;
        if encoding == Encoding::Delta && encoded.len() as u64 > sequence.header.raw_len() {
            encoded = sequence.encode(Encoding::Raw)?;
            encoding = Encoding::Raw;
        }
        Ok(Self {
            header: sequence.header,
            encoding,
            encoded,
            crc32: sequence.crc32(),
            intensity_table: sequence.intensity_table.clone(),
            rig_crc32: rig_crc32(&Positions::from_points(&positions_um)),
            positions_um,
        })
    }

    /// A plan's sequence and scene positions, encoded as `encoding`.
    pub fn from_plan(plan: &Plan, encoding: Encoding) -> anyhow::Result<Self> {
        Ok(Self::new(&plan.sequence, plan.positions_um()?, encoding)?)
    }

    /// The `BeginUpload` of this sequence into `slot`.
    pub fn begin(&self, slot: u8) -> BeginUpload {
        BeginUpload {
            slot,
            header: self.header,
            encoding: self.encoding,
            encoded_len: self.encoded.len().min(u32::MAX as usize) as u32,
            rig_crc32: self.rig_crc32,
            intensity_table: self.intensity_table.is_some(),
        }
    }

    /// Whether it fits `info`'s device in `slot`: the device's own check
    /// ([`BeginUpload::validate`]), run before sending anything.
    pub fn check_fits(&self, info: &Info, slot: u8) -> Result<(), HeaderError> {
        self.begin(slot).validate(&DeviceLimits::from_info(info))
    }
}

/// What an upload did.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct UploadReport {
    /// Slot written.
    pub slot: u8,
    /// Raw sequence bytes.
    pub raw_bytes: u64,
    /// Encoded sequence bytes (the chunks' data).
    pub sequence_bytes: u64,
    /// Rig positions sent with this upload (12 bytes each); 0 when the
    /// device already held the rig.
    pub rig_bytes: u64,
    /// Useful bytes sent: the encoded sequence plus any rig positions.
    pub payload_bytes: u64,
    /// All bytes written to the wire during the upload (frames, resends).
    pub wire_bytes_sent: u64,
    /// All bytes read from the wire during the upload.
    pub wire_bytes_received: u64,
    /// Wall time (s).
    pub seconds: f64,
    /// CRC-32 of the raw sequence, as the device confirmed.
    pub crc32: u32,
    /// Resends during the upload.
    pub retries: u64,
    /// Whole-upload restarts.
    pub restarts: u64,
}

impl UploadReport {
    /// Payload bytes over all wire bytes in both directions.
    pub fn wire_efficiency(&self) -> f64 {
        self.payload_bytes as f64 / (self.wire_bytes_sent + self.wire_bytes_received).max(1) as f64
    }
}
