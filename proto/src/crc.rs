//! CRC-32 (IEEE 802.3): reflected, polynomial 0xEDB88320, initial value and
//! final XOR 0xFFFF_FFFF. The same CRC as zlib, PNG and Ethernet;
//! `crc32(b"123456789") == 0xCBF4_3926`.
//!
//! Used twice on the wire: as the frame check (over header and payload) and
//! as the `Commit` check over a whole raw sequence.

/// Byte-wise lookup table, built at compile time.
const TABLE: [u32; 256] = make_table();

const fn make_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

/// Incremental CRC-32 hasher: feed pieces with [`Crc32::update`], read the
/// result with [`Crc32::finish`] (which does not consume, so a running
/// value can be read at any point).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc32 {
    state: u32,
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A hasher over the empty message.
    pub const fn new() -> Self {
        Self { state: 0xFFFF_FFFF }
    }

    /// Adds `bytes` to the message.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut c = self.state;
        for &b in bytes {
            c = TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
        }
        self.state = c;
    }

    /// Adds one byte to the message.
    pub fn update_byte(&mut self, b: u8) {
        self.state = TABLE[((self.state ^ b as u32) & 0xFF) as usize] ^ (self.state >> 8);
    }

    /// The CRC of everything fed so far.
    pub const fn finish(&self) -> u32 {
        self.state ^ 0xFFFF_FFFF
    }
}

/// CRC-32 (IEEE) of `bytes` in one call.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut h = Crc32::new();
    h.update(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-at-a-time reference, independent of the table.
    fn reference(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                let mask = (c & 1).wrapping_neg();
                c = (c >> 1) ^ (0xEDB8_8320 & mask);
            }
        }
        !c
    }

    #[test]
    fn check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        assert_eq!(crc32(&[0]), 0xD202_EF8D);
    }

    #[test]
    fn matches_bitwise_reference_and_is_incremental() {
        let data: [u8; 300] = core::array::from_fn(|i| (i * 37 + 11) as u8);
        for split in [0, 1, 7, 150, 299, 300] {
            let mut h = Crc32::new();
            h.update(&data[..split]);
            for &b in &data[split..] {
                h.update_byte(b);
            }
            assert_eq!(h.finish(), reference(&data));
        }
        assert_eq!(crc32(&data), reference(&data));
    }
}
