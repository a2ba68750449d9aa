//! The camera settings files (intrinsics, the colour camera): TOML read
//! whole within the text-file limit, one line per error naming the file.

use std::path::Path;

use crate::InputError;

/// `text` as a `what` settings value; the first line of TOML's message.
pub(crate) fn parse<T: serde::de::DeserializeOwned>(
    what: &str,
    text: &str,
    origin: &str,
) -> Result<T, InputError> {
    toml::from_str(text).map_err(|e| {
        InputError::new(format!(
            "{what} {origin}: {}",
            e.message().lines().next().unwrap_or("invalid TOML")
        ))
    })
}

/// The file at `path`, through `from_toml` (which parses and checks it).
pub(crate) fn load<T>(
    what: &str,
    path: &Path,
    from_toml: impl FnOnce(&str, &str) -> Result<T, InputError>,
) -> Result<T, InputError> {
    let text = crate::limits::read_text_file(what, path)?;
    from_toml(&text, &path.display().to_string())
}
