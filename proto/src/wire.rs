//! Declaring wire enums and payload layouts, each from one table (in the
//! manner of smoltcp's `wire` modules).
//!
//! [`wire_enum!`] declares a one-byte enum: its variants, their wire bytes
//! and, where given, words for humans; it writes `ALL`, `from_u8`, `to_u8`
//! (and `describe`/`Display`) from that one table. [`layout!`] declares a
//! payload's fields as byte ranges and derives the payload length from the
//! last field's end, after checking at compile time that the fields tile
//! `0..LEN` without gaps or overlaps.

/// Byte range of one payload field.
pub type Field = core::ops::Range<usize>;

/// The end of the last of `fields`, which must follow each other from
/// offset 0 with no gap or overlap (checked when the constant is built, so
/// a bad layout does not compile).
pub(crate) const fn tiled_len(fields: &[Field]) -> usize {
    let mut end = 0;
    let mut i = 0;
    while i < fields.len() {
        assert!(
            fields[i].start == end,
            "payload fields must follow each other"
        );
        assert!(fields[i].end > fields[i].start, "payload field is empty");
        end = fields[i].end;
        i += 1;
    }
    end
}

/// True if `bytes` holds no value twice.
pub(crate) const fn distinct(bytes: &[u8]) -> bool {
    let mut i = 0;
    while i < bytes.len() {
        let mut j = i + 1;
        while j < bytes.len() {
            if bytes[i] == bytes[j] {
                return false;
            }
            j += 1;
        }
        i += 1;
    }
    true
}

