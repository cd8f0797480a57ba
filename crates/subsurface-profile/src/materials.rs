//! Named materials: d'Eon's skin profile and the measured coefficients of
//! Jensen et al. 2001, with helpers to fit Gaussians and derive kernels and T(s).

use serde::Serialize;

use crate::dipole::{Dipole, Multipole};
use crate::error::{ProfileError, Result};
use crate::fit::{GaussianFit, fit_sum_of_gaussians};
use crate::gaussian::SumOfGaussians;

/// One row of Jensen et al. 2001's measured table (their Figure 5): reduced
/// scattering and absorption coefficients in mm^-1 for R, G, B.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeasuredMaterial {
    /// Lower-case name without spaces (`"skin1"`, `"wholemilk"`).
    pub name: &'static str,
    /// Reduced scattering coefficient sigma_s' per mm, R, G, B.
    pub sigma_s_prime: [f64; 3],
    /// Absorption coefficient sigma_a per mm, R, G, B.
    pub sigma_a: [f64; 3],
}

/// Relative index of refraction Jensen et al. 2001 assume for all measured materials.
pub const JENSEN2001_ETA: f64 = 1.3;

/// Jensen et al. 2001's measured materials. Spectralon is left out: its measured
/// absorption is 0, which the diffusion model here rejects (`sigma_a` must be > 0).
pub const JENSEN2001_MATERIALS: [MeasuredMaterial; 11] = [
    m("apple", [2.29, 2.39, 1.97], [0.0030, 0.0034, 0.046]),
    m("chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    m("chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.20]),
    m("cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    m("ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    m("marble", [2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071]),
    m("potato", [0.68, 0.70, 0.55], [0.0024, 0.0090, 0.12]),
    m("skimmilk", [0.70, 1.22, 1.90], [0.0014, 0.0025, 0.0142]),
    m("skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    m("skin2", [1.09, 1.59, 1.79], [0.013, 0.070, 0.145]),
    m("wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
];

const fn m(name: &'static str, sigma_s_prime: [f64; 3], sigma_a: [f64; 3]) -> MeasuredMaterial {
    MeasuredMaterial {
        name,
        sigma_s_prime,
        sigma_a,
    }
}

/// A named diffusion profile.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Material {
    /// Given directly as Gaussians (the "skin" preset: d'Eon's six).
    Gaussians {
        /// The preset's name, or the medium written out.
        name: String,
        /// The profile R(r), variances in mm^2.
        profile: SumOfGaussians,
    },
    /// Semi-infinite medium, dipole model.
    Dipole {
        /// The preset's name, or the medium written out.
        name: String,
        /// The medium's coefficients, per mm.
        dipole: Dipole,
    },
    /// Slab of finite thickness, multipole model.
    Multipole {
        /// The preset's name, or the medium written out.
        name: String,
        /// The medium's coefficients and the slab's thickness.
        multipole: Multipole,
    },
}

/// Names accepted by [`material`]: "skin" then Jensen 2001's materials.
pub fn material_names() -> Vec<&'static str> {
    std::iter::once("skin")
        .chain(JENSEN2001_MATERIALS.iter().map(|m| m.name))
        .collect()
}

/// Jensen 2001's skin1 as a dipole: the medium the canonical scenes render, shared by the
/// crate's tests.
#[cfg(test)]
pub(crate) fn skin1() -> crate::Dipole {
    match material("skin1").unwrap() {
        Material::Dipole { dipole, .. } => dipole,
        _ => unreachable!("skin1 is a measured medium"),
    }
}

/// Looks a preset up by name, ignoring case, spaces, '-' and '_'
/// ("Whole milk" = "wholemilk").
pub fn material(name: &str) -> Result<Material> {
    let key: String = name
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .map(|c| c.to_ascii_lowercase())
        .collect();
    if key == "skin" {
        return Ok(Material::Gaussians {
            name: "skin".into(),
            profile: SumOfGaussians::skin(),
        });
    }
    JENSEN2001_MATERIALS
        .iter()
        .find(|m| m.name == key)
        .map(|m| Material::Dipole {
            name: m.name.into(),
            dipole: Dipole::new(m.sigma_a, m.sigma_s_prime, JENSEN2001_ETA)
                .expect("table values are valid"),
        })
        .ok_or_else(|| ProfileError::UnknownMaterial {
            name: name.into(),
            known: material_names().join(", "),
        })
}

impl Material {
    /// The name: a preset's canonical name (`"skin1"`), or a measured medium written out.
    pub fn name(&self) -> &str {
        match self {
            Material::Gaussians { name, .. }
            | Material::Dipole { name, .. }
            | Material::Multipole { name, .. } => name,
        }
    }

