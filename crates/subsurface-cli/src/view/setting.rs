//! One `[render]` setting as the panel edits it, without a window: its value in a form the
//! panel can hold, the widget its type calls for, and applying an edit through
//! `RenderSettings::set`, so that the scene file's checks run. A rejected edit is kept with
//! its one-line error, to be shown in place of the value until the next edit of that key.
//!
//! The render crate's table [`SETTINGS`] is the one declaration: every key, its unit and doc.
//! The values come from `RenderSettings::entries()` (TOML values; this crate reads them
//! through their accessors and writes them back as TOML text).

use subsurface_render::settings::{Quality, value_text};
use subsurface_render::{
    MapEvaluation, OutlineChords, RenderSettings, SETTINGS, SettingDoc, SssFetch, SssMethod,
    TransmittanceMethod,
};

use super::state::Which;

/// A setting's value: the TOML types the settings serialize to.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    Array(Vec<Value>),
    /// A type no setting has yet: shown as its TOML text, not editable.
    Other(String),
}

/// A TOML value (whatever the type, read through its accessors) as a [`Value`].
macro_rules! scalar {
    ($v:expr) => {{
        let v = $v;
        if let Some(b) = v.as_bool() {
            Value::Bool(b)
        } else if let Some(i) = v.as_integer() {
            Value::Int(i)
        } else if let Some(x) = v.as_float() {
            Value::Float(x)
        } else if let Some(s) = v.as_str() {
            Value::Str(s.to_string())
        } else {
            Value::Other(value_text(v))
        }
    }};
}

impl Value {
    /// Every key of `s` with its value, in the order of [`SETTINGS`].
    pub fn entries(s: &RenderSettings) -> Vec<(&'static SettingDoc, Value)> {
        let mut all: Vec<(String, Value)> = s
            .entries()
            .into_iter()
            .map(|(k, v)| {
                let value = match v.as_array() {
                    Some(a) => Value::Array(a.iter().map(|e| scalar!(e)).collect()),
                    None => scalar!(&v),
                };
                (k, value)
            })
            .collect();
        SETTINGS
            .iter()
            .filter_map(|doc| {
                let i = all.iter().position(|(k, _)| k == doc.key)?;
                Some((doc, all.swap_remove(i).1))
            })
            .collect()
    }

    /// The value as a scene file writes it: what `RenderSettings::set` reads.
    pub fn text(&self) -> String {
        match self {
            Value::Bool(b) => b.to_string(),
            Value::Int(i) => i.to_string(),
            Value::Float(x) => value_text(&(*x).into()),
            Value::Str(s) => value_text(&s.as_str().into()),
            Value::Array(a) => {
                let items: Vec<String> = a.iter().map(Value::text).collect();
                format!("[{}]", items.join(", "))
            }
            Value::Other(t) => t.clone(),
        }
    }
}

/// The widget a setting gets.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    Check,
    /// A drag value over integers, moving `speed` per point dragged.
    Int {
        speed: f64,
    },
    /// A drag value over floats, moving `speed` per point dragged.
    Float {
        speed: f64,
    },
    /// A drop-down of these names (a method enum).
    Choice(Vec<&'static str>),
    /// A text field, applied when it loses focus.
    Text,
    /// One widget per element.
    Array(Vec<Kind>),
    /// Shown, not edited: `width` and `height`, which the viewer keeps at the 3D view's size.
    ReadOnly,
}

/// Keys the viewer sets itself: the image size follows the 3D view's.
pub const VIEW_SIZED: [&str; 2] = ["width", "height"];

/// The widget for `doc`'s key holding `v`.
pub fn kind(doc: &SettingDoc, v: &Value) -> Kind {
    if VIEW_SIZED.contains(&doc.key) {
        return Kind::ReadOnly;
    }
    match v {
        Value::Bool(_) => Kind::Check,
        Value::Int(i) => Kind::Int {
            speed: (*i as f64 * 0.01).abs().max(0.05),
        },
        Value::Float(x) => Kind::Float {
            speed: float_speed(doc.unit, *x),
        },
        Value::Str(_) => choices(doc.key).map_or(Kind::Text, Kind::Choice),
        Value::Array(a) => Kind::Array(a.iter().map(|e| kind(doc, e)).collect()),
        Value::Other(_) => Kind::ReadOnly,
    }
}

