//! Flag parsers the subcommands share: library enums offered as clap
//! values without the library knowing clap.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};

use crate::stream::filter::FilterKind;

/// `--filter`: one of [`FilterKind::ALL`] by name, with each one's help.
pub fn filter() -> impl TypedValueParser<Value = FilterKind> {
    PossibleValuesParser::new(
        FilterKind::ALL.map(|k| PossibleValue::new(k.name()).help(k.describe())),
    )
    .map(|name: String| {
        FilterKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .unwrap_or(FilterKind::Kalman)
    })
}
