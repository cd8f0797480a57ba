//! What the passes need of each material, GPU-free: its profile as Gaussians, its measured
//! coefficients, and the screen-space profile table with each object's row in it.

use std::collections::HashMap;

use std::sync::Arc;

use subsurface_profile::{
    Dipole, KernelParams, Material, Medium, ScreenKernels, SumOfGaussians, TransmittanceLut,
    TransportTable, material, slab_transport,
};

use crate::error::RenderError;
use crate::scene::{MaterialDesc, Scene};

/// A material's profile as Gaussians (fitted for measured materials), its extinction
/// coefficient for Beer-Lambert, per millimetre, and its measured coefficients for
/// diffusion-theory transmittance.
#[derive(Clone, Debug)]
pub struct MaterialOptics {
    /// The diffusion profile R(r) as a sum of Gaussians, in mm and mm²: d'Eon's for the skin
    /// preset, a six-Gaussian fit of the medium's R(r) otherwise.
    pub profile: SumOfGaussians,
    /// Reduced extinction sigma_a + sigma_s' per mm, for Beer-Lambert (skin1's for the Gaussian
    /// preset).
    pub sigma_t: [f32; 3],
    /// The medium's coefficients and index of refraction (skin1's for the Gaussian preset).
    pub dipole: Dipole,
    /// The preset is d'Eon's skin Gaussians, for which the papers' own kernels exist.
    pub is_skin_preset: bool,
    /// What the material's albedo (and colour texture) multiplies: the medium's total
    /// diffuse reflectance for a measured medium (exact transport, `transport.albedo`), so
    /// that the real-time colour is the path-traced medium's; 1 for the Gaussian skin preset,
    /// whose weights carry no colour.
    pub diffuse_albedo: [f32; 3],
    /// Exact transport through slabs of the medium (skin1's for the Gaussian preset): the
    /// `diffusion` transmittance's T(s) and the diffuse albedo. Shared: the solve takes a
    /// few hundred milliseconds, once per medium.
    pub transport: Arc<TransportTable>,
}

/// Jensen et al. 2001's skin1 (sigma_a, sigma_s' in 1/mm, eta), what the Gaussian skin preset
/// uses where measured coefficients are needed.
fn skin1() -> Dipole {
    match material("skin1") {
        Ok(Material::Dipole { dipole, .. }) => dipole,
        _ => unreachable!("skin1 is a measured preset"),
    }
}

/// Looks materials up by name and fits measured ones once.
///
/// Fitting six Gaussians to a medium's R(r) costs tens of milliseconds; `Renderer::update`
/// derives the optics afresh on every edit, and the viewer updates on every frame a slider
/// moves (the soak spent 85 % of its time refitting the same skin1). So besides this
/// cache's own map, the optics of the last [`FITTED_KEPT`] media are kept for the whole
/// process: they are a pure function of the medium's exact coefficients.
#[derive(Default)]
pub struct MaterialCache {
    cache: HashMap<String, MaterialOptics>,
}

/// How many media's optics the process keeps (a scene has a handful; a sweep over media
/// evicts the oldest).
pub const FITTED_KEPT: usize = 64;

/// The process-wide memo behind [`MaterialCache`], oldest first.
fn fitted() -> std::sync::MutexGuard<'static, Vec<(String, MaterialOptics)>> {
    static FITTED: std::sync::Mutex<Vec<(String, MaterialOptics)>> =
        std::sync::Mutex::new(Vec::new());
    // A panic while holding the lock cannot leave a half-written entry (entries are pushed
    // whole), so a poisoned memo is still a good one.
    FITTED.lock().unwrap_or_else(|e| e.into_inner())
}

impl MaterialCache {
    /// The optics of `medium`, from this cache, the process's memo, or derived and fitted; `field`
    /// names the material in errors.
    pub fn get(&mut self, medium: &Medium, field: &str) -> Result<MaterialOptics, RenderError> {
        let key = medium.to_string();
        if let Some(m) = self.cache.get(&key) {
            return Ok(m.clone());
        }
        if let Some((_, m)) = fitted().iter().find(|(k, _)| *k == key) {
            self.cache.insert(key, m.clone());
            return Ok(m.clone());
        }
        let optics = Self::derive(medium, field)?;
        let mut memo = fitted();
        if memo.len() >= FITTED_KEPT {
            memo.remove(0);
        }
        memo.push((key.clone(), optics.clone()));
        drop(memo);
        self.cache.insert(key, optics.clone());
        Ok(optics)
    }

    /// The optics of `medium`, derived (and for a measured medium, fitted) from scratch.
    fn derive(medium: &Medium, field: &str) -> Result<MaterialOptics, RenderError> {
        let m = medium
            .material()
            .map_err(|e| RenderError::invalid(field, e.to_string()))?;
        let transport = |dipole: &Dipole| {
            slab_transport(
                dipole,
                TransmittanceLut::TRANSPORT_POINTS,
                f64::from(TransmittanceLut::DIFFUSION_S_MAX_MM),
            )
            .map(Arc::new)
            .map_err(|e| RenderError::invalid(field, e.to_string()))
        };
        let optics = match &m {
            Material::Gaussians { profile, .. } => {
                let dipole = skin1();
                MaterialOptics {
                    profile: profile.clone(),
                    sigma_t: [0, 1, 2]
                        .map(|c| (dipole.sigma_a[c] + dipole.sigma_s_prime[c]) as f32),
                    transport: transport(&dipole)?,
                    dipole,
                    is_skin_preset: true,
                    diffuse_albedo: [1.0; 3],
                }
            }
            Material::Dipole { dipole, .. }
            | Material::Multipole {
                multipole: subsurface_profile::Multipole { dipole, .. },
                ..
            } => {
                let fit = m
                    .fit(6)
                    .map_err(|e| RenderError::invalid(field, e.to_string()))?;
                let sigma_t =
                    [0, 1, 2].map(|c| (dipole.sigma_a[c] + dipole.sigma_s_prime[c]) as f32);
                let transport = transport(dipole)?;
                MaterialOptics {
                    profile: fit.profile,
                    sigma_t,
                    dipole: *dipole,
                    is_skin_preset: false,
                    diffuse_albedo: transport.albedo.map(|r| r as f32),
                    transport,
                }
            }
        };
        Ok(optics)
    }
}

