//! Settings of light through thin parts (Jimenez et al. 2010 and its alternatives).

use serde::{Deserialize, Serialize};

use super::{InvalidSetting, check};

/// How light through thin parts is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TransmittanceMethod {
    /// None.
    Off,
    /// Jimenez et al. 2010: T(s) of the sum-of-Gaussians profile (colour turns from yellow to
    /// red with thickness).
    Paper,
    /// Green 2004: Beer-Lambert exp(-sigma_t s) with the material's extinction.
    Beer,
    /// The ad-hoc s^-0.6 falloff of the screen/texture-space report (001_*), grey.
    SeedReport,
    /// Translucent shadow maps (d'Eon et al. 2007): the shadow maps also store the (u, v) of
    /// the surface nearest the light, whose irradiance, blurred in texture space, is
    /// attenuated by the same T(s) as `Paper`.
    Tsm,
    /// Light diffusing through the medium (our extension, see `docs/lab/fidelity.md`): T(s) is the
    /// multiply scattered light that a slab of the material's measured coefficients transmits,
    /// by exact transport (adding-doubling; diffusion theory's multipole passes half the green
    /// and a tenth of the blue through a finger), relative to what it reflects, leaving in the
    /// slab's angular shape around the way the light flows; plus the light scattered once
    /// (along the view ray) and the light that crosses thin parts unscattered. It decays
    /// exponentially rather than like a Gaussian, so fingers and thick ears still glow red.
    /// The Gaussian skin preset uses skin1's coefficients. The default: against the path
    /// tracer it is the closest on every backlit canonical scene (docs/lab/fidelity.md), where
    /// `Paper`'s Gaussian T(s) has all but vanished at the thickness of a finger.
    #[default]
    Diffusion,
}

impl TransmittanceMethod {
    /// Every method, in the order of their codes.
    pub const ALL: [TransmittanceMethod; 6] = [
        TransmittanceMethod::Off,
        TransmittanceMethod::Paper,
        TransmittanceMethod::Beer,
        TransmittanceMethod::SeedReport,
        TransmittanceMethod::Tsm,
        TransmittanceMethod::Diffusion,
    ];

    /// The number transmittance.wgsl switches on.
    pub const fn code(self) -> u32 {
        match self {
            TransmittanceMethod::Off => 0,
            TransmittanceMethod::Paper => 1,
            TransmittanceMethod::Beer => 2,
            TransmittanceMethod::SeedReport => 3,
            TransmittanceMethod::Tsm => 4,
            TransmittanceMethod::Diffusion => 5,
        }
    }

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            TransmittanceMethod::Off => "off",
            TransmittanceMethod::Paper => "paper",
            TransmittanceMethod::Beer => "beer",
            TransmittanceMethod::SeedReport => "seed-report",
            TransmittanceMethod::Tsm => "tsm",
            TransmittanceMethod::Diffusion => "diffusion",
        }
    }
}

/// How the lateral pass evaluates `diffusion`'s map (`TransmittanceSettings::lateral_texel_mm`).
/// Both give the same map (tests/transmittance.rs compares them); they differ in speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LateralPass {
    /// The map's raster pass only records each texel's surface (position, normal, object);
    /// one compute dispatch per object then evaluates every light's transmitted light there.
    /// The default: on the data-centre GPUs measured so far a fragment shader's arithmetic
    /// ran many times slower than a compute shader's, and the evaluation is nearly all
    /// arithmetic (docs/lab/performance.md). Adapters without compute shaders and storage
    /// textures evaluate in the fragment shader.
    #[default]
    Compute,
    /// The raster pass's fragment shader evaluates it at each texel (no surface targets).
    Fragment,
}

impl LateralPass {
    /// Both evaluations.
    pub const ALL: [LateralPass; 2] = [LateralPass::Compute, LateralPass::Fragment];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LateralPass::Compute => "compute",
            LateralPass::Fragment => "fragment",
        }
    }
}

/// The `[render.transmittance]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TransmittanceSettings {
    /// How light through thin parts is computed.
    pub method: TransmittanceMethod,
    /// How far (scene units) a shaded point moves inward along its vertex normal before the
    /// shadow-map lookup (000_* uses 0.005), so it does not find itself in the map.
    pub normal_shrink: f32,
    /// Width in texels (odd, 1..=15) of the shadow-map square averaged for thickness.
    pub thickness_filter: u32,
    /// `diffusion`: shadow-map taps (0..=32) that gather the light entering the lit surface
    /// around the chord through the medium (`subsurface_profile::lateral`); behind thick parts
    /// beside thinner ones (a palm, the finger roots) most light comes that way. 0: the chord's
    /// slab alone.
    pub lateral_taps: u32,
    /// `diffusion`: all of it (the chord's slab, the lateral taps, the unscattered lobe, single
    /// scattering), for every light, runs on a map whose texels are about this many profile
    /// millimetres apart on the skin (0..=50), in a pass of their own, and each pixel
    /// interpolates the lights' sum from the four nearest texels on its own surface (where
    /// none is, an outline, it runs each light's chord itself and keeps the larger of that and
    /// the diffuse light of the nearest texel in depth). What crosses skin varies over
    /// millimetres, not pixels, so the map's reduction follows the skin's size on screen
    /// (`lateral_downsample`): the same texels in millimetres at any resolution, on the nearest
    /// skin (a farther skin whose texels come out coarser than [`MAX_TEXEL_FACTOR`] times this
    /// runs everything at each of its pixels). 0 runs it at every pixel inside the lighting
    /// pass.
    pub lateral_texel_mm: f32,
    /// `diffusion`: where the lateral map is evaluated, `compute` (a compute shader on the
    /// texels' surfaces) or `fragment` (the map's raster pass); the same map.
    pub lateral_pass: LateralPass,
    /// `diffusion`: the light that crosses a thin part unscattered, refracted into a narrow
    /// lobe by the rough boundary (the glow at a backlit edge).
    pub ballistic: bool,
    /// `diffusion`: light scattered once on its way through a thin part (Jensen et al.
    /// 2001's single-scattering term, which diffusion leaves out).
    pub single_scattering: bool,
}

