//! What a frame is rendered with, one GPU-free type per effect. The scene file's `[render]`
//! table is a [`RenderSettings`]; the command line overlays its flags on it and the viewer's
//! two sides are clones of it, so every setting has one name, one unit and one default.

mod bounce;
mod keys;
mod quality;
mod sss;
mod transmittance;
mod transmitted_map;

pub use bounce::{BounceSettings, MAX_BOUNCE_RING};
pub use keys::{RENAMED, SETTINGS, SettingDoc, renamed, value_text};
pub use quality::Quality;
pub use sss::{SssFetch, SssMethod, SssSettings};
pub use transmittance::{TransmittanceMethod, TransmittanceSettings};
pub use transmitted_map::{
    DEFAULT_MAP_TEXEL_MM, MAX_MAP_DOWNSAMPLE, MAX_TEXEL_FACTOR, MapEvaluation, OutlineChords,
    TransmittedMapSettings, map_downsample,
};

use serde::{Deserialize, Serialize};

/// `FromStr` and `Display` of a method enum by its `name()` (the scene-file and command-line
/// spelling); parsing an unknown name lists the names of `ALL`.
macro_rules! method_names {
    ($($method:ty),*) => {$(
        impl std::str::FromStr for $method {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                <$method>::ALL
                    .into_iter()
                    .find(|m| m.name() == s)
                    .ok_or_else(|| {
                        let names: Vec<&str> = <$method>::ALL.iter().map(|m| m.name()).collect();
                        format!("{s:?} is not one of {}", names.join(", "))
                    })
            }
        }

        impl std::fmt::Display for $method {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    )*};
}

method_names!(
    SssMethod,
    SssFetch,
    TransmittanceMethod,
    MapEvaluation,
    OutlineChords,
    Quality
);

/// A setting out of range. `field` is its path below `[render]` as written in a scene file
/// (`width`, `sss.samples`, `transmittance.normal_shrink`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct InvalidSetting {
    /// The setting's path below `[render]` (`sss.samples`).
    pub field: String,
    /// The rule broken and the value given.
    pub message: String,
}

impl InvalidSetting {
    /// An error for `field`.
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }

    /// The same error for a setting nested under `prefix` (`sss` + `samples` = `sss.samples`).
    pub fn under(self, prefix: &str) -> Self {
        Self {
            field: format!("{prefix}.{}", self.field),
            message: self.message,
        }
    }
}

/// `x` finite and satisfying `ok`; `rule` reads like "> 0".
pub(crate) fn check(field: &str, x: f32, ok: bool, rule: &str) -> Result<(), InvalidSetting> {
    if x.is_finite() && ok {
        Ok(())
    } else if rule.is_empty() {
        Err(InvalidSetting::new(
            field,
            format!("must be finite (got {x})"),
        ))
    } else {
        Err(InvalidSetting::new(
            field,
            format!("must be finite and {rule} (got {x})"),
        ))
    }
}

/// `v` within `range` (an integer setting).
pub(crate) fn check_int(
    field: &str,
    v: u32,
    range: std::ops::RangeInclusive<u32>,
) -> Result<(), InvalidSetting> {
    if range.contains(&v) {
        Ok(())
    } else {
        Err(InvalidSetting::new(
            field,
            format!("must be in {}..={} (got {v})", range.start(), range.end()),
        ))
    }
}

/// Largest image side accepted before the device's own limit is known.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Exposure beyond this many stops saturates or blackens every pixel of a half-float target.
pub const MAX_EXPOSURE_EV: f32 = 32.0;