/// Declares a wire enum from one table of variants and wire bytes, with the
/// derives every wire enum has (`Clone, Copy, Debug, PartialEq, Eq, Hash`,
/// `defmt::Format` and serde behind their features, `#[non_exhaustive]`);
/// extra attributes (`#[derive(Default)]`, serde renames) pass through.
///
/// - `Variant = byte,` for every variant: a closed `#[repr(u8)]` enum with
///   `ALL`, `from_u8(u8) -> Option<Self>` and `to_u8`.
/// - `Variant = byte => "words",` for every variant: the same plus
///   `describe() -> &'static str` and `Display`.
/// - `... } else { Other(u8) => "unknown ... {}", }`: an open enum that
///   keeps unknown bytes in `Other`; `from_u8(u8) -> Self`, and `Display`
///   formats an unknown byte with the given string.
macro_rules! wire_enum {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $byte:literal => $desc:literal, )+
        } else {
            $(#[$ometa:meta])* $other:ident(u8) => $unknown:literal,
        }
    ) => {
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
        #[non_exhaustive]
        $(#[$meta])*
        pub enum $name {
            $( $(#[$vmeta])* $variant, )+
            $(#[$ometa])* $other(u8),
        }

        const _: () = assert!(
            $crate::wire::distinct(&[$($byte),+]),
            concat!(stringify!($name), ": a wire byte is listed twice"),
        );

        impl $name {
            /// Every known value, in table order (without the unknown one).
            pub const ALL: [Self; [$($byte),+].len()] = [$(Self::$variant),+];

            /// The wire byte.
            pub fn to_u8(self) -> u8 {
                match self {
                    $( Self::$variant => $byte, )+
                    Self::$other(b) => b,
                }
            }

            /// The value for a wire byte (unknown bytes are kept in
            #[doc = concat!("[`", stringify!($name), "::", stringify!($other), "`]).")]
            pub fn from_u8(b: u8) -> Self {
                match b {
                    $( $byte => Self::$variant, )+
                    b => Self::$other(b),
                }
            }
        }

        impl core::fmt::Display for $name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                match *self {
                    $( Self::$variant => f.write_str($desc), )+
                    Self::$other(b) => write!(f, $unknown, b),
                }
            }
        }
    };
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $byte:literal => $desc:literal, )+
        }
    ) => {
        $crate::wire::wire_enum! {
            $(#[$meta])*
            pub enum $name { $( $(#[$vmeta])* $variant = $byte, )+ }
        }

        impl $name {
            /// Words for humans.
            pub fn describe(self) -> &'static str {
                match self {
                    $( Self::$variant => $desc, )+
                }
            }
        }

        impl core::fmt::Display for $name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str(self.describe())
            }
        }
    };
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $byte:literal, )+
        }
    ) => {
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
        #[non_exhaustive]
        #[repr(u8)]
        $(#[$meta])*
        pub enum $name {
            $( $(#[$vmeta])* $variant = $byte, )+
        }

        impl $name {
            /// Every value this version knows, in table order.
            pub const ALL: [Self; [$($byte),+].len()] = [$(Self::$variant),+];

            /// The wire byte.
            pub fn to_u8(self) -> u8 {
                self as u8
            }

            /// The value for a wire byte, if this version knows it.
            pub fn from_u8(b: u8) -> Option<Self> {
                match b {
                    $( $byte => Some(Self::$variant), )+
                    _ => None,
                }
            }
        }
    };
}

/// Declares a payload layout: a module of [`Field`] constants in wire
/// order, and `LEN`, the end of the last one (the whole payload for fixed
/// messages, the fixed head for variable ones). The fields must tile
/// `0..LEN`, or the crate does not compile.
macro_rules! layout {
    (
        $(#[$meta:meta])*
        pub mod $name:ident {
            $( $(#[$fmeta:meta])* $field:ident = $range:expr, )+
        }
    ) => {
        $(#[$meta])*
        pub mod $name {
            use $crate::wire::Field;
            $( $(#[$fmeta])* pub const $field: Field = $range; )+
            /// Bytes up to the end of the last field.
            pub const LEN: usize = $crate::wire::tiled_len(&[$($field),+]);
        }
    };
}

pub(crate) use {layout, wire_enum};

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use crate::{DeviceState, Encoding, MessageType, MuteReason, NackCode, PlayAt};

    /// Every byte maps to at most one value and back; `ALL` lists exactly
    /// the known ones.
    macro_rules! check_closed {
        ($($t:ty),+) => {$(
            let known = (0..=255u8).filter_map(<$t>::from_u8).count();
            assert_eq!(known, <$t>::ALL.len(), stringify!($t));
            for v in <$t>::ALL {
                assert_eq!(<$t>::from_u8(v.to_u8()), Some(v));
            }
        )+};
    }

    #[test]
    fn tables_round_trip() {
        check_closed!(MessageType, Encoding, PlayAt, DeviceState, MuteReason);
        assert_eq!(MessageType::Status as u8, MessageType::Status.to_u8());
        for b in 0..=255u8 {
            let c = NackCode::from_u8(b);
            assert_eq!(c.to_u8(), b);
            assert_eq!(NackCode::ALL.contains(&c), !matches!(c, NackCode::Other(_)));
        }
        assert_eq!(NackCode::ALL.len(), 18);
        assert_eq!(NackCode::Busy.to_string(), "device busy");
        assert_eq!(NackCode::Other(99).to_string(), "unknown nack code 99");
        for r in MuteReason::ALL {
            assert_eq!(r.to_string(), r.describe());
        }
    }

    /// The derived lengths are the ones SPEC section 3 states.
    #[test]
    fn lengths_are_the_spec_ones() {
        use crate::{HEADER_LEN, len};
        let got = [
            HEADER_LEN,
            len::BEGIN_UPLOAD,
            len::BEGIN_RIG,
            len::GEOMETRY_HEAD,
            len::CHUNK_HEAD,
            len::INTENSITY_HEAD,
            len::COMMIT,
            len::PLAY,
            len::CENTROID,
            len::NACK,
            len::INFO,
            len::STATUS,
            len::SELF_TEST_RESULT,
            len::ECHO,
        ];
        assert_eq!(got, [4, 41, 6, 2, 5, 3, 5, 9, 25, 1, 32, 52, 15, 5]);
    }
}
