//! The camera settings files (intrinsics, the colour camera): TOML read
//! whole within the text-file limit, one line per error naming the file,
//! checked as a whole once parsed ([`SettingsFile`]).

use std::path::Path;

use crate::InputError;

/// `text` as a `what` settings value; TOML's message with its line and
/// field, as every TOML file lmhost reads says it.
fn parse<T: serde::de::DeserializeOwned>(
    what: &str,
    kind: &crate::files::kind::Kind,
    text: &str,
    origin: &str,
) -> Result<T, InputError> {
    crate::plan::scene::from_toml(text, kind)
        .map_err(|m| InputError::new(format!("{what} {origin}: {m}")))
}

/// The file at `path`, through `from_toml` (which parses and checks it).
fn load<T>(
    what: &str,
    path: &Path,
    from_toml: impl FnOnce(&str, &str) -> Result<T, InputError>,
) -> Result<T, InputError> {
    let text = crate::limits::read_text_file(what, path)?;
    from_toml(&text, &path.display().to_string())
}

/// A camera settings file: parsed, then checked as a whole.
pub trait SettingsFile: serde::Serialize + serde::de::DeserializeOwned {
    /// What it is called in errors (`intrinsics`).
    const WHAT: &'static str;

    /// Its kind among the files lmhost reads.
    const KIND: &'static crate::files::kind::Kind;

    /// Checks every value, and the values together (`origin` names the
    /// file or source in errors).
    fn check(&self, origin: &str) -> Result<(), InputError>;

    /// Parse and check TOML text.
    fn from_toml(text: &str, origin: &str) -> Result<Self, InputError> {
        let v: Self = parse(Self::WHAT, Self::KIND, text, origin)?;
        v.check(origin)?;
        Ok(v)
    }

    /// Read and check a file.
    fn load(path: &Path) -> Result<Self, InputError> {
        load(Self::WHAT, path, Self::from_toml)
    }

    /// The TOML text.
    fn to_toml(&self) -> String {
        toml::to_string(self).expect("settings serialise: plain numbers and strings")
    }
}
