//! The WGSL overrides that specialize the lighting shader's pipelines (lighting.wgsl,
//! transmittance.wgsl, transmitted_map.wgsl): one pipeline per value, so that the shader compiler drops
//! the other values' code. Each name is declared here once and read by every pass that builds
//! on the lighting shader.

use crate::settings::TransmittanceMethod;

/// Fixes a pipeline's transmittance method (`TransmittanceMethod::code`).
pub const TRANSMITTANCE_METHOD: &str = "TRANSMITTANCE_METHOD";
/// Fixes where a pipeline's `diffusion` takes its lateral light from
/// (`frame_plan::LightingVariant::lateral`; 2: the taps per pixel, 3: the taps' sum given by
/// the texel's lanes in the transmitted map's compute evaluation).
pub const LATERAL_SOURCE: &str = "LATERAL_SOURCE";
/// Leaves each light's chord at the pixels the transmitted map misses to the outline pass
/// (`frame_plan::LightingVariant::outline_pass`; lighting.wgsl, outline.wgsl).
pub const OUTLINE_PASS: &str = "OUTLINE_PASS";
/// Writes the thickness instead of the diffuse light (`DebugView::Thickness`;
/// `frame_plan::LightingVariant::thickness_view`). A constant rather than a uniform: a CPU
/// rasteriser runs a branch's code whether or not a pixel takes it, and the view's thickness
/// lookups cost every frame of every view 14 ms of the default scene's 1280x720 lighting pass on
/// lavapipe (docs/lab/performance.md, session 39).
pub const THICKNESS_VIEW: &str = "THICKNESS_VIEW";
/// Fixes where a pipeline's pixels take the bounce from (`frame_plan::LightingVariant::bounce`).
pub const BOUNCE_SOURCE: &str = "BOUNCE_SOURCE";

/// The value an override is left at to follow the uniform at run time (`FOLLOW_UNIFORM` in
/// ids.wgsl): the texture-space pass builds one pipeline for every frame shape.
pub const FOLLOW_UNIFORM: u32 = 255;

/// Values of `LATERAL_SOURCE` ([`crate::frame_plan::LightingVariant::lateral`]; `LATERAL_*`
/// in ids.wgsl): where `diffusion` takes its lateral light from.
pub mod lateral {
    /// No lateral light (another method, or no taps).
    pub const NONE: u32 = 0;
    /// The transmitted map (the lights' chords per pixel only where the map has no texel of the
    /// pixel's surface).
    pub const MAP: u32 = 1;
    /// The taps per pixel.
    pub const TAPS: u32 = 2;
    /// The taps' sum given by the texel's lanes (the transmitted map's compute evaluation).
    pub const GIVEN: u32 = 3;
}

/// Values of `BOUNCE_SOURCE` ([`crate::frame_plan::LightingVariant::bounce`]; `BOUNCE_*` in
/// ids.wgsl): where a pixel takes the bounce from.
pub mod bounce {
    /// No bounce.
    pub const NONE: u32 = 0;
    /// The transmitted map's bounce layer.
    pub const MAP: u32 = 1;
    /// A gather per pixel (no map).
    pub const GATHER: u32 = 2;
}

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
    /// Thin parts lit from the front reflect what their far face does not let out
    /// (lighting.wgsl `thin_part_reflectance`, from the back faces' depth).
    pub const THIN_PARTS: u32 = 8;
    /// The side walls of a part narrower than the light's spread take their share of the
    /// chord's and the lateral taps' light (side_walls.wgsl `side_wall_share`).
    pub const SIDE_WALLS: u32 = 16;
    /// A point the light reaches takes the light of the beam beneath it beyond the
    /// half-space's (lit_side.wgsl `lit_side_light`).
    pub const LIT_SIDE: u32 = 32;
    /// Every term.
    pub const ALL: Self = Self(63);

    /// The terms `settings` asks for.
    pub fn of(settings: &crate::settings::RenderSettings) -> Self {
        let t = &settings.transmittance;
        let bit = |on: bool, b: u32| if on { b } else { 0 };
        Self(
            bit(t.ballistic, Self::BALLISTIC)
                | bit(t.single_scattering, Self::SINGLE_SCATTERING)
                | bit(t.side_walls, Self::SIDE_WALLS)
                | bit(t.lit_side, Self::LIT_SIDE)
                // Without a blur the shift has nothing to feed (the shader tests it at run time
                // too), but code a pipeline holds costs even where it does not run: on
                // llvmpipe, whose branches mask rather than jump, the unreached lookups were a
                // third of the lighting pass of a frame without scattering.
                | bit(
                    settings.sss.source_shift
                        && settings.sss.method != crate::settings::SssMethod::None,
                    Self::SOURCE_SHIFT,
                )
                // Texture-space diffusion lights its UV maps without the screen's back faces.
                | bit(
                    settings.sss.thin_parts
                        && settings.sss.method != crate::settings::SssMethod::Texture,
                    Self::THIN_PARTS,
                ),
        )
    }
}