/// The `[render]` table: output size, exposure, ambient light and the settings of each effect.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
// Missing keys take `high`'s values, not `Default`'s: the default preset is made by `set`, which
// deserializes (a scene file's keys are put over its preset by `SceneDesc::from_toml_str`).
#[serde(deny_unknown_fields, default = "RenderSettings::high")]
pub struct RenderSettings {
    /// The preset the other keys started from (`Quality::keys`); keys set after it override it.
    /// A scene file without one takes the default preset.
    #[serde(default)]
    pub quality: Quality,
    /// Image width in pixels, 1..=16384 and within the device's limit.
    pub width: u32,
    /// Image height in pixels, 1..=16384 and within the device's limit.
    pub height: u32,
    /// Exposure in stops: radiance is multiplied by 2^ev before tone mapping.
    pub exposure_ev: f32,
    /// Uniform ambient radiance (linear RGB).
    #[serde(deserialize_with = "subsurface_profile::exact_array::exact")]
    pub ambient: [f32; 3],
    /// Background colour (linear RGB).
    #[serde(deserialize_with = "subsurface_profile::exact_array::exact")]
    pub background: [f32; 3],
    /// Subsurface scattering of the reflected light (`[render.sss]`).
    pub sss: SssSettings,
    /// Light through thin parts (`[render.transmittance]`).
    pub transmittance: TransmittanceSettings,
    /// Where `diffusion`'s transmitted light and the bounce are evaluated
    /// (`[render.transmitted_map]`).
    pub transmitted_map: TransmittedMapSettings,
    /// Light between lit parts across the air (`[render.bounce]`).
    pub bounce: BounceSettings,
}

impl Default for RenderSettings {
    /// The default preset, [`Quality::Medium`].
    fn default() -> Self {
        Self::preset(Quality::default())
    }
}

impl RenderSettings {
    /// Every setting at its most accurate: the settings structs' own defaults.
    pub fn high() -> Self {
        Self {
            quality: Quality::High,
            width: 1280,
            height: 720,
            exposure_ev: 0.0,
            ambient: [0.02, 0.02, 0.02],
            background: [0.02, 0.02, 0.025],
            sss: SssSettings::default(),
            transmittance: TransmittanceSettings::default(),
            transmitted_map: TransmittedMapSettings::default(),
            bounce: BounceSettings::default(),
        }
    }

    /// `quality`'s preset: [`Self::high`] with its keys set.
    pub fn preset(quality: Quality) -> Self {
        let mut s = Self::high();
        s.apply_quality(quality);
        s
    }

    /// Sets `quality` and its bundle: every key any preset sets, at this preset's value or
    /// else [`Self::high`]'s (the other settings are kept).
    pub fn apply_quality(&mut self, quality: Quality) {
        let high = Self::high().entries();
        let bundle: Vec<&str> = Quality::ALL
            .iter()
            .flat_map(|q| q.keys().iter().map(|(k, _)| *k))
            .collect();
        for key in bundle {
            let value = match quality.keys().iter().find(|(k, _)| *k == key) {
                Some((_, v)) => v.to_string(),
                None => high
                    .iter()
                    .find(|(k, _)| k == key)
                    .map(|(_, v)| value_text(v))
                    .expect("a preset's key is a setting"),
            };
            self.set_unchecked(key, &value)
                .expect("a preset's keys are settings of their type");
        }
        self.quality = quality;
    }

    /// Checks every value; the error names the field below `[render]`.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        for (field, v) in [("width", self.width), ("height", self.height)] {
            check_int(field, v, 1..=MAX_IMAGE_SIDE)?;
        }
        check(
            "exposure_ev",
            self.exposure_ev,
            self.exposure_ev.abs() <= MAX_EXPOSURE_EV,
            &format!("within +-{MAX_EXPOSURE_EV}"),
        )?;
        for (field, v) in [("ambient", self.ambient), ("background", self.background)] {
            for (i, x) in v.into_iter().enumerate() {
                check(&format!("{field}[{i}]"), x, x >= 0.0, ">= 0")?;
            }
        }
        self.sss.validate().map_err(|e| e.under("sss"))?;
        self.transmittance
            .validate()
            .map_err(|e| e.under("transmittance"))?;
        self.transmitted_map
            .validate()
            .map_err(|e| e.under("transmitted_map"))?;
        self.bounce.validate().map_err(|e| e.under("bounce"))
    }
}
