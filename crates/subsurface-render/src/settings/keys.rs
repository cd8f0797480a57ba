//! Every setting of the `[render]` table by its key (`sss.samples`, or `render.sss.samples`):
//! listed with its unit and meaning in [`SETTINGS`], read and written through the same serde
//! form a scene file has, so that the command line's `--set KEY=VALUE`, `bench`'s
//! `--vary KEY=V1,V2` and the quality presets reach every setting with the scene file's
//! names, types and checks. A test holds [`SETTINGS`] to the fields the structs serialize.

use super::{InvalidSetting, RenderSettings, SssMethod, TransmittanceMethod};

/// One setting: its key below `[render]`, its unit and what it does.
#[derive(Clone, Copy, Debug)]
pub struct SettingDoc {
    /// Path below `[render]` (`sss.samples`).
    pub key: &'static str,
    /// Unit (`mm`, `px`, `linear RGB`); empty for names, flags and plain numbers.
    pub unit: &'static str,
    /// One line on what the setting does and its range.
    pub doc: &'static str,
}

const fn doc(key: &'static str, unit: &'static str, doc: &'static str) -> SettingDoc {
    SettingDoc { key, unit, doc }
}

/// Every key of the `[render]` table, in the scene file's order.
#[rustfmt::skip]
pub const SETTINGS: &[SettingDoc] = &[
    doc("quality", "", "low, medium or high: a bundle of the keys below; explicit keys override it"),
    doc("width", "px", "image width, 1..=16384"),
    doc("height", "px", "image height, 1..=16384"),
    doc("exposure_ev", "stops", "radiance is scaled by 2^ev before tone mapping"),
    doc("ambient", "linear RGB", "uniform, unshadowed ambient radiance"),
    doc("background", "linear RGB", "colour where nothing is drawn"),
    doc("sss.method", "", "none, gaussian6, separable, hable13 or texture"),
    doc("sss.samples", "taps", "separable: kernel taps, odd, 3..=63"),
    doc("sss.jitter", "", "separable: jitter the taps per pixel (few-sample mode)"),
    doc("sss.fetch", "", "screen space: packed, workgroup or direct (same image)"),
    doc("sss.follow_surface", "", "screen space: taps fade across depth edges"),
    doc("sss.edge_mm", "mm", "screen space: depth step that stops a tap, > 0"),
    doc("sss.min_sigma_px", "px", "gaussian6: narrower Gaussians are skipped, >= 0"),
    doc("sss.gaussians", "", "gaussian6: which of the five blurred Gaussians add up"),
    doc("sss.texture_size", "texels", "texture space: UV map side, 16..=16384"),
    doc("sss.texture_padding", "texels", "texture space: UV island padding, 0..=16"),
    doc("sss.texture_albedo_pre", "", "texture space: albedo share before the blur, 0..=1"),
    doc("sss.source_shift", "", "oblique light's shadow looked up where it feeds the diffusion"),
    doc("sss.thin_parts", "", "screen space: thin parts reflect less (light leaves their back face)"),
    doc("transmittance.method", "", "off, paper, beer, seed-report, tsm or diffusion"),
    doc("transmittance.normal_shrink", "scene units", "inward shift before the shadow lookup"),
    doc("transmittance.thickness_filter", "texels", "odd width averaged for thickness, 1..=15"),
    doc("transmittance.lateral_taps", "taps", "diffusion: lit-surface taps around the chord, 0..=32"),
    doc("transmittance.ballistic", "", "diffusion: unscattered light through thin parts"),
    doc("transmittance.single_scattering", "", "diffusion: light scattered once through thin parts"),
    doc("transmittance.side_walls", "", "diffusion: the sides of narrow parts take their share of the light through them"),
    doc("transmittance.lit_side", "", "diffusion: lit points take the light beneath them beyond the half-space's"),
    doc("transmitted_map.texel_mm", "mm", "diffusion and bounce: map texel on the skin, 0..=50 (0: per pixel)"),
    doc("transmitted_map.pass", "", "diffusion and bounce: compute or fragment evaluation of the map"),
    doc("transmitted_map.outlines", "", "diffusion: chords where the map misses, in the lighting pass or a pass (same image)"),
    doc("bounce.ring", "cells", "light between parts: cells read per level, 0..=8 (0: off)"),
    doc("bounce.cell_mm", "mm", "light between parts: finest cell width, 0.1..=50"),
];

