//! A scattering medium as a scene names it: a preset (d'Eon's skin Gaussians or one of
//! Jensen et al. 2001's measured materials) or its own measured coefficients. Everything
//! else a material needs, the Gaussian-sum profile, T(s) and the diffuse albedo R_d, is
//! derived from it, so the real-time side and the path tracer render the same material.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::dipole::Dipole;
use crate::error::{CHANNELS, Result, positive};
use crate::exact_array::exact;
use crate::materials::{JENSEN2001_ETA, Material, material};

/// `medium = "skin1"` or `medium = { sigma_a = [..], sigma_s = [..], eta = 1.3 }` in a scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Medium {
    /// A preset of [`crate::material_names`].
    Preset(String),
    /// Measured coefficients.
    Coefficients(Coefficients),
}

/// A homogeneous medium's optical coefficients, per millimetre, red/green/blue.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Coefficients {
    /// Absorption coefficient sigma_a, 1/mm, each > 0.
    #[serde(deserialize_with = "exact")]
    pub sigma_a: [f64; 3],
    /// Reduced scattering coefficient sigma_s' = sigma_s (1 - g), 1/mm, each > 0.
    #[serde(deserialize_with = "exact")]
    pub sigma_s: [f64; 3],
    /// Relative index of refraction of the boundary, in 1..=10 (default 1.3, Jensen 2001's).
    #[serde(default = "default_eta")]
    pub eta: f64,
}

impl<'de> Deserialize<'de> for Medium {
    /// As the untagged enum it is, but with an error that says what is expected: serde's own
    /// ("did not match any variant of untagged enum Medium") names neither form.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Preset(String),
            Coefficients(Coefficients),
        }
        Raw::deserialize(d)
            .map(|r| match r {
                Raw::Preset(name) => Medium::Preset(name),
                Raw::Coefficients(c) => Medium::Coefficients(c),
            })
            .map_err(|_| {
                serde::de::Error::custom(
                    "expected a preset name such as \"skin1\" or a table { sigma_a = [r, g, b], \
                     sigma_s = [r, g, b], eta = 1.3 } (three numbers each, eta optional)",
                )
            })
    }
}

/// The coefficients a medium may have, per mm: past them the profile's arithmetic overflows
/// (`sigma_a = 1e300` gave "profile: must be finite (got NaN)") or its radius does. Every
/// measured material lies well inside: water's absorption is 1e-5/mm, skin's scattering 1-3/mm.
pub const SIGMA_RANGE_PER_MM: (f64, f64) = (1e-8, 1e8);

/// The largest ratio between the channels' diffusion lengths `1 / sigma_tr`: one fit of six
/// Gaussians (and one kernel) covers all three channels over the widest one's radius, so a
/// channel far narrower falls inside the narrowest Gaussian and its profile vanished
/// ("kernel sum.g (profile vanishes)"). Ratios of 2e7 still rendered, 2e9 did not.
pub const MAX_CHANNEL_SPREAD: f64 = 1e6;

/// Rejects coefficients whose channels' diffusion lengths are more than
/// [`MAX_CHANNEL_SPREAD`] apart, naming the coefficient (`sigma_a` or `sigma_s`) that differs
/// more between the widest and the narrowest channel.
fn check_channel_spread(c: &Coefficients) -> Result<()> {
    let length = |ch: usize| 1.0 / (3.0 * c.sigma_a[ch] * (c.sigma_a[ch] + c.sigma_s[ch])).sqrt();
    let (wide, narrow) = (0..3).fold((0, 0), |(w, n), ch| {
        (
            if length(ch) > length(w) { ch } else { w },
            if length(ch) < length(n) { ch } else { n },
        )
    });
    let spread = length(wide) / length(narrow);
    if spread <= MAX_CHANNEL_SPREAD {
        return Ok(());
    }
    let ratio = |v: [f64; 3]| (v[wide] / v[narrow]).max(v[narrow] / v[wide]);
    let name = if ratio(c.sigma_a) >= ratio(c.sigma_s) {
        "sigma_a"
    } else {
        "sigma_s"
    };
    Err(crate::ProfileError::Invalid {
        field: name.into(),
        reason: format!(
            "the channels' diffusion lengths 1/sqrt(3 sigma_a (sigma_a + sigma_s)) are {:.3e} mm \
             ({}) and {:.3e} mm ({}), {spread:.1e} times apart: at most {MAX_CHANNEL_SPREAD:e} \
             is supported (one fit covers all three channels)",
            length(wide),
            CHANNELS[wide],
            length(narrow),
            CHANNELS[narrow]
        ),
    })
}

fn default_eta() -> f64 {
    JENSEN2001_ETA
}

impl Default for Medium {
    fn default() -> Self {
        Medium::Preset("skin".into())
    }
}

impl fmt::Display for Medium {
    /// The preset's name, or the coefficients in the scene's syntax: also the key under
    /// which a renderer caches the derived profile.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Medium::Preset(name) => f.write_str(name),
            Medium::Coefficients(c) => write!(
                f,
                "{{ sigma_a = {:?}, sigma_s = {:?}, eta = {} }}",
                c.sigma_a, c.sigma_s, c.eta
            ),
        }
    }
}

