//! Declaring wire enums from one table (in the manner of smoltcp's `wire`
//! modules).
//!
//! [`wire_enum!`] declares a one-byte enum: its variants, their wire bytes
//! and, where given, words for humans; it writes `ALL`, `from_u8`, `to_u8`
//! (and `describe`/`Display`) from that one table.

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

pub(crate) use wire_enum;

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
        assert_eq!(NackCode::ALL.len(), 15);
        assert_eq!(NackCode::Busy.to_string(), "device busy");
        assert_eq!(NackCode::Other(99).to_string(), "unknown nack code 99");
        for r in MuteReason::ALL {
            assert_eq!(r.to_string(), r.describe());
        }
    }
}
