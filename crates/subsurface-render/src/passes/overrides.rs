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

/// Which optional terms a pipeline evaluates ([`Terms`]).
pub const DIFFUSION_TERMS: &str = "DIFFUSION_TERMS";

/// The optional terms of the lighting shader, a bit each (`DIFFUSION_TERMS` in
/// shadow_lookup.wgsl): each costs shader time and buys fidelity, so quality presets switch
/// them (`settings::Quality`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Terms(pub u32);

impl Terms {
    /// `diffusion`'s unscattered lobe (`ballistic_transmittance`).
    pub const BALLISTIC: u32 = 1;
    /// `diffusion`'s single scattering (`single_scattering`).
    pub const SINGLE_SCATTERING: u32 = 2;
    /// The diffusion source's shadow along the refracted ray (`source_shadow`).
    pub const SOURCE_SHIFT: u32 = 4;
    pub const ALL: Self = Self(7);

    /// The terms `settings` asks for.
    pub fn of(settings: &crate::settings::RenderSettings) -> Self {
        let t = &settings.transmittance;
        let bit = |on: bool, b: u32| if on { b } else { 0 };
        Self(
            bit(t.ballistic, Self::BALLISTIC)
                | bit(t.single_scattering, Self::SINGLE_SCATTERING)
                | bit(settings.sss.source_shift, Self::SOURCE_SHIFT),
        )
    }
}

/// `diffusion` evaluated whole with `terms`, the lateral taps included (LATERAL_SOURCE 2, or
/// `lateral` given): the lateral map's passes.
pub fn diffusion_whole(terms: Terms, lateral: f64) -> [(&'static str, f64); 3] {
    [
        (
            TRANSMITTANCE_METHOD,
            TransmittanceMethod::Diffusion.code() as f64,
        ),
        (LATERAL_SOURCE, lateral),
        (DIFFUSION_TERMS, f64::from(terms.0)),
    ]
}