impl Medium {
    /// The material: a preset looked up by name, coefficients validated (each finite and
    /// > 0, eta in 1..=10) into a dipole whose fitted Gaussians give the profile and T(s).
    pub fn material(&self) -> Result<Material> {
        match self {
            Medium::Preset(name) => material(name),
            Medium::Coefficients(c) => {
                // The scene's names (sigma_s, not the dipole's sigma_s_prime) in the errors.
                for ch in 0..3 {
                    for (name, v) in [("sigma_a", c.sigma_a[ch]), ("sigma_s", c.sigma_s[ch])] {
                        let field = format!("{name}.{}", CHANNELS[ch]);
                        positive(&field, v)?;
                        let (lo, hi) = SIGMA_RANGE_PER_MM;
                        if !(lo..=hi).contains(&v) {
                            return Err(crate::ProfileError::Invalid {
                                field,
                                reason: format!("must be in {lo:e}..={hi:e} per mm (got {v:e})"),
                            });
                        }
                    }
                }
                check_channel_spread(c)?;
                Ok(Material::Dipole {
                    name: self.to_string(),
                    dipole: Dipole::new(c.sigma_a, c.sigma_s, c.eta)?,
                })
            }
        }
    }

    /// The measured coefficients behind the medium, when it has one: d'Eon's three-layer
    /// skin Gaussians are a fit to several layers, not one homogeneous medium.
    pub fn dipole(&self) -> Result<Option<Dipole>> {
        Ok(match self.material()? {
            Material::Gaussians { .. } => None,
            Material::Dipole { dipole, .. } => Some(dipole),
            Material::Multipole { multipole, .. } => Some(multipole.dipole),
        })
    }

    /// Total diffuse reflectance R_d of a semi-infinite block of the medium (Jensen 2001's
    /// closed form): the colour it shows under uniform light. None for the Gaussian preset,
    /// whose weights are normalised and carry no colour.
    pub fn diffuse_albedo(&self) -> Result<Option<[f64; 3]>> {
        Ok(self.dipole()?.map(|d| d.total_reflectance()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    struct M {
        medium: Medium,
    }

    fn parse(s: &str) -> std::result::Result<Medium, String> {
        serde_json::from_str::<M>(s)
            .map(|m| m.medium)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn a_preset_and_its_coefficients_are_the_same_material() {
        let preset = parse(r#"{"medium": "skin1"}"#).unwrap();
        let coeffs =
            parse(r#"{"medium": {"sigma_a": [0.032, 0.17, 0.48], "sigma_s": [0.74, 0.88, 1.01]}}"#)
                .unwrap();
        assert_eq!(preset.dipole().unwrap(), coeffs.dipole().unwrap());
        // Jensen 2001's skin1 reflects mostly red: R_d from the dipole's closed form.
        let rd = coeffs.diffuse_albedo().unwrap().unwrap();
        assert!(
            (rd[0] - 0.436).abs() < 2e-3 && (rd[2] - 0.131).abs() < 2e-3,
            "{rd:?}"
        );
        assert!(coeffs.to_string().starts_with("{ sigma_a = [0.032"));
    }

    #[test]
    fn the_gaussian_skin_preset_has_no_single_medium() {
        let skin = Medium::default();
        assert_eq!(skin.to_string(), "skin");
        assert_eq!(skin.dipole().unwrap(), None);
        assert_eq!(skin.diffuse_albedo().unwrap(), None);
    }

    #[test]
    fn bad_coefficients_name_the_field() {
        for (json, field) in [
            (
                r#"{"sigma_a": [0.0, 1, 1], "sigma_s": [1, 1, 1]}"#,
                "sigma_a.r",
            ),
            (
                r#"{"sigma_a": [1, 1, 1], "sigma_s": [1, -1, 1]}"#,
                "sigma_s.g",
            ),
            (
                r#"{"sigma_a": [1, 1, 1], "sigma_s": [1, 1, 1], "eta": 0.5}"#,
                "eta",
            ),
        ] {
            let m = parse(&format!(r#"{{"medium": {json}}}"#)).unwrap();
            let e = m.material().unwrap_err().to_string();
            assert!(e.starts_with(field), "{e}");
        }
        // Neither form: the error says what either form looks like.
        let e = parse(r#"{"medium": {"sigma_a": [1, 1, 1]}}"#).unwrap_err();
        assert!(
            e.contains("\"skin1\"") && e.contains("sigma_s = [r, g, b]"),
            "{e}"
        );
        assert!(
            Medium::Preset("velvet".into())
                .material()
                .unwrap_err()
                .to_string()
                .contains("skin1")
        );
    }

    /// Extreme media are errors naming the coefficient, in the scene's words, never an
    /// internal quantity ("kernel sum.b", "profile: must be finite (got NaN)").
    #[test]
    fn extreme_coefficients_name_the_coefficient() {
        let coeffs = |sigma_a: [f64; 3], sigma_s: [f64; 3]| {
            Medium::Coefficients(Coefficients {
                sigma_a,
                sigma_s,
                eta: 1.3,
            })
            .material()
            .map(|_| ())
            .map_err(|e| e.to_string())
        };
        let e = coeffs([1e300, 0.02, 0.05], [1.0; 3]).unwrap_err();
        assert_eq!(e, "sigma_a.r: must be in 1e-8..=1e8 per mm (got 1e300)");
        let e = coeffs([0.01; 3], [1.0, 1e-40, 1.0]).unwrap_err();
        assert!(e.starts_with("sigma_s.g: must be in"), "{e}");
        let e = coeffs([1e-8, 100.0, 100.0], [1.0; 3]).unwrap_err();
        assert!(
            e.starts_with("sigma_a: the channels' diffusion lengths"),
            "{e}"
        );
        assert!(e.contains("(r)") && e.contains("(g)"), "{e}");
        let e = coeffs([1e-6; 3], [1e-8, 1.0, 1e8]).unwrap_err();
        assert!(e.starts_with("sigma_s: the channels'"), "{e}");
        // Wide but supported media still are.
        coeffs([1e-4, 0.1, 0.1], [1e-4, 1.0, 1.0]).unwrap();
        coeffs([1e-8; 3], [1e-8; 3]).unwrap();
        coeffs([1e8; 3], [1e8; 3]).unwrap();
    }
}
