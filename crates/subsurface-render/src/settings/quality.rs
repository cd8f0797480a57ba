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
// Twelve lateral taps, the library's own count, as in `high`. Sixteen (session 32, against
// blotches a texel wide that eight left along the default scene's fingers once the side walls
// took the chord term down) turned out to be a dip of the taps' quadrature, not a step toward
// its limit: measured in session 44 at 8 to 256 taps, twelve read the suite's tuning part
// within ±25 % on 96.2 % of regions (sixteen 94.9 %, 256 taps 97.5 %), the canonical worst
// and mean region -24.6 / 7.0 % (sixteen -24.7 / 7.2 %) and a random walk's 108 windows 0.123
// (0.129), for a quarter fewer shadow-map loads; the fingers' blotches are alike at twelve,
// sixteen and 256 (docs/lab/quality.md, session 44).
const MEDIUM: &[(&str, &str)] = &[
    ("sss.samples", "7"),
    ("sss.jitter", "true"),
    ("transmittance.thickness_filter", "1"),
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
    ("transmittance.single_scattering", "false"),
    ("sss.thin_parts", "false"),
    ("bounce.ring", "0"),
];