/// `diffusion` evaluated whole with `terms`, the lateral taps included (LATERAL_SOURCE 2, or
/// `lateral` given): the transmitted map's passes.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::TransmittanceMethod;

    /// The constants ids.wgsl declares, by name.
    fn wgsl_ids() -> std::collections::HashMap<String, u32> {
        let module = naga::front::wgsl::parse_str(include_str!("ids.wgsl")).unwrap();
        module
            .constants
            .iter()
            .map(|(_, c)| {
                let value = match module.global_expressions[c.init] {
                    naga::Expression::Literal(naga::Literal::U32(v)) => v,
                    ref e => panic!("{:?}: not a u32 literal: {e:?}", c.name),
                };
                (c.name.clone().unwrap(), value)
            })
            .collect()
    }

    /// Every id the shaders compare against is the one the Rust side writes.
    #[test]
    fn shader_ids_match_the_rust_side() {
        let ids = wgsl_ids();
        let methods = [
            ("TRANSMITTANCE_OFF", TransmittanceMethod::Off),
            ("TRANSMITTANCE_PAPER", TransmittanceMethod::Paper),
            ("TRANSMITTANCE_BEER", TransmittanceMethod::Beer),
            ("TRANSMITTANCE_SEED_REPORT", TransmittanceMethod::SeedReport),
            ("TRANSMITTANCE_TSM", TransmittanceMethod::Tsm),
            ("TRANSMITTANCE_DIFFUSION", TransmittanceMethod::Diffusion),
        ];
        let mut expected: Vec<(&str, u32)> = methods.iter().map(|(n, m)| (*n, m.code())).collect();
        expected.extend([
            ("FOLLOW_UNIFORM", FOLLOW_UNIFORM),
            ("LATERAL_NONE", lateral::NONE),
            ("LATERAL_MAP", lateral::MAP),
            ("LATERAL_TAPS", lateral::TAPS),
            ("LATERAL_GIVEN", lateral::GIVEN),
            ("BOUNCE_NONE", bounce::NONE),
            ("BOUNCE_MAP", bounce::MAP),
            ("BOUNCE_GATHER", bounce::GATHER),
            ("TERM_BALLISTIC", Terms::BALLISTIC),
            ("TERM_SINGLE_SCATTERING", Terms::SINGLE_SCATTERING),
            ("TERM_SOURCE_SHIFT", Terms::SOURCE_SHIFT),
            ("TERM_THIN_PARTS", Terms::THIN_PARTS),
            ("TERM_SIDE_WALLS", Terms::SIDE_WALLS),
            ("TERM_LIT_SIDE", Terms::LIT_SIDE),
        ]);
        for (name, value) in &expected {
            assert_eq!(ids.get(*name), Some(value), "{name} in ids.wgsl");
        }
        assert_eq!(
            ids.len(),
            expected.len(),
            "ids.wgsl declares ids the test does not check"
        );
        // Every method has its id (a new method needs one).
        assert_eq!(methods.len(), TransmittanceMethod::ALL.len());
    }

    /// A frame without a blur builds its lighting pipeline without the source shift's
    /// lookups, whatever `sss.source_shift` says; with a blur the key decides.
    #[test]
    fn the_source_shift_is_compiled_only_where_a_blur_reads_it() {
        use crate::settings::{RenderSettings, SssMethod};
        let mut s = RenderSettings::default();
        s.sss.source_shift = true;
        assert_ne!(Terms::of(&s).0 & Terms::SOURCE_SHIFT, 0);
        s.sss.method = SssMethod::None;
        assert_eq!(Terms::of(&s).0 & Terms::SOURCE_SHIFT, 0);
        s.sss.method = SssMethod::Separable;
        s.sss.source_shift = false;
        assert_eq!(Terms::of(&s).0 & Terms::SOURCE_SHIFT, 0);
    }
}
