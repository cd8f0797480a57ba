//! The renderer's error type.

use thiserror::Error;

/// Errors of the renderer. Each `Display` is a single line that names what was wrong, so a
/// command-line tool can print it as it is.
#[derive(Debug, Error)]
pub enum RenderError {
    /// No GPU adapter was found, or none whose name contains `WGPU_ADAPTER_NAME`.
    #[error(
        "no GPU adapter found (WGPU_BACKEND={backend}, WGPU_ADAPTER_NAME={name}); on Linux install a Vulkan driver, e.g. `apt-get install mesa-vulkan-drivers` for lavapipe"
    )]
    NoAdapter {
        /// `WGPU_BACKEND`, empty when unset.
        backend: String,
        /// `WGPU_ADAPTER_NAME`, empty when unset.
        name: String,
    },
    /// The adapter could not create a device.
    #[error("could not create the GPU device on {adapter}: {message}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason, on one line.
        message: String,
    },
    /// A setting or input out of its range, or not supported by the device.
    #[error("{field}: {message}")]
    Invalid {
        /// The setting, scene key or flag at fault (`render.width`, `lights`).
        field: String,
        /// What was wrong, on one line.
        message: String,
    },
    /// An error wgpu raised since the last [`crate::GpuContext::check`] (validation, out of
    /// memory), or a GPU profiler that could not be created.
    #[error("wgpu validation error: {0}")]
    Validation(String),
    /// Copying a texture back to the CPU failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
    /// The scene file or its assets could not be read or are invalid.
    #[error(transparent)]
    Scene(#[from] crate::scene::error::SceneError),
    /// A profile, kernel or medium could not be built from the material's parameters.
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
    /// [`RenderError::Invalid`] for `field`.
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