/// The screen-space kernels of one material: the skin preset gets the papers' own tables,
/// a measured material kernels built from its fitted profile.
pub fn screen_kernels(
    optics: &MaterialOptics,
    material: &MaterialDesc,
    samples: u32,
) -> Result<ScreenKernels, subsurface_profile::ProfileError> {
    let (strength, falloff) = material.kernel_params(optics.is_skin_preset);
    let params = KernelParams {
        samples,
        strength,
        falloff,
    };
    if optics.is_skin_preset {
        ScreenKernels::skin(&params)
    } else {
        ScreenKernels::for_profile(&optics.profile, &params)
    }
}

/// The screen-space profile table of a scene: one row per distinct (profile, kernel strength,
/// falloff) among its scattering materials, and each object's row. Objects that do not
/// scatter get row 0 (the table always has one row, so the passes can bind it).
#[derive(Clone, Debug)]
pub struct ProfileTable {
    /// One row per distinct profile and kernel parameters; row 0 always exists.
    pub kernels: Vec<ScreenKernels>,
    /// One per `scene.objects`.
    pub object_rows: Vec<u32>,
}

/// Most distinct profiles in one frame: the index is stored in a half float, exact to 2048.
pub const MAX_PROFILES: usize = 1024;

impl ProfileTable {
    /// The table of `scene`'s scattering materials, with separable kernels of `samples` taps;
    /// errors when a medium is invalid or there are more than [`MAX_PROFILES`] rows.
    pub fn for_scene(
        scene: &Scene,
        samples: u32,
        cache: &mut MaterialCache,
    ) -> Result<Self, RenderError> {
        let mut keys: Vec<(String, [u32; 6])> = Vec::new();
        let mut kernels = Vec::new();
        let mut object_rows = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let m = &o.material;
            if m.sss_strength <= 0.0 {
                object_rows.push(0);
                continue;
            }
            let field = format!("objects[{i}].material.medium");
            let optics = cache.get(&m.medium, &field)?;
            let (s, f) = m.kernel_params(optics.is_skin_preset);
            let key = (
                m.medium.to_string(),
                [s[0], s[1], s[2], f[0], f[1], f[2]].map(f32::to_bits),
            );
            let row = match keys.iter().position(|k| *k == key) {
                Some(r) => r,
                None => {
                    if keys.len() == MAX_PROFILES {
                        return Err(RenderError::invalid(
                            field,
                            format!("more than {MAX_PROFILES} distinct profiles in one frame"),
                        ));
                    }
                    kernels.push(
                        screen_kernels(&optics, m, samples)
                            .map_err(|e| RenderError::invalid(field, e.to_string()))?,
                    );
                    keys.push(key);
                    keys.len() - 1
                }
            };
            object_rows.push(row as u32);
        }
        if kernels.is_empty() {
            let skin = MaterialDesc::default();
            kernels.push(
                ScreenKernels::skin(&KernelParams {
                    samples,
                    strength: skin.kernel_params(true).0,
                    falloff: skin.kernel_params(true).1,
                })
                .map_err(RenderError::from)?,
            );
        }
        Ok(Self {
            kernels,
            object_rows,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use subsurface_profile::Coefficients;

    fn medium(k: usize) -> Medium {
        Medium::Coefficients(Coefficients {
            sigma_a: [0.03 + 0.001 * k as f64, 0.1, 0.2],
            sigma_s: [7.0, 8.0, 9.0],
            eta: 1.4,
        })
    }

    /// A fresh cache (each `Renderer::update` makes one) finds a medium fitted before in the
    /// process-wide memo, identical to a fit from scratch; the memo keeps the newest
    /// [`FITTED_KEPT`] media.
    #[test]
    fn fits_are_kept_across_caches_and_the_oldest_evicted() {
        let key = |k| medium(k).to_string();
        let kept = |k| fitted().iter().any(|(x, _)| *x == key(k));
        let first = MaterialCache::default().get(&medium(0), "m").unwrap();
        assert!(kept(0));
        let again = MaterialCache::default().get(&medium(0), "m").unwrap();
        let scratch = MaterialCache::derive(&medium(0), "m").unwrap();
        for o in [&again, &scratch] {
            assert_eq!(o.profile, first.profile);
            assert_eq!(o.diffuse_albedo, first.diffuse_albedo);
        }
        for k in 1..=FITTED_KEPT {
            MaterialCache::default().get(&medium(k), "m").unwrap();
        }
        assert!(!kept(0), "the oldest medium was not evicted");
        assert!(kept(FITTED_KEPT) && fitted().len() <= FITTED_KEPT);
        // A bad medium is an error naming the field, and is not memoised.
        let mut bad = medium(0);
        if let Medium::Coefficients(c) = &mut bad {
            c.sigma_a[1] = -1.0;
        }
        let e = MaterialCache::default().get(&bad, "objects[2].material.medium");
        assert!(
            e.unwrap_err()
                .to_string()
                .contains("objects[2].material.medium")
        );
        assert!(!fitted().iter().any(|(x, _)| *x == bad.to_string()));
    }
}
