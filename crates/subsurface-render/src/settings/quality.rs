//! Quality presets: each a bundle of settings keys, chosen from the measured front of cost
//! against error (docs/lab/quality.md). A scene file's `[render] quality` (or `--quality`)
//! applies its bundle first; keys the scene or the command line set explicitly override it.

use serde::{Deserialize, Serialize};

/// A quality preset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// `medium` without single scattering.
    Low,
    /// The default: a few jittered taps and `diffusion`'s transmitted light on its
    /// transmitted map; no bounce.
    #[default]
    Medium,
    /// Every term: the renderer's closest match to the path tracer.
    High,
}

impl Quality {
    /// Every preset, cheapest first.
    pub const ALL: [Quality; 3] = [Quality::Low, Quality::Medium, Quality::High];

    /// The scene-file and command-line spelling (`"medium"`).
    pub fn name(self) -> &'static str {
        match self {
            Quality::Low => "low",
            Quality::Medium => "medium",
            Quality::High => "high",
        }
    }

    /// The keys the preset sets (below `[render]`) and their values; `high` is the settings
    /// structs' own defaults, the others start from it.
    pub fn keys(self) -> &'static [(&'static str, &'static str)] {
        match self {
            Quality::High => &[],
            Quality::Medium => MEDIUM,
            Quality::Low => LOW,
        }
    }
}

// From tools/reference/quality.py on lavapipe (docs/lab/quality.md): against the nine canonical
// references, seven jittered taps gave the same errors as seventeen fixed ones (worst region
// -16.7 % against -17.3 %), one thickness texel as three, eight lateral taps as twelve; the
// bounce bought 3 points on the hand's fingers (-20.5 % without it) for about a quarter of
// the skin's cost there. What stays: the ballistic lobe (-84 % on the wedge's thin end
// without it), the source shift (+45 % under the knife edge), single scattering (-31 % at the
// finger's outline) and, in `medium`, the lateral taps (-30 % on the tilted slab without).
// Sixteen lateral taps rather than eight: with the side walls (session 32) the chord term no
// longer covers the taps' noise along the default scene's fingers, where eight left blotches
// a texel wide; sixteen cost 0.4 ms more of lavapipe's 1280x720 map pass (19.4 -> 19.8 ms)
// and on the suite, before the walls, took the mean region error from 18.9 to 19.2 / 16.2 %
// (tuning / held out), 24 and 32 to 15.9 / 15.7 and 15.5 / 15.4 % (docs/lab/quality.md).
const MEDIUM: &[(&str, &str)] = &[
    ("sss.samples", "7"),
    ("sss.jitter", "true"),
    ("transmittance.thickness_filter", "1"),
    ("transmittance.lateral_taps", "16"),
    ("bounce.ring", "0"),
];

// On the H200 (docs/lab/quality.md, session 28) the lateral taps cost next to nothing on the
// map (0.01 ms for eight at 1920x1080) and single scattering 0.13 ms of the lighting pass:
// `low` is `medium` without single scattering (worst canonical region -30.4 %, within its
// 40 %). The former `low`, the chords at every pixel with no taps, cost more than `medium` on
// that GPU (27 % of the frame against 22 %); four taps instead of eight left the suite's
// wedge at +301 % on its light-side outline.
// Nor the thin parts' reflectance: their back faces' pass cost 8 ms of lavapipe's 175 at
// 1280x720 (about the depth pre-pass's), for a term that moves no canonical region and three
// of the suite's front-lit thin ones (docs/lab/suite.md, session 31).
const LOW: &[(&str, &str)] = &[
    ("sss.samples", "7"),
    ("sss.jitter", "true"),
    ("transmittance.thickness_filter", "1"),
    ("transmittance.lateral_taps", "16"),
    ("transmittance.single_scattering", "false"),
    ("sss.thin_parts", "false"),
    ("bounce.ring", "0"),
];