/// Drag speed of a float: 1 % of its value per point, so that values of any scale (a
/// normal shrink of 0.0005 scene units, a texel of 10 mm) move alike, with a floor in the
/// unit's own terms so that zero can be left.
pub fn float_speed(unit: &str, x: f64) -> f64 {
    let floor = match unit {
        "stops" | "px" => 0.01,
        "mm" | "linear RGB" | "" => 0.001,
        _ => 1e-5,
    };
    (x.abs() * 0.01).max(floor)
}

/// The names a string key takes: the method enums' (and the quality presets') `ALL`, in
/// their order.
pub fn choices(key: &str) -> Option<Vec<&'static str>> {
    fn names<T: Copy>(all: &[T], name: fn(T) -> &'static str) -> Vec<&'static str> {
        all.iter().map(|&m| name(m)).collect()
    }
    Some(match key {
        "sss.method" => names(&SssMethod::ALL, SssMethod::name),
        "sss.fetch" => names(&SssFetch::ALL, SssFetch::name),
        "transmittance.method" => names(&TransmittanceMethod::ALL, TransmittanceMethod::name),
        "transmitted_map.pass" => names(&MapEvaluation::ALL, MapEvaluation::name),
        "transmitted_map.outlines" => names(&OutlineChords::ALL, OutlineChords::name),
        "quality" => names(&Quality::ALL, Quality::name),
        _ => return None,
    })
}

/// The hover text of a key: its scene-file name, unit and doc.
pub fn hover_text(doc: &SettingDoc) -> String {
    let unit = if doc.unit.is_empty() {
        String::new()
    } else {
        format!(" [{}]", doc.unit)
    };
    let mut text = format!("render.{}{unit}: {}", doc.key, doc.doc);
    if VIEW_SIZED.contains(&doc.key) {
        text.push_str("\nthe viewer keeps this at the 3D view's size");
    }
    text
}

/// An edit `RenderSettings::set` refused: shown in place of the value, with its error.
#[derive(Clone, Debug, PartialEq)]
pub struct Rejected {
    pub which: Which,
    pub key: &'static str,
    pub value: Value,
    pub error: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::model::Model;
    use crate::view::model::tests::model;
    use crate::view::state::per_side;

    fn value(m: &Model, which: Which, key: &str) -> Value {
        Value::entries(&m.state.settings(which))
            .into_iter()
            .find(|(d, _)| d.key == key)
            .unwrap()
            .1
    }

    #[test]
    fn every_key_has_a_value_that_reads_back_as_written() {
        let s = RenderSettings::default();
        let all = Value::entries(&s);
        assert_eq!(all.len(), SETTINGS.len());
        for (d, v) in &all {
            let mut t = s.clone();
            t.set(d.key, &v.text()).unwrap();
            assert_eq!(t, s, "{}: {}", d.key, v.text());
            assert!(!matches!(v, Value::Other(_)), "{}: {v:?}", d.key);
        }
    }

    #[test]
    fn each_type_gets_its_widget() {
        let s = RenderSettings::default();
        let kinds: Vec<(&str, Kind)> = Value::entries(&s)
            .iter()
            .map(|(d, v)| (d.key, kind(d, v)))
            .collect();
        let of = |k: &str| kinds.iter().find(|(key, _)| *key == k).unwrap().1.clone();
        assert_eq!(of("width"), Kind::ReadOnly);
        assert_eq!(of("sss.jitter"), Kind::Check);
        assert!(matches!(of("sss.samples"), Kind::Int { .. }));
        assert!(matches!(of("exposure_ev"), Kind::Float { speed } if speed == 0.01));
        assert_eq!(
            of("sss.method"),
            Kind::Choice(vec!["none", "gaussian6", "separable", "hable13", "texture"])
        );
        assert_eq!(
            of("transmitted_map.pass"),
            Kind::Choice(vec!["auto", "compute", "fragment"])
        );
        assert!(matches!(of("ambient"), Kind::Array(k) if k.len() == 3
            && k.iter().all(|k| matches!(k, Kind::Float { .. }))));
        assert_eq!(of("sss.gaussians"), Kind::Array(vec![Kind::Check; 5]));
        // Every string key is a method with a drop-down, every name one `set` accepts.
        for (d, v) in Value::entries(&s) {
            if let Value::Str(_) = v {
                let Kind::Choice(names) = kind(d, &v) else {
                    panic!("{}: no drop-down", d.key)
                };
                for n in names {
                    s.clone().set(d.key, &Value::Str(n.into()).text()).unwrap();
                }
            }
        }
    }

