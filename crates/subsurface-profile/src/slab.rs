//! Light through a slab of a measured medium, by Monte Carlo random walks: what a backlit thin
//! part shows where diffusion theory does not hold.
//!
//! The multipole ([`crate::Multipole`]) describes light that has forgotten its direction; a
//! slab a few transport mean free paths thick still passes much of it forward, along the
//! light, so the radiance seen through it (looking toward the light, as at a backlit ear or
//! finger) is several times what a diffuse transmitter of the same total would show. The walk
//! follows the same medium the path tracer renders: `sigma_t = sigma_a + sigma_s'` with an
//! isotropic phase function (the similarity relation the exporter uses), smooth Fresnel
//! boundaries of index `eta` on both faces, collimated light at normal incidence.
//!
//! The tally is the radiance leaving the far face within a cone around the normal, in the
//! renderer's units: `L / E` where a Lambertian transmitter of total transmittance `T` gives
//! exactly `T` (the lighting pass writes `albedo * E`, and the exporter scales the emitters
//! by pi to match).

use crate::dipole::{Dipole, Multipole};
use crate::error::{Result, count, positive};

/// Half-angle of the tally cone (radians): wide enough for a few thousand walks to find it,
/// narrow enough to keep the forward peak.
const CONE: f64 = 0.5;

/// SplitMix64: a tiny deterministic generator, so tables are the same on every machine.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
}

