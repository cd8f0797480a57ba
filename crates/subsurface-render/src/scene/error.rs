//! Errors of scene parsing and loading.

/// Every error of scene parsing and loading. `Display` is always one line that
/// names the file (and, where it applies, the field or `line:col`).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// TOML syntax error, unknown key, wrong type or missing key.
    #[error("{file}{}: {msg}", .line_col.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Toml {
        /// The scene file.
        file: String,
        /// Line and column of the error, 1-based, where the parser gave them.
        line_col: Option<(usize, usize)>,
        /// The parser's message, on one line.
        msg: String,
    },
    /// A value out of range (or not finite).
    #[error("{file}: {field}: {msg}")]
    Invalid {
        /// The scene file.
        file: String,
        /// The key at fault (`objects[0].mm_per_unit`).
        field: String,
        /// What was wrong, with the value given.
        msg: String,
    },
    /// A file could not be read.
    #[error("{file}: cannot read: {msg}")]
    Io {
        /// The file that could not be read.
        file: String,
        /// Why, on one line.
        msg: String,
    },
    /// A glTF/GLB file could not be parsed or has no usable mesh.
    #[error("{file}: not a valid glTF file: {msg}")]
    Gltf {
        /// The glTF or GLB file.
        file: String,
        /// Why, on one line.
        msg: String,
    },
    /// An image could not be read or decoded.
    #[error("{file}: cannot decode image: {msg}")]
    Image {
        /// The image file.
        file: String,
        /// Why, on one line.
        msg: String,
    },
    /// An error while loading an asset named by a scene field.
    #[error("{file}: {field}: {source}")]
    Asset {
        /// The scene file.
        file: String,
        /// The key that names the asset (`objects[0].mesh`).
        field: String,
        /// The asset's own error.
        source: Box<SceneError>,
    },
}

/// Flattens a possibly multi-line message into one line.
pub fn one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}
