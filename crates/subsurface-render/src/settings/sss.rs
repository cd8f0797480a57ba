//! Settings of subsurface scattering that hold for the whole frame. What differs per material
//! (profile, strength, width, kernel strength and falloff) is in the material.

use serde::{Deserialize, Serialize};
use subsurface_profile::DEFAULT_SAMPLES;

use super::{InvalidSetting, check, check_int};

/// Which subsurface-scattering method runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SssMethod {
    /// No scattering: the diffuse radiance is left as it is.
    None,
    /// Jimenez et al. 2009 / GPU Pro 2010: the profile's Gaussians, a 7-tap H and V blur
    /// each, accumulated by blending.
    Gaussian6,
    /// Jimenez et al. 2015: one horizontal and one vertical pass of an N-tap kernel.
    #[default]
    Separable,
    /// Hable et al. 2009: one 2-D pass with 13 jittered taps.
    Hable13,
    /// d'Eon et al. 2007: the sum of Gaussians in texture space (per-object UV maps).
    Texture,
}

impl SssMethod {
    /// Every method.
    pub const ALL: [SssMethod; 5] = [
        SssMethod::None,
        SssMethod::Gaussian6,
        SssMethod::Separable,
        SssMethod::Hable13,
        SssMethod::Texture,
    ];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SssMethod::None => "none",
            SssMethod::Gaussian6 => "gaussian6",
            SssMethod::Separable => "separable",
            SssMethod::Hable13 => "hable13",
            SssMethod::Texture => "texture",
        }
    }

    /// True for the methods that blur the screen-space image.
    pub fn is_screen_space(self) -> bool {
        matches!(
            self,
            SssMethod::Gaussian6 | SssMethod::Separable | SssMethod::Hable13
        )
    }
}

/// How the screen-space passes fetch a texel of a tap. Both give the same image (the oracle
/// tests run each); they differ in speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SssFetch {
    /// A first pass packs colour, depth, strength, scale and profile row into one Rgba32Uint
    /// texel per pixel, so a tap reads one texel per footprint texel instead of three.
    Packed,
    /// Every texel of a tap reads the colour, depth and SSS textures (no extra pass or
    /// memory).
    Direct,
    /// Separable: packed texels, and the two 1-D passes run as compute shaders that load each
    /// line's texels once into workgroup memory (taps past a 64-pixel apron read the
    /// texture). The vertical pass writes the diffuse texture as a storage texture; where it
    /// lacks STORAGE_BINDING that pass is a fragment pass. Other methods, and adapters without
    /// compute shaders and storage textures, fetch packed. The default: on an H200 the two
    /// passes took 0.68 ms at 1920x1080 against packed's 2.78 (lavapipe, a CPU, runs them
    /// within 10 % of each other; docs/lab/performance.md).
    #[default]
    Workgroup,
}

impl SssFetch {
    /// Every fetch mode.
    pub const ALL: [SssFetch; 3] = [SssFetch::Packed, SssFetch::Direct, SssFetch::Workgroup];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SssFetch::Packed => "packed",
            SssFetch::Direct => "direct",
            SssFetch::Workgroup => "workgroup",
        }
    }
}

/// Largest separable kernel.
pub const MAX_SAMPLES: u32 = 63;

/// The `[render.sss]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SssSettings {
    /// Which method blurs the diffuse radiance.
    pub method: SssMethod,
    /// Separable: number of kernel taps (odd, 3..=63).
    pub samples: u32,
    /// Separable: move every tap, per pixel and pass, by a hashed amount within the interval
    /// its weight stands for (Jimenez et al. 2015's jittering, which lets 7 taps stand in for
    /// many): the banding of few taps becomes fine per-pixel noise.
    pub jitter: bool,
    /// Screen space: how a tap fetches its texels (`packed`, `workgroup` or `direct`; the
    /// same image at a different cost).
    pub fetch: SssFetch,
    /// Screen space: weaken taps by their depth difference, so the blur follows the surface
    /// instead of crossing silhouettes and depth edges (Jimenez et al. 2009).
    pub follow_surface: bool,
    /// Screen space: depth difference, in millimetres on the skin, that fully stops a tap.
    pub edge_mm: f32,
    /// Six Gaussians: a Gaussian narrower than this many pixels is skipped (GPU Pro).
    pub min_sigma_px: f32,
    /// Six Gaussians: which of the five blurred Gaussians (the narrowest is never blurred)
    /// are accumulated; switching one off shows its share of the profile.
    #[serde(deserialize_with = "subsurface_profile::exact_array::exact")]
    pub gaussians: [bool; 5],
    /// Texture space: size of each object's UV-space maps in texels per side.
    pub texture_size: u32,
    /// Texture space: padding of the UV islands in texels (0..=16).
    pub texture_padding: u32,
    /// Texture space: exponent of the albedo applied before the blur, the rest after it:
    /// 0 = post-scatter, 0.5 = pre- and post-scatter (d'Eon), 1 = pre-scatter.
    pub texture_albedo_pre: f32,
    /// Light entering obliquely feeds a diffusion source along its refracted ray, so the
    /// shadow it sees is looked up there, per channel (Jensen et al. 2001's real source):
    /// softer, redder shadow edges.
    pub source_shift: bool,
    /// Screen space: a part thinner than a few diffusion lengths, lit from the front, lets
    /// part of the light out through its far face, so it reflects less than the half-space
    /// the albedo is measured on (an ear's rim, a nostril, an eyelid: 2 mm of skin keep 0.75
    /// of the red). Its thickness comes from a depth pass of the back faces.
    pub thin_parts: bool,
}

impl Default for SssSettings {
    fn default() -> Self {
        Self {
            method: SssMethod::Separable,
            samples: DEFAULT_SAMPLES,
            jitter: false,
            fetch: SssFetch::default(),
            follow_surface: true,
            edge_mm: 3.0,
            min_sigma_px: 0.25,
            gaussians: [true; 5],
            texture_size: 1024,
            texture_padding: 4,
            texture_albedo_pre: 0.5,
            source_shift: true,
            thin_parts: true,
        }
    }
}

impl SssSettings {
    /// Checks each key's range; the error names the key below `sss`.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        let n = self.samples;
        if !(3..=MAX_SAMPLES).contains(&n) || n.is_multiple_of(2) {
            return Err(InvalidSetting::new(
                "samples",
                format!("must be odd and in 3..={MAX_SAMPLES} (got {n})"),
            ));
        }
        check("edge_mm", self.edge_mm, self.edge_mm > 0.0, "> 0")?;
        check(
            "min_sigma_px",
            self.min_sigma_px,
            self.min_sigma_px >= 0.0,
            ">= 0",
        )?;
        check_int("texture_size", self.texture_size, 16..=16384)?;
        check_int("texture_padding", self.texture_padding, 0..=16)?;
        check(
            "texture_albedo_pre",
            self.texture_albedo_pre,
            (0.0..=1.0).contains(&self.texture_albedo_pre),
            "in [0, 1]",
        )
    }
}