    #[test]
    fn float_speed_follows_the_value() {
        assert_eq!(float_speed("scene units", 0.0005), 1e-5);
        assert!((float_speed("mm", 10.0) - 0.1).abs() < 1e-12);
        assert_eq!(float_speed("stops", 0.0), 0.01);
    }

    #[test]
    fn edits_apply_through_the_scene_files_checks() {
        let mut m = model();
        assert!(m.set_setting(Which::A, "sss.samples", Value::Int(9)));
        assert_eq!(m.state.a.sss.samples, 9);
        assert!(m.dirty.update);
        m.dirty.update = false;
        // Even counts are refused: nothing changes, the value and error are kept to show.
        assert!(!m.set_setting(Which::A, "sss.samples", Value::Int(10)));
        assert_eq!(m.state.a.sss.samples, 9);
        assert!(!m.dirty.update);
        let r = m.rejected(Which::A, "sss.samples").unwrap();
        assert_eq!(r.value, Value::Int(10));
        assert!(
            r.error.starts_with("render.sss.samples: must be odd"),
            "{}",
            r.error
        );
        assert!(!r.error.contains('\n'));
        assert_eq!(value(&m, Which::A, "sss.samples"), Value::Int(9));
        // The next good edit clears it.
        assert!(m.set_setting(Which::A, "sss.samples", Value::Int(11)));
        assert!(m.rejected(Which::A, "sss.samples").is_none());
        // Out of range and of the wrong type alike.
        assert!(!m.set_setting(Which::A, "exposure_ev", Value::Float(99.0)));
        assert!(!m.set_setting(Which::A, "sss.method", Value::Str("blurry".into())));
        assert_eq!(m.state.a.sss.method, SssMethod::Separable);
    }

    /// The right side's own keys change it alone; the scene's keys change both sides.
    #[test]
    fn sides_hold_their_own_keys_and_share_the_rest() {
        let mut m = model();
        m.state.compare_with(SssMethod::Separable);
        let s = RenderSettings::default();
        for (d, v) in Value::entries(&s) {
            if Kind::ReadOnly == kind(d, &v) {
                continue;
            }
            let changed = match (d.key, v) {
                (k, Value::Str(now)) => {
                    let other = choices(k).unwrap().into_iter().find(|n| *n != now);
                    Value::Str(other.unwrap().into())
                }
                ("sss.samples" | "transmittance.thickness_filter", Value::Int(i)) => {
                    Value::Int(i + 2)
                }
                (_, Value::Int(i)) => Value::Int(if i > 1 { i - 1 } else { i + 1 }),
                (_, Value::Float(x)) => Value::Float(x * 0.5 + 0.25),
                (_, Value::Bool(b)) => Value::Bool(!b),
                (_, Value::Array(mut a)) => {
                    a[1] = match &a[1] {
                        Value::Bool(b) => Value::Bool(!b),
                        Value::Float(x) => Value::Float(x + 0.25),
                        v => v.clone(),
                    };
                    Value::Array(a)
                }
                (k, v) => panic!("{k}: {v:?}"),
            };
            let a_before = value(&m, Which::A, d.key);
            assert!(
                m.set_setting(Which::B, d.key, changed.clone()),
                "{}: {:?}",
                d.key,
                m.ui.rejected
            );
            // As f32 holds it: compared as written.
            assert_eq!(
                value(&m, Which::B, d.key).text(),
                changed.text(),
                "{}",
                d.key
            );
            let a_after = value(&m, Which::A, d.key);
            assert_eq!(a_after == a_before, per_side(d.key), "{}", d.key);
        }
    }
}