/// Unpolarised Fresnel reflectance from inside (index `eta`) toward outside (index 1), for a
/// direction at `cos_i` to the normal; 1 past the critical angle.
fn fresnel_out(eta: f64, cos_i: f64) -> (f64, f64) {
    let sin_t = eta * (1.0 - cos_i * cos_i).max(0.0).sqrt();
    if sin_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

/// Radiance ratio `L / E` (see the module) through a slab `s_mm` thick, for one channel:
/// `sigma_t` (1/mm) and single-scattering albedo `alpha`. Also returns how many walks reached
/// the tally cone (the estimate's own sample count).
pub fn slab_radiance(
    sigma_t: f64,
    alpha: f64,
    eta: f64,
    s_mm: f64,
    walks: u32,
    seed: u64,
) -> (f64, u32) {
    let mut rng = Rng(seed ^ 0x5EED_0000_0000_0000 ^ s_mm.to_bits());
    let cos_cone = CONE.cos();
    let entry = 1.0 - fresnel_out(1.0 / eta, 1.0).0;
    let mut hits = 0u32;
    let mut tally = 0.0f64;
    for _ in 0..walks {
        let (mut z, mut mu) = (0.0f64, 1.0f64);
        let mut scattered = false;
        // Enough events that even the least absorbing material's walks end by absorption.
        for _ in 0..100_000 {
            z += mu * (-rng.next().ln() / sigma_t);
            if z >= s_mm || z <= 0.0 {
                let at_far = z >= s_mm;
                let (r, cos_out) = fresnel_out(eta, mu.abs());
                if rng.next() < r {
                    // Internal reflection: back inside, mirrored.
                    z = if at_far { 2.0 * s_mm - z } else { -z };
                    z = z.clamp(0.0, s_mm);
                    mu = -mu;
                    continue;
                }
                // The unscattered beam is left out: behind a rough surface it is a narrow lobe
                // around the light's own direction, seen only when eye and light line up
                // within a few degrees, which the shading cannot know.
                if at_far && scattered && cos_out >= cos_cone {
                    hits += 1;
                    tally += 1.0;
                }
                break;
            }
            if rng.next() >= alpha {
                break;
            }
            mu = 2.0 * rng.next() - 1.0;
            scattered = true;
        }
    }
    // L = flux in the cone / (projected solid angle of the cone = pi sin^2), per incident
    // flux; times pi for the renderer's units.
    let sin2 = 1.0 - cos_cone * cos_cone;
    (entry * tally / (f64::from(walks) * sin2), hits)
}

/// The radiance ratio through slabs of the medium at evenly spaced thicknesses, per channel:
/// the random walk where it has enough samples, the multipole's total transmittance beyond
/// (scaled to join the walk's last reliable value; deep in a slab light is diffuse and decays
/// as diffusion says, only its level is the walk's).
#[derive(Debug, Clone, PartialEq)]
pub struct SlabTransmittance {
    /// Thickness of the last value, mm.
    pub s_max_mm: f64,
    /// Value at `i / (len - 1) * s_max_mm`.
    pub data: Vec<[f64; 3]>,
}

impl SlabTransmittance {
    /// Tabulates `points` thicknesses over `0..=s_max_mm` with `walks` random walks per
    /// thickness and channel (100..=1e7); the multipole takes over where too few walks get out.
    pub fn new(dipole: &Dipole, points: usize, s_max_mm: f64, walks: u32) -> Result<Self> {
        count("points", points, 2, 65536)?;
        positive("s_max_mm", s_max_mm)?;
        count("walks", walks as usize, 100, 10_000_000)?;
        // A walk estimate is trusted with this many samples in the cone (about 10 % noise).
        const MIN_HITS: u32 = 100;
        let last = (points - 1) as f64;
        let mut data = vec![[0.0f64; 3]; points];
        let thickness = |i: usize| (i as f64 / last * s_max_mm).max(1e-3);
        // The multipole's total transmittance at every thickness, once for all channels.
        let diffusion = (0..points)
            .map(|i| {
                Ok(
                    Multipole::new(*dipole, thickness(i), Multipole::DEFAULT_PAIRS)?
                        .total_transmittance(),
                )
            })
            .collect::<Result<Vec<[f64; 3]>>>()?;
        for c in 0..3 {
            let ch = dipole.channel(c);
            // Multipole-to-walk ratio once the walk runs out of samples.
            let mut join: Option<f64> = None;
            for i in 0..points {
                let t = diffusion[i][c];
                if let Some(k) = join {
                    data[i][c] = (k * t).max(0.0);
                    continue;
                }
                let s = thickness(i);
                let (l, hits) = slab_radiance(
                    ch.sigma_t_prime,
                    ch.alpha_prime,
                    dipole.eta,
                    s,
                    walks,
                    c as u64,
                );
                let t_prev = if i > 0 { diffusion[i - 1][c] } else { 0.0 };
                // The multipole holds from a couple of mean free paths on (it is negative
                // below), so it takes over only there.
                if hits < MIN_HITS && s * ch.sigma_t_prime > 2.0 && t_prev > 0.0 {
                    let k = data[i - 1][c] / t_prev;
                    join = Some(k);
                    data[i][c] = (k * t).max(0.0);
                } else {
                    data[i][c] = l;
                }
            }
        }
        Ok(Self { s_max_mm, data })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::skin1;

    #[test]
    fn a_clear_slab_shows_no_light_but_its_scattered_light() {
        // The unscattered beam is not tallied: a slab that scatters nothing shows nothing,
        // and one thin enough to scatter little shows about its single scattering.
        let (l, _) = slab_radiance(1.0, 0.0, 1.3, 0.5, 10_000, 1);
        assert_eq!(l, 0.0);
        // Single scattering, isotropic, thin slab: L/E ~ pi * sigma_s * s / (4 pi) per
        // steradian of the cone... within the Fresnel factors, 0.5 * 0.1 / 4 = 0.0125.
        let (l, _) = slab_radiance(0.1, 0.5, 1.0 + 1e-9, 1.0, 200_000, 1);
        assert!((l - 0.0125).abs() < 0.004, "{l}");
    }

    #[test]
    fn thick_slabs_transmit_what_the_multipole_says() {
        // Deep in the slab the light is diffuse: the total the walk passes (any direction)
        // agrees with the multipole's total transmittance, an independent model.
        let d = skin1();
        let ch = d.channel(0);
        let s = 8.0;
        let (l, hits) = slab_radiance(ch.sigma_t_prime, ch.alpha_prime, d.eta, s, 40_000, 7);
        let t = Multipole::new(d, s, Multipole::DEFAULT_PAIRS)
            .unwrap()
            .total_transmittance()[0];
        assert!(hits > 200, "{hits}");
        // A diffuse exitance of total T shows radiance ratio T (the module's units); Fresnel
        // shapes it a little, so within a factor of 1.5 either way.
        assert!(l > t / 1.5 && l < 1.5 * t, "{l} vs {t}");
    }

    #[test]
    fn the_table_falls_with_thickness_and_red_passes_most() {
        let d = skin1();
        let tab = SlabTransmittance::new(&d, 33, 32.0, 4000).unwrap();
        for c in 0..3 {
            assert!(tab.data.iter().all(|v| v[c].is_finite() && v[c] >= 0.0));
            assert!(tab.data[1][c] > tab.data[8][c] && tab.data[8][c] > tab.data[32][c]);
        }
        // Red, the least absorbed, passes most at every thickness past the first millimetre.
        assert!(tab.data[4][0] > tab.data[4][1] && tab.data[4][1] > tab.data[4][2]);
    }
}
