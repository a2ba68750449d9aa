//! Errors that name the protocol file and, for a field, its line.

use std::ops::Range;

use crate::error::InputError;

/// Errors that name the protocol file and, for a field, its line.
pub(super) struct Errors<'a> {
    pub text: &'a str,
    pub origin: &'a str,
}

impl Errors<'_> {
    /// An error about the whole file.
    pub fn bad(&self, msg: impl std::fmt::Display) -> InputError {
        InputError::new(format!("study protocol {}: {msg}", self.origin))
    }

    /// An error about `field`, whose value starts at `span`: named by its
    /// whole path in the file (`question[1].points`), as a parse error
    /// names it, `field` where the path cannot be found.
    pub fn at(&self, span: Range<usize>, field: &str, msg: impl std::fmt::Display) -> InputError {
        let at = span.start.min(self.text.len());
        let line = crate::plan::scene::line_of(self.text, at);
        // The path of what sits at `span`, when that is `field` itself (a
        // span may be its table's, for a field that is missing).
        let path = crate::plan::scene::field_at(self.text, at).filter(|p| {
            let last = p.rsplit('.').next().unwrap_or(p);
            last.split('[').next() == Some(field)
        });
        let field = path.as_deref().unwrap_or(field);
        self.bad(format!("line {line}, field `{field}`: {msg}"))
    }

    /// The `name` of a `what` (a factor, a block), refused when one of
    /// `taken` already has it.
    pub fn unique<'n>(
        &self,
        what: &str,
        name: &toml::Spanned<super::file::Name>,
        mut taken: impl Iterator<Item = &'n str>,
    ) -> Result<String, InputError> {
        let n = &name.get_ref().0;
        if taken.any(|x| x == n) {
            return Err(self.at(name.span(), "name", format!("{what} `{n}` is given twice")));
        }
        Ok(n.clone())
    }
}
