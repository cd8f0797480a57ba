//! Settings of the transmitted map: `diffusion`'s transmitted light, every light summed, and
//! the bounce, evaluated at a reduced resolution that follows the skin's size on screen.

use serde::{Deserialize, Serialize};

use super::{InvalidSetting, check};

/// How the map's pass evaluates the transmitted map. Each gives the same map
/// (tests/transmittance.rs compares them); they differ in speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MapEvaluation {
    /// `compute` on GPUs, `fragment` on adapters whose shaders run both sides of every branch
    /// (CPU rasterisers such as lavapipe): the compute shader spreads each texel over eight
    /// invocations, one per light for most of its work, and a CPU runs all eight in one vector
    /// whether the scene has two lights or eight; the fragment shader gives each texel a lane
    /// (docs/lab/performance.md, session 38).
    #[default]
    Auto,
    /// The map's raster pass only records each texel's surface (position, normal, object);
    /// one compute dispatch per object then evaluates every light's transmitted light there.
    /// On the data-centre GPUs measured so far a fragment shader's arithmetic ran many times
    /// slower than a compute shader's, and the evaluation is nearly all arithmetic
    /// (docs/lab/performance.md). Adapters without compute shaders and storage textures
    /// evaluate in the fragment shader.
    Compute,
    /// The raster pass's fragment shader evaluates it at each texel (no surface targets).
    Fragment,
}

impl MapEvaluation {
    /// Every choice.
    pub const ALL: [MapEvaluation; 3] = [
        MapEvaluation::Auto,
        MapEvaluation::Compute,
        MapEvaluation::Fragment,
    ];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            MapEvaluation::Auto => "auto",
            MapEvaluation::Compute => "compute",
            MapEvaluation::Fragment => "fragment",
        }
    }
}

/// Where a frame that reads `diffusion` from the transmitted map runs each light's chord at the
/// pixels the map has no texel of (outlines, depth edges). The same image either way (tests/
/// transmittance.rs compares them); they differ in speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OutlineChords {
    /// `pass` on adapters whose shaders run both sides of every branch (CPU rasterisers such
    /// as lavapipe), `lighting` on the others (docs/lab/performance.md, session 29).
    #[default]
    Auto,
    /// In the lighting pass's shader, behind a branch only outline pixels take: one draw, but
    /// the branch's code weighs on the shader everywhere (registers on a GPU; on a CPU
    /// rasteriser, which masks rather than jumps, its whole cost at every pixel).
    Lighting,
    /// In a pass of their own after the lighting pass, over the skin's pixels, which leave at
    /// once where the map holds their surface: a second draw of the skin, and a lighting
    /// shader without the chords.
    Pass,
}

impl OutlineChords {
    /// Every choice.
    pub const ALL: [OutlineChords; 3] = [
        OutlineChords::Auto,
        OutlineChords::Lighting,
        OutlineChords::Pass,
    ];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            OutlineChords::Auto => "auto",
            OutlineChords::Lighting => "lighting",
            OutlineChords::Pass => "pass",
        }
    }
}

/// The `[render.transmitted_map]` table. The map exists when `diffusion` runs on skin large
/// enough on screen; the bounce then rides on it as one more layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TransmittedMapSettings {
    /// All of `diffusion` (the chord's slab, the lateral taps, the unscattered lobe, single
    /// scattering), for every light, and the bounce, run on a map whose texels are about this
    /// many profile millimetres apart on the skin (0..=50), in a pass of their own; each pixel
    /// interpolates the lights' sum from the four nearest texels on its own surface (where
    /// none is, an outline, it runs each light's chord itself and keeps the larger of that and
    /// the diffuse light of the nearest texel in depth). What crosses skin varies over
    /// millimetres, not pixels, so the map's reduction follows the skin's size on screen
    /// ([`map_downsample`]): the same texels in millimetres at any resolution, on the nearest
    /// skin (a farther skin whose texels come out coarser than [`MAX_TEXEL_FACTOR`] times this
    /// runs everything at each of its pixels). 0: no map, everything at every pixel inside
    /// the lighting pass.
    pub texel_mm: f32,
    /// Where the map is evaluated: `auto`, `compute` (a compute shader on the texels'
    /// surfaces) or `fragment` (the map's raster pass); the same map.
    pub pass: MapEvaluation,
    /// Where each light's chord runs at the pixels the map misses: `auto`, `lighting` (in the
    /// lighting pass) or `pass` (a pass of their own); the same image.
    pub outlines: OutlineChords,
}

impl Default for TransmittedMapSettings {
    fn default() -> Self {
        Self {
            texel_mm: DEFAULT_MAP_TEXEL_MM,
            pass: MapEvaluation::default(),
            outlines: OutlineChords::default(),
        }
    }
}

impl TransmittedMapSettings {
    /// Checks each key's range; the error names the key below `transmitted_map`.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        check(
            "texel_mm",
            self.texel_mm,
            (0.0..=50.0).contains(&self.texel_mm),
            "in 0..=50",
        )
    }
}

/// Default of [`TransmittedMapSettings::texel_mm`].
pub const DEFAULT_MAP_TEXEL_MM: f32 = 4.0;
/// Largest reduction of the transmitted map (one texel per 8 x 8 pixels).
pub const MAX_MAP_DOWNSAMPLE: u32 = 8;

/// How much coarser than `texel_mm` a skin's map texels may be for its pixels to read the
/// map: 16 mm at the default 4, about four of skin1's decay lengths. A skin farther than the
/// nearest, whose texels come out coarser, is drawn with a lighting pipeline that gathers the
/// taps at every pixel instead (`frame_plan::lateral_taps_objects`): across a step in
/// thickness the map's error there grows past the taps' own (tests/transmittance.rs,
/// `far_skin_gathers_its_own_taps`).
pub const MAX_TEXEL_FACTOR: f32 = 4.0;

/// The transmitted map's reduction for skin whose pixels are `pixel_mm` profile millimetres
/// apart on the nearest translucent object in view: texels of at most `texel_mm` there, at
/// most [`MAX_MAP_DOWNSAMPLE`]. Where that leaves less than two pixels a side, two, as long as
/// the texels stay within [`MAX_TEXEL_FACTOR`] of `texel_mm` (skin small on screen, as a
/// crowd of characters: the map's pipeline holds no taps, and the taps at every pixel cost
/// several times the map's); 1 (no map, the taps at every pixel) only for skin smaller still.
pub fn map_downsample(texel_mm: f32, pixel_mm: f32) -> u32 {
    if !(texel_mm > 0.0 && pixel_mm > 0.0) {
        return 1;
    }
    let n = (texel_mm / pixel_mm).floor();
    if n >= 2.0 {
        (n as u32).min(MAX_MAP_DOWNSAMPLE)
    } else if 2.0 * pixel_mm <= MAX_TEXEL_FACTOR * texel_mm {
        2
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_transmitted_map_is_sized_for_the_nearest_skin() {
        // Texels of 4 mm, at least two pixels a side, at most 8.
        assert_eq!(map_downsample(4.0, 1.0), 4);
        assert_eq!(map_downsample(4.0, 0.55), 7);
        assert_eq!(map_downsample(4.0, 0.1), MAX_MAP_DOWNSAMPLE);
        assert_eq!(map_downsample(0.0, 1.0), 1);
        assert_eq!(map_downsample(4.0, f32::NAN), 1);
        // Skin small on screen: two pixels a texel while the texels stay within the factor.
        assert_eq!(map_downsample(4.0, 2.5), 2);
        assert_eq!(map_downsample(4.0, 8.0), 2);
        assert_eq!(map_downsample(4.0, 8.5), 1);
    }
}
