//! Errors of scene parsing and loading.

/// Every error of scene parsing and loading. `Display` is always one line that
/// names the file (and, where it applies, the field or `line:col`).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// TOML syntax error, unknown key, wrong type or missing key.
    #[error("{file}{}: {msg}", .line_col.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Toml {
        file: String,
        line_col: Option<(usize, usize)>,
        msg: String,
    },
    /// A value out of range (or not finite).
    #[error("{file}: {field}: {msg}")]
    Invalid {
        file: String,
        field: String,
        msg: String,
    },
    /// A file could not be read.
    #[error("{file}: cannot read: {msg}")]
    Io { file: String, msg: String },
    /// A glTF/GLB file could not be parsed or has no usable mesh.
    #[error("{file}: not a valid glTF file: {msg}")]
    Gltf { file: String, msg: String },
    /// An image could not be read or decoded.
    #[error("{file}: cannot decode image: {msg}")]
    Image { file: String, msg: String },
    /// An error while loading an asset named by a scene field.
    #[error("{file}: {field}: {source}")]
    Asset {
        file: String,
        field: String,
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
