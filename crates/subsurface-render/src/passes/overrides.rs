//! The WGSL overrides that specialize the lighting shader's pipelines (lighting.wgsl,
//! transmittance.wgsl, lateral.wgsl): one pipeline per value, so that the shader compiler drops
//! the other values' code. Each name is declared here once and read by every pass that builds
//! on the lighting shader.

use crate::settings::TransmittanceMethod;

/// Fixes a pipeline's transmittance method (`TransmittanceMethod::code`).
pub const TRANSMITTANCE_METHOD: &str = "TRANSMITTANCE_METHOD";
/// Fixes where a pipeline's `diffusion` takes its lateral light from
/// (`frame_plan::LightingVariant::lateral`; 2: the taps per pixel, 3: the taps' sum given by
/// the texel's lanes in the lateral map's compute evaluation).
pub const LATERAL_SOURCE: &str = "LATERAL_SOURCE";
/// Fixes where a pipeline's pixels take the bounce from (`frame_plan::LightingVariant::bounce`).
pub const BOUNCE_SOURCE: &str = "BOUNCE_SOURCE";

/// `diffusion` evaluated whole, the lateral taps included: the lateral map's passes.
pub const DIFFUSION_WHOLE: [(&str, f64); 2] = [
    (
        TRANSMITTANCE_METHOD,
        TransmittanceMethod::Diffusion.code() as f64,
    ),
    (LATERAL_SOURCE, 2.0),
];