    /// The material as a slab of `thickness_mm` (multipole with
    /// [`Multipole::DEFAULT_PAIRS`]); only dipole materials have the coefficients
    /// this needs, so Gaussian presets give an error naming `thickness_mm`.
    pub fn with_thickness(self, thickness_mm: f64) -> Result<Material> {
        match self {
            Material::Dipole { name, dipole }
            | Material::Multipole {
                name,
                multipole: Multipole { dipole, .. },
            } => {
                // The multipole puts its real source one mean free path deep; a slab thinner
                // than that has the source outside it and the sums turn negative (a
                // transmittance below zero), so such a slab is outside the model.
                let (c, z_r) = (0..3)
                    .map(|c| (c, dipole.channel(c).z_r))
                    .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
                if thickness_mm > 0.0 && thickness_mm.is_finite() && thickness_mm <= z_r {
                    return Err(ProfileError::Invalid {
                        field: "thickness_mm".into(),
                        reason: format!(
                            "{thickness_mm} mm is not thicker than {name}'s mean free path \
                             ({z_r:.3} mm in {}), below which diffusion theory does not hold",
                            ["red", "green", "blue"][c]
                        ),
                    });
                }
                Ok(Material::Multipole {
                    name,
                    multipole: Multipole::new(dipole, thickness_mm, Multipole::DEFAULT_PAIRS)?,
                })
            }
            Material::Gaussians { name, .. } => Err(ProfileError::Invalid {
                field: "thickness_mm".into(),
                reason: format!(
                    "material {name} is given as Gaussians, not scattering coefficients"
                ),
            }),
        }
    }

    /// Reflectance profile `R(r)`, mm^-2 per channel.
    pub fn profile(&self, r_mm: f64) -> [f64; 3] {
        match self {
            Material::Gaussians { profile, .. } => profile.eval(r_mm),
            Material::Dipole { dipole, .. } => dipole.reflectance(r_mm),
            Material::Multipole { multipole, .. } => multipole.reflectance(r_mm),
        }
    }

    /// Integral of `R` over the plane (total diffuse reflectance).
    pub fn total_reflectance(&self) -> [f64; 3] {
        match self {
            Material::Gaussians { profile, .. } => profile.total_weight(),
            Material::Dipole { dipole, .. } => dipole.total_reflectance(),
            Material::Multipole { multipole, .. } => multipole.total_reflectance(),
        }
    }

    /// Radius (mm) holding 99.9 % of every channel's reflected energy: the range
    /// [`Material::fit`] covers.
    pub fn fit_radius_mm(&self) -> f64 {
        match self {
            Material::Gaussians { profile, .. } => profile.energy_radius_mm(0.999),
            Material::Dipole { dipole, .. } => dipole.energy_radius_mm(0.999),
            Material::Multipole { multipole, .. } => multipole.energy_radius_mm(0.999),
        }
    }

    /// Fits `k` Gaussians to `R(r)` over [`Material::fit_radius_mm`]. The fitted
    /// profile gives the material's blur kernel (`separable_kernel_for`) and
    /// `T(s)` (`SumOfGaussians::transmittance`, or `normalized()` first for
    /// T(0) = 1 as in the skin shader).
    pub fn fit(&self, k: usize) -> Result<GaussianFit> {
        fit_sum_of_gaussians(|r| self.profile(r), k, self.fit_radius_mm())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_is_forgiving_and_unknown_names_list_the_known_ones() {
        assert_eq!(material("Whole milk").unwrap().name(), "wholemilk");
        assert_eq!(material("skin-1").unwrap().name(), "skin1");
        match material("skin").unwrap() {
            Material::Gaussians { profile, .. } => assert_eq!(profile, SumOfGaussians::skin()),
            other => panic!("skin must be the six Gaussians, got {other:?}"),
        }
        let e = material("granite").unwrap_err().to_string();
        assert!(e.starts_with("material: unknown name \"granite\""), "{e}");
        assert!(e.contains("marble") && !e.contains('\n'));
        assert_eq!(material_names().len(), 12);
    }

    #[test]
    fn every_preset_has_a_valid_dipole_and_a_decent_fit() {
        for name in ["skin1", "marble", "ketchup"] {
            let mat = material(name).unwrap();
            let fit = mat.fit(6).unwrap();
            // d'Eon et al. report a few percent for dipoles with six Gaussians.
            assert!(fit.max_error() < 0.05, "{name}: {:?}", fit.rel_l2_error);
            // The fit carries (almost) all of the reflected energy.
            let total = mat.total_reflectance();
            let got = fit.profile.total_weight();
            for c in 0..3 {
                assert!(
                    (got[c] - total[c]).abs() < 0.05 * total[c] + 1e-4,
                    "{name} c{c}"
                );
            }
        }
        for m in JENSEN2001_MATERIALS {
            assert!(Dipole::new(m.sigma_a, m.sigma_s_prime, JENSEN2001_ETA).is_ok());
        }
    }

    #[test]
    fn thickness_turns_a_dipole_into_a_slab() {
        let slab = material("marble").unwrap().with_thickness(3.0).unwrap();
        assert!(matches!(slab, Material::Multipole { .. }));
        let semi = material("marble").unwrap();
        assert!(slab.total_reflectance()[0] < semi.total_reflectance()[0]);
        assert!(material("skin").unwrap().with_thickness(3.0).is_err());
        assert!(material("marble").unwrap().with_thickness(0.0).is_err());
        // Thinner than a mean free path: outside the model (it gave T < 0), an error.
        let e = material("marble")
            .unwrap()
            .with_thickness(0.1)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("thickness_mm: 0.1 mm is not thicker than"),
            "{e}"
        );
        // Just above it, every channel's transmittance is a fraction.
        let Material::Multipole { multipole, .. } =
            material("marble").unwrap().with_thickness(0.5).unwrap()
        else {
            panic!("a slab is a multipole")
        };
        for t in multipole.total_transmittance() {
            assert!((0.0..=1.0).contains(&t), "{t}");
        }
    }
}
