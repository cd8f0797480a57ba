use thiserror::Error;

/// Errors of the renderer. Each `Display` is a single line that names what was wrong, so a
/// command-line tool can print it as it is.
#[derive(Debug, Error)]
pub enum RenderError {
    #[error(
        "no GPU adapter found (WGPU_BACKEND={backend}, WGPU_ADAPTER_NAME={name}); on Linux install a Vulkan driver, e.g. `apt-get install mesa-vulkan-drivers` for lavapipe"
    )]
    NoAdapter { backend: String, name: String },
    #[error("could not create the GPU device on {adapter}: {message}")]
    Device { adapter: String, message: String },
    #[error("{field}: {message}")]
    Invalid { field: String, message: String },
    #[error("wgpu validation error: {0}")]
    Validation(String),
    #[error("GPU readback failed: {0}")]
    Readback(String),
    #[error(transparent)]
    Scene(#[from] crate::scene::error::SceneError),
    #[error(transparent)]
    Profile(#[from] subsurface_profile::ProfileError),
}

impl From<crate::settings::InvalidSetting> for RenderError {
    fn from(e: crate::settings::InvalidSetting) -> Self {
        RenderError::Invalid {
            field: e.field,
            message: e.message,
        }
    }
}

impl RenderError {
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        RenderError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Collapses wgpu's multi-line error reports into one line for the user.
pub(crate) fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}
