//! Settings of light through thin parts (Jimenez et al. 2010 and its alternatives).

use serde::{Deserialize, Serialize};

use super::{InvalidSetting, check, check_int};

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
    /// `diffusion`: the light that crosses a thin part unscattered, refracted into a narrow
    /// lobe by the rough boundary (the glow at a backlit edge).
    pub ballistic: bool,
    /// `diffusion`: light scattered once on its way through a thin part (Jensen et al.
    /// 2001's single-scattering term, which diffusion leaves out).
    pub single_scattering: bool,
    /// `diffusion`: the sides of a part narrower than the light's spread (a rod, a ball, lit
    /// from behind) take their share of the chord's and the lateral taps' light, by the method
    /// of images, less what a like part across a narrow gap sends back; without it, the chord's
    /// light is scaled by the share of the lateral taps' kernel that the part covers.
    pub side_walls: bool,
    /// `diffusion`: a point the light reaches directly also takes the light of the beam
    /// beneath it, where the part holds more of it than the half-space the profile assumes
    /// (the lit side of a rod near its terminator, in a medium whose light crosses the rod).
    pub lit_side: bool,
}

impl Default for TransmittanceSettings {
    fn default() -> Self {
        Self {
            method: TransmittanceMethod::default(),
            normal_shrink: 0.005,
            thickness_filter: 3,
            lateral_taps: subsurface_profile::lateral::DEFAULT_LATERAL_TAPS,
            ballistic: true,
            single_scattering: true,
            side_walls: true,
            lit_side: true,
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
        check_int(
            "lateral_taps",
            self.lateral_taps,
            0..=subsurface_profile::lateral::MAX_LATERAL_TAPS,
        )?;
        Ok(())
    }
}
