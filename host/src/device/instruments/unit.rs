//! Force units a gauge may be set to, and their exact conversions to
//! newtons (kgf and gf by standard gravity 9.80665 m/s², lbf by the
//! international avoirdupois pound: 0.45359237 kg × 9.80665 m/s²).

/// Newtons per kilogram-force (standard gravity).
pub const N_PER_KGF: f64 = 9.806_65;
/// Newtons per pound-force (0.45359237 kg × standard gravity).
pub const N_PER_LBF: f64 = 4.448_221_615_260_5;

/// A unit a force gauge reports in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum ForceUnit {
    /// Newton.
    N,
    /// Millinewton.
    MilliN,
    /// Kilonewton.
    KiloN,
    /// Gram-force.
    Gf,
    /// Kilogram-force.
    Kgf,
    /// Ounce-force (1/16 lbf).
    Ozf,
    /// Pound-force.
    Lbf,
    /// Kilopound-force.
    Klbf,
}

impl ForceUnit {
    /// Newtons in one of this unit.
    pub fn newtons(self) -> f64 {
        match self {
            Self::N => 1.0,
            Self::MilliN => 1e-3,
            Self::KiloN => 1e3,
            Self::Gf => N_PER_KGF * 1e-3,
            Self::Kgf => N_PER_KGF,
            Self::Ozf => N_PER_LBF / 16.0,
            Self::Lbf => N_PER_LBF,
            Self::Klbf => N_PER_LBF * 1e3,
        }
    }

    /// `value` in this unit, in newtons.
    pub fn to_newtons(self, value: f64) -> f64 {
        value * self.newtons()
    }

    /// The unit's usual symbol.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::N => "N",
            Self::MilliN => "mN",
            Self::KiloN => "kN",
            Self::Gf => "gf",
            Self::Kgf => "kgf",
            Self::Ozf => "ozf",
            Self::Lbf => "lbf",
            Self::Klbf => "klbf",
        }
    }

    /// A unit from its symbol, in any case (`lbF` as Mark-10 writes it,
    /// `kgf`, `N`); `None` for anything else.
    pub fn from_symbol(s: &str) -> Option<Self> {
        let all = [
            Self::N,
            Self::MilliN,
            Self::KiloN,
            Self::Gf,
            Self::Kgf,
            Self::Ozf,
            Self::Lbf,
            Self::Klbf,
        ];
        // "mN" and "MN" differ only in case; a force gauge never reports
        // meganewtons, so the case-insensitive match is safe.
        all.into_iter().find(|u| u.symbol().eq_ignore_ascii_case(s))
    }
}

impl std::fmt::Display for ForceUnit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.symbol())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_are_the_standard_ones() {
        assert_eq!(ForceUnit::N.to_newtons(1.25), 1.25);
        assert!((ForceUnit::Kgf.to_newtons(1.0) - 9.80665).abs() < 1e-12);
        assert!((ForceUnit::Lbf.to_newtons(1.0) - 4.4482216152605).abs() < 1e-12);
        assert!((ForceUnit::Ozf.to_newtons(16.0) - ForceUnit::Lbf.newtons()).abs() < 1e-12);
        assert!((ForceUnit::Gf.to_newtons(1000.0) - ForceUnit::Kgf.newtons()).abs() < 1e-12);
    }

    #[test]
    fn symbols_round_trip_in_any_case() {
        assert_eq!(ForceUnit::from_symbol("lbF"), Some(ForceUnit::Lbf));
        assert_eq!(ForceUnit::from_symbol("KGF"), Some(ForceUnit::Kgf));
        assert_eq!(ForceUnit::from_symbol("mN"), Some(ForceUnit::MilliN));
        assert_eq!(ForceUnit::from_symbol("psi"), None);
        assert_eq!(ForceUnit::from_symbol(""), None);
    }
}