/// Keys that moved, with their new place: a scene file or `--set` that uses the old key gets
/// an error naming the new one.
pub const RENAMED: &[(&str, &str)] = &[
    ("transmittance.lateral_texel_mm", "transmitted_map.texel_mm"),
    ("transmittance.lateral_pass", "transmitted_map.pass"),
];

/// The error for a key that moved ([`RENAMED`]), if `key` (below `[render]`) is one.
pub fn renamed(key: &str) -> Option<InvalidSetting> {
    let key = relative(key);
    RENAMED.iter().find(|(old, _)| *old == key).map(|(_, new)| {
        InvalidSetting::new(
            format!("render.{key}"),
            format!("this key is now render.{new}"),
        )
    })
}

/// `key` below `[render]` (a leading `render.` is dropped).
fn relative(key: &str) -> &str {
    key.strip_prefix("render.").unwrap_or(key)
}

/// `value` as TOML reads it (`9`, `0.5`, `true`, `[1, 0, 1, 1, 1]`, `"paper"`); a bare word
/// that is no TOML value is a string, so `sss.method=separable` needs no quotes.
fn parse_value(value: &str) -> toml::Value {
    match toml::from_str::<toml::Table>(&format!("v = {value}")) {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| value.into()),
        Err(_) => toml::Value::String(value.to_string()),
    }
}

/// Finite numbers past a 32-bit float's range turn into infinities when stored: refused with
/// the literal as written.
fn check_range(key: &str, value: &str, v: &toml::Value) -> Result<(), InvalidSetting> {
    let too_big = match v {
        toml::Value::Float(x) => x.is_finite() && x.abs() > f64::from(f32::MAX),
        toml::Value::Array(a) => a.iter().any(|x| check_range(key, value, x).is_err()),
        _ => false,
    };
    if too_big {
        return Err(InvalidSetting::new(
            key,
            format!("{value} is out of range of a 32-bit float"),
        ));
    }
    Ok(())
}

/// `v` as a scene file would spell it, with the settings' 32-bit floats in their shortest form
/// (0.01, not 0.009999999776482582).
pub fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::Float(x) => {
            let f = *x as f32;
            // Spelled so that TOML reads a float back: an exponent where plain digits would
            // be long (or read as an integer), `nan` and `inf` as TOML writes them.
            if f.is_nan() {
                "nan".to_string()
            } else if f.is_infinite() {
                if f > 0.0 { "inf" } else { "-inf" }.to_string()
            } else if f != 0.0 && !(1e-4..1e15).contains(&f.abs()) {
                format!("{f:e}")
            } else if f.fract() == 0.0 {
                format!("{f:.1}")
            } else {
                format!("{f}")
            }
        }
        toml::Value::Array(a) => {
            let items: Vec<String> = a.iter().map(value_text).collect();
            format!("[{}]", items.join(", "))
        }
        v => v.to_string(),
    }
}

impl RenderSettings {
    /// Every key below `[render]` with its value, as a scene file would write it.
    pub fn entries(&self) -> Vec<(String, toml::Value)> {
        fn walk(prefix: &str, v: &toml::Value, out: &mut Vec<(String, toml::Value)>) {
            match v {
                toml::Value::Table(t) => {
                    for (k, v) in t {
                        let key = if prefix.is_empty() {
                            k.clone()
                        } else {
                            format!("{prefix}.{k}")
                        };
                        walk(&key, v, out);
                    }
                }
                v => out.push((prefix.to_string(), v.clone())),
            }
        }
        let mut out = Vec::new();
        walk("", &self.to_toml(), &mut out);
        out
    }

    fn to_toml(&self) -> toml::Value {
        toml::Value::try_from(self).expect("the settings serialize as TOML")
    }