/// Default of [`TransmittanceSettings::lateral_texel_mm`].
pub const DEFAULT_LATERAL_TEXEL_MM: f32 = 4.0;
/// Largest reduction of the lateral map (one texel per 8 x 8 pixels).
pub const MAX_LATERAL_DOWNSAMPLE: u32 = 8;

/// How much coarser than `lateral_texel_mm` a skin's lateral-map texels may be for its pixels
/// to read the map: 16 mm at the default 4, about four of skin1's decay lengths. A skin farther
/// than the nearest, whose texels come out coarser, is drawn with a lighting pipeline that
/// gathers the taps at every pixel instead (`frame_plan::lateral_taps_objects`): across a step
/// in thickness the map's error there grows past the taps' own (tests/transmittance.rs,
/// `far_skin_gathers_its_own_taps`: at 23 mm texels the row's mean error 0.032 against the
/// taps' 0.007).
pub const MAX_TEXEL_FACTOR: f32 = 4.0;

/// The lateral map's reduction for skin whose pixels are `pixel_mm` profile millimetres apart
/// on the nearest translucent object in view: texels of at most `texel_mm` there, at most
/// [`MAX_LATERAL_DOWNSAMPLE`]. Where that leaves less than two pixels a side, two, as long as
/// the texels stay within [`MAX_TEXEL_FACTOR`] of `texel_mm` (skin small on screen, as a crowd
/// of characters: the map's pipeline holds no taps, and the taps at every pixel cost several
/// times the map's); 1 (no map, the taps at every pixel) only for skin smaller still.
pub fn lateral_downsample(texel_mm: f32, pixel_mm: f32) -> u32 {
    if !(texel_mm > 0.0 && pixel_mm > 0.0) {
        return 1;
    }
    let n = (texel_mm / pixel_mm).floor();
    if n >= 2.0 {
        (n as u32).min(MAX_LATERAL_DOWNSAMPLE)
    } else if 2.0 * pixel_mm <= MAX_TEXEL_FACTOR * texel_mm {
        2
    } else {
        1
    }
}

impl Default for TransmittanceSettings {
    fn default() -> Self {
        Self {
            method: TransmittanceMethod::default(),
            normal_shrink: 0.005,
            thickness_filter: 3,
            lateral_taps: subsurface_profile::lateral::DEFAULT_LATERAL_TAPS,
            lateral_texel_mm: DEFAULT_LATERAL_TEXEL_MM,
            lateral_pass: LateralPass::default(),
            ballistic: true,
            single_scattering: true,
        }
    }
}

impl TransmittanceSettings {
    /// Checks each key's range; the error names the key below `transmittance`.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        check(
            "normal_shrink",
            self.normal_shrink,
            self.normal_shrink >= 0.0,
            ">= 0",
        )?;
        let f = self.thickness_filter;
        if !(1..=15).contains(&f) || f.is_multiple_of(2) {
            return Err(InvalidSetting::new(
                "thickness_filter",
                format!("must be odd and in 1..=15 (got {f})"),
            ));
        }
        let max = subsurface_profile::lateral::MAX_LATERAL_TAPS;
        if self.lateral_taps > max {
            return Err(InvalidSetting::new(
                "lateral_taps",
                format!("must be in 0..={max} (got {})", self.lateral_taps),
            ));
        }
        check(
            "lateral_texel_mm",
            self.lateral_texel_mm,
            (0.0..=50.0).contains(&self.lateral_texel_mm),
            "in 0..=50",
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lateral_map_is_sized_for_the_nearest_skin() {
        // Texels of 4 mm, at least two pixels a side, at most 8.
        assert_eq!(lateral_downsample(4.0, 1.0), 4);
        assert_eq!(lateral_downsample(4.0, 0.55), 7);
        assert_eq!(lateral_downsample(4.0, 0.1), MAX_LATERAL_DOWNSAMPLE);
        assert_eq!(lateral_downsample(0.0, 1.0), 1);
        assert_eq!(lateral_downsample(4.0, f32::NAN), 1);
        // Skin small on screen: two pixels a texel while the texels stay within the factor.
        assert_eq!(lateral_downsample(4.0, 2.5), 2);
        assert_eq!(lateral_downsample(4.0, 8.0), 2);
        assert_eq!(lateral_downsample(4.0, 8.5), 1);
    }
}