    /// Sets `key` (`sss.samples` or `render.sss.samples`) to `value` (TOML syntax, a bare word
    /// being a string) and checks the whole; the error names the key and, for an unknown one,
    /// the keys of its table.
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), InvalidSetting> {
        let mut next = self.clone();
        next.set_unchecked(key, value)?;
        next.validate()
            .map_err(|e| InvalidSetting::new(format!("render.{}", e.field), e.message))?;
        *self = next;
        Ok(())
    }

    /// As [`Self::set`], without checking the other settings' ranges (a scene file's keys are
    /// put over its preset before the whole is validated, which names the file): the value
    /// must still be of the key's type.
    pub fn set_unchecked(&mut self, key: &str, value: &str) -> Result<(), InvalidSetting> {
        let rel = relative(key);
        if let Some(e) = renamed(rel) {
            return Err(e);
        }
        if !SETTINGS.iter().any(|s| s.key == rel) {
            let table = rel.rsplit_once('.').map_or("", |(t, _)| t);
            let mut valid: Vec<&str> = SETTINGS
                .iter()
                .filter_map(|s| match s.key.rsplit_once('.') {
                    Some((t, leaf)) if t == table => Some(leaf),
                    None if table.is_empty() => Some(s.key),
                    _ => None,
                })
                .collect();
            if table.is_empty() {
                valid.extend(["sss.*", "transmittance.*", "transmitted_map.*", "bounce.*"]);
            }
            let under = if table.is_empty() {
                "render".to_string()
            } else {
                format!("render.{table}")
            };
            return Err(InvalidSetting::new(
                format!("render.{rel}"),
                if valid.is_empty() {
                    "unknown key; the tables are render, render.sss, render.transmittance, render.transmitted_map and render.bounce"
                        .to_string()
                } else {
                    format!("unknown key; the keys of {under} are {}", valid.join(", "))
                },
            ));
        }
        let named = |e: InvalidSetting| InvalidSetting::new(format!("render.{rel}"), e.message);
        if rel == "quality" {
            let q: super::Quality = value
                .trim_matches('"')
                .parse()
                .map_err(|m| named(InvalidSetting::new("", m)))?;
            self.apply_quality(q);
            return Ok(());
        }
        let parsed = parse_value(value);
        check_range(rel, value, &parsed).map_err(named)?;
        let mut tree = self.to_toml();
        let mut slot = &mut tree;
        for part in rel.split('.') {
            slot = slot
                .get_mut(part)
                .expect("every key of SETTINGS is a field of the settings");
        }
        *slot = parsed;
        *self = tree
            .try_into()
            .map_err(|e: toml::de::Error| named(InvalidSetting::new("", e.message())))?;
        Ok(())
    }

    /// Whether `key` changes the frame with the other settings as they are: the separable
    /// kernel's taps only matter to `separable`, the transmitted map only to `diffusion`, the
    /// bounce's cells only with a ring. Conservative: true where unsure.
    pub fn matters(&self, key: &str) -> bool {
        let (sss, t) = (self.sss.method, self.transmittance.method);
        match relative(key) {
            "sss.samples" | "sss.jitter" => sss == SssMethod::Separable,
            "sss.fetch" | "sss.follow_surface" | "sss.edge_mm" => sss.is_screen_space(),
            "sss.source_shift" => sss != SssMethod::None,
            "sss.thin_parts" => sss != SssMethod::Texture,
            "sss.min_sigma_px" | "sss.gaussians" => sss == SssMethod::Gaussian6,
            k if k.starts_with("sss.texture_") => sss == SssMethod::Texture,
            "transmittance.lateral_taps" => t == TransmittanceMethod::Diffusion,
            k if k.starts_with("transmitted_map.") => t == TransmittanceMethod::Diffusion,
            "transmittance.ballistic"
            | "transmittance.single_scattering"
            | "transmittance.side_walls"
            | "transmittance.lit_side" => t == TransmittanceMethod::Diffusion,
            "transmittance.method" => true,
            k if k.starts_with("transmittance.") => t != TransmittanceMethod::Off,
            "bounce.cell_mm" => self.bounce.enabled(),
            _ => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table lists exactly the keys the settings serialize, in order: a field added to
    /// a settings struct without its line here fails.
    #[test]
    fn the_table_lists_every_serialized_key() {
        let keys: Vec<String> = RenderSettings::default()
            .entries()
            .into_iter()
            .map(|(k, _)| k)
            .collect();
        let mut table: Vec<String> = SETTINGS.iter().map(|s| s.key.to_string()).collect();
        let mut sorted = keys.clone();
        sorted.sort();
        table.sort();
        assert_eq!(sorted, table);
    }

    #[test]
    fn set_writes_every_kind_of_value_and_checks_it() {
        let mut s = RenderSettings::default();
        s.set("render.sss.samples", "9").unwrap();
        s.set("sss.method", "hable13").unwrap();
        s.set("transmittance.method", "\"paper\"").unwrap();
        s.set("exposure_ev", "1").unwrap();
        s.set("ambient", "[0.5, 0.25, 0]").unwrap();
        s.set("sss.gaussians", "[true, false, true, true, true]")
            .unwrap();
        assert_eq!(s.sss.samples, 9);
        assert_eq!(s.sss.method, SssMethod::Hable13);
        assert_eq!(s.transmittance.method, TransmittanceMethod::Paper);
        assert_eq!(s.exposure_ev, 1.0);
        assert_eq!(s.ambient, [0.5, 0.25, 0.0]);
        assert!(!s.sss.gaussians[1]);
        let before = s.clone();
        for (key, value, want) in [
            (
                "render.sss.sampels",
                "9",
                "render.sss.sampels: unknown key; the keys of render.sss are method, samples,",
            ),
            (
                "render.colour",
                "1",
                "render.colour: unknown key; the keys of render are quality, width, height,",
            ),
            ("sss.samples", "4", "render.sss.samples: must be odd"),
            (
                "transmittance.lateral_texel_mm",
                "2",
                "render.transmittance.lateral_texel_mm: this key is now render.transmitted_map.texel_mm",
            ),
            ("sss.samples", "abc", "render.sss.samples: "),
            ("sss.method", "blurry", "render.sss.method: "),
            ("exposure_ev", "nan", "render.exposure_ev: must be finite"),
            (
                "exposure_ev",
                "1e39",
                "render.exposure_ev: 1e39 is out of range of a 32-bit float",
            ),
        ] {
            let e = s.set(key, value).unwrap_err().to_string();
            assert!(e.starts_with(want), "{key}={value}: {e}");
            assert!(!e.contains('\n'), "{e}");
            assert_eq!(s, before, "a failed set changes nothing");
        }
    }

    #[test]
    fn values_read_as_written() {
        let s = RenderSettings::default();
        let text = |k: &str| {
            let v = s.entries().into_iter().find(|(key, _)| key == k).unwrap().1;
            value_text(&v)
        };
        assert_eq!(text("ambient"), "[0.02, 0.02, 0.02]");
        assert_eq!(text("exposure_ev"), "0.0");
        assert_eq!(text("sss.method"), "\"separable\"");
        for x in [1e30f32, -3.4e38, 1e-7, 0.0, 2.5, f32::NAN, f32::INFINITY] {
            let v = toml::Value::Float(f64::from(x));
            let back = parse_value(&value_text(&v));
            let y = back.as_float().unwrap_or_else(|| panic!("{x}: {back:?}")) as f32;
            assert!(y == x || (x.is_nan() && y.is_nan()), "{x} read back as {y}");
        }
    }

    #[test]
    fn keys_matter_only_where_their_method_runs() {
        let mut s = RenderSettings::default();
        s.sss.method = SssMethod::Hable13;
        s.transmittance.method = TransmittanceMethod::Paper;
        assert!(!s.matters("render.sss.samples"));
        assert!(!s.matters("transmittance.lateral_taps"));
        assert!(s.matters("sss.fetch"));
        s.bounce.ring = 0;
        assert!(!s.matters("bounce.cell_mm"));
        assert!(s.matters("bounce.ring"));
    }
}
