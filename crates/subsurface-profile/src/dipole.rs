//! Physically based diffusion profiles: the dipole of Jensen et al. 2001 for a
//! semi-infinite medium and the multipole of Donner and Jensen 2005 for a slab.
//!
//! Units: coefficients in mm^-1, distances in mm, profiles in mm^-2.

use std::f64::consts::PI;

use serde::Serialize;

use crate::error::{CHANNELS, Result, count, in_range, positive};
use crate::gaussian::bisect;

/// Diffuse Fresnel reflectance `F_dr` of a boundary with relative index `eta` (>= 1): the
/// share of diffuse light inside the medium that the boundary reflects back in.
///
/// Up to eta = 1.8 (`FDR_POLYNOMIAL_MAX_ETA`) it is the polynomial fit Jensen et al. 2001 use
/// (within 1e-3 of the exact integral there); beyond, that fit grows past the exact value and
/// reaches 1 at eta = 3.86 (A = (1 + F_dr) / (1 - F_dr) turned negative, the profile vanished
/// and `eta = 4`, within the documented 1..=10, failed with "r_max_mm: must be > 0"), so the
/// exact hemispherical integral (`fresnel_diffuse_reflectance_exact`) takes over, blended
/// linearly across eta 1.8..2.2 (`FDR_BLEND_ETA`) so that F_dr stays continuous.
pub fn fresnel_diffuse_reflectance(eta: f64) -> f64 {
    let poly = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    let (lo, hi) = FDR_BLEND_ETA;
    if eta <= lo {
        return poly;
    }
    let exact = fresnel_diffuse_reflectance_exact(eta);
    let t = ((eta - lo) / (hi - lo)).min(1.0);
    (1.0 - t) * poly + t * exact
}

/// Below this eta the polynomial fit of [`fresnel_diffuse_reflectance`] is used alone.
pub const FDR_POLYNOMIAL_MAX_ETA: f64 = 1.8;
/// The range of eta over which the polynomial hands over to the exact integral.
const FDR_BLEND_ETA: (f64, f64) = (FDR_POLYNOMIAL_MAX_ETA, 2.2);

/// Exact internal diffuse Fresnel reflectance: `1 - (1 - F_ext) / eta^2`, with `F_ext =
/// int_0^1 2 mu F(mu) dmu` the cosine-weighted Fresnel reflectance of light arriving from
/// outside (no total internal reflection there, so the integrand is smooth; Simpson's rule on
/// 64 intervals is exact to about 1e-9). Always below 1 for a finite eta.
pub fn fresnel_diffuse_reflectance_exact(eta: f64) -> f64 {
    let fresnel_outside = |mu: f64| {
        let cos_t = (1.0 - (1.0 - mu * mu) / (eta * eta)).max(0.0).sqrt();
        let rs = (mu - eta * cos_t) / (mu + eta * cos_t);
        let rp = (eta * mu - cos_t) / (eta * mu + cos_t);
        0.5 * (rs * rs + rp * rp)
    };
    const N: usize = 64;
    let h = 1.0 / N as f64;
    // The weight 2 mu is 0 at grazing, where eta = 1 makes the Fresnel term 0 / 0.
    let f = |i: usize| {
        let mu = i as f64 * h;
        if mu == 0.0 {
            0.0
        } else {
            2.0 * mu * fresnel_outside(mu)
        }
    };
    let inner: f64 = (1..N)
        .map(|i| if i % 2 == 1 { 4.0 } else { 2.0 } * f(i))
        .sum();
    let external = h / 3.0 * (f(0) + inner + f(N));
    1.0 - (1.0 - external) / (eta * eta)
}

/// Derived per-channel quantities of the diffusion approximation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DiffusionChannel {
    /// Reduced extinction `sigma_t' = sigma_a + sigma_s'`.
    pub sigma_t_prime: f64,
    /// Reduced albedo `alpha' = sigma_s' / sigma_t'`.
    pub alpha_prime: f64,
    /// Effective transport coefficient `sigma_tr = sqrt(3 sigma_a sigma_t')`.
    pub sigma_tr: f64,
    /// Depth of the real source, one mean free path: `z_r = 1 / sigma_t'`.
    pub z_r: f64,
    /// Height of the extrapolated boundary above the surface, `z_b = 2 A D` with
    /// `D = 1 / (3 sigma_t')`.
    pub z_b: f64,
    /// Height of the dipole's virtual source above the surface, `z_v = z_r + 2 z_b`
    /// (= `z_r (1 + 4A/3)` in Jensen 2001).
    pub z_v: f64,
}

/// Material coefficients shared by the dipole and multipole.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Dipole {
    /// Absorption coefficient per channel, mm^-1, > 0.
    pub sigma_a: [f64; 3],
    /// Reduced scattering coefficient per channel, mm^-1, > 0.
    pub sigma_s_prime: [f64; 3],
    /// Relative index of refraction, >= 1.
    pub eta: f64,
}

/// Signed energy of one pole term `z (1 + s d) e^{-s d} / (4 pi d^3)`,
/// `d = sqrt(r^2 + z^2)`, integrated over the disc of radius `rho`:
/// `sign(z) / 2 * (e^{-s|z|} - |z| e^{-s D} / D)` with `D = sqrt(rho^2 + z^2)`.
/// (The antiderivative of `(1 + s d) e^{-s d} / d^2` is `-e^{-s d} / d`.)
fn pole_energy(z: f64, s: f64, rho: f64) -> f64 {
    let a = z.abs();
    if a == 0.0 {
        return 0.0;
    }
    let big_d = (rho * rho + z * z).sqrt();
    let tail = if rho.is_infinite() {
        0.0
    } else {
        a * (-s * big_d).exp() / big_d
    };
    z.signum() * 0.5 * ((-s * a).exp() - tail)
}

/// One pole term of the profile, `z (1 + s d) e^{-s d} / (4 pi d^3)`.
fn pole(z: f64, s: f64, r: f64) -> f64 {
    if z == 0.0 {
        return 0.0;
    }
    let d = (r * r + z * z).sqrt();
    z * (1.0 + s * d) * (-s * d).exp() / (4.0 * PI * d * d * d)
}

impl Dipole {
    /// Validates: every sigma finite and > 0, `eta` finite and in 1..=10.
    pub fn new(sigma_a: [f64; 3], sigma_s_prime: [f64; 3], eta: f64) -> Result<Self> {
        for c in 0..3 {
            positive(&format!("sigma_a.{}", CHANNELS[c]), sigma_a[c])?;
            positive(&format!("sigma_s_prime.{}", CHANNELS[c]), sigma_s_prime[c])?;
        }
        in_range("eta", eta, 1.0, 10.0)?;
        Ok(Self {
            sigma_a,
            sigma_s_prime,
            eta,
        })
    }

    /// `A = (1 + F_dr) / (1 - F_dr)`, the boundary mismatch term.
    pub fn boundary_a(&self) -> f64 {
        let fdr = fresnel_diffuse_reflectance(self.eta);
        (1.0 + fdr) / (1.0 - fdr)
    }

    /// Derived quantities for channel `c` (0..3).
    pub fn channel(&self, c: usize) -> DiffusionChannel {
        let sigma_t_prime = self.sigma_a[c] + self.sigma_s_prime[c];
        let z_r = 1.0 / sigma_t_prime;
        let z_b = 2.0 * self.boundary_a() / (3.0 * sigma_t_prime);
        DiffusionChannel {
            sigma_t_prime,
            alpha_prime: self.sigma_s_prime[c] / sigma_t_prime,
            sigma_tr: (3.0 * self.sigma_a[c] * sigma_t_prime).sqrt(),
            z_r,
            z_b,
            z_v: z_r + 2.0 * z_b,
        }
    }

    /// Diffuse reflectance profile `R_d(r)` (Jensen 2001, eq. 4 with the
    /// virtual source above the surface).
    pub fn reflectance(&self, r_mm: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            let ch = self.channel(c);
            ch.alpha_prime * (pole(ch.z_r, ch.sigma_tr, r_mm) + pole(ch.z_v, ch.sigma_tr, r_mm))
        })
    }

    /// Total diffuse reflectance in closed form (Jensen 2001):
    /// `alpha'/2 (1 + exp(-4/3 A sqrt(3 (1 - alpha')))) exp(-sqrt(3 (1 - alpha')))`.
    pub fn total_reflectance(&self) -> [f64; 3] {
        let a = self.boundary_a();
        [0, 1, 2].map(|c| {
            let alpha = self.channel(c).alpha_prime;
            let k = (3.0 * (1.0 - alpha)).sqrt();
            0.5 * alpha * (1.0 + (-4.0 / 3.0 * a * k).exp()) * (-k).exp()
        })
    }

    /// Radius (mm) inside which every channel holds `fraction` of its total
    /// reflectance (exact disc energies, bisection).
    pub fn energy_radius_mm(&self, fraction: f64) -> f64 {
        let hi = (0..3)
            .map(|c| {
                let ch = self.channel(c);
                50.0 / ch.sigma_tr + 50.0 * ch.z_v
            })
            .fold(0.0, f64::max);
        (0..3)
            .map(|c| {
                let ch = self.channel(c);
                let inside = |rho: f64| {
                    pole_energy(ch.z_r, ch.sigma_tr, rho) + pole_energy(ch.z_v, ch.sigma_tr, rho)
                };
                let total = inside(f64::INFINITY);
                bisect(|rho| inside(rho) / total - fraction, 0.0, hi)
            })
            .fold(0.0, f64::max)
    }
}

/// Donner and Jensen 2005's multipole: a slab of finite `thickness_mm`, both faces
/// with the same `eta`, approximated by `2 * pairs + 1` dipoles mirrored about
/// the two extrapolated boundaries.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Multipole {
    /// The medium: coefficients per mm and the faces' relative index.
    pub dipole: Dipole,
    /// Slab thickness `d` in mm, > 0.
    pub thickness_mm: f64,
    /// Dipole pairs on each side of the central one (`i = -pairs..=pairs`).
    pub pairs: u32,
}

impl Multipole {
    /// Default `pairs`: beyond it the extra poles sit more than 20 slab
    /// thicknesses away and change the profile negligibly for thin slabs.
    pub const DEFAULT_PAIRS: u32 = 20;

    /// Validates `thickness_mm` (finite, > 0) and `pairs` (0..=1000).
    pub fn new(dipole: Dipole, thickness_mm: f64, pairs: u32) -> Result<Self> {
        positive("thickness_mm", thickness_mm)?;
        count("pairs", pairs as usize, 0, 1000)?;
        Ok(Self {
            dipole,
            thickness_mm,
            pairs,
        })
    }

    /// Depths of real and virtual source of pair `i` for channel `ch`:
    /// `z_r,i = 2i (d + 2 z_b) + z_r`, `z_v,i = 2i (d + 2 z_b) - z_r - 2 z_b`
    /// (Donner and Jensen 2005; i = 0 is the classic dipole).
    fn poles(&self, ch: &DiffusionChannel) -> impl Iterator<Item = (f64, f64)> + '_ {
        let n = self.pairs as i64;
        let period = 2.0 * (self.thickness_mm + 2.0 * ch.z_b);
        let (z_r, z_b) = (ch.z_r, ch.z_b);
        (-n..=n).map(move |i| {
            let shift = i as f64 * period;
            (shift + z_r, shift - z_r - 2.0 * z_b)
        })
    }

    /// Reflectance profile `R(r)` of the slab.
    pub fn reflectance(&self, r_mm: f64) -> [f64; 3] {
        self.pole_sum(|z, sigma_tr| pole(z, sigma_tr, r_mm))
    }

    /// Transmittance profile `T(r)` through the slab (distance `r` measured on
    /// the far face from the point below the entry point).
    pub fn transmittance(&self, r_mm: f64) -> [f64; 3] {
        let d = self.thickness_mm;
        self.pole_sum(|z, sigma_tr| pole(d - z, sigma_tr, r_mm))
    }

    /// Total reflectance, in closed form per pole (see [`Dipole`]'s derivation).
    pub fn total_reflectance(&self) -> [f64; 3] {
        self.reflected_energy(f64::INFINITY)
    }

    /// Total transmittance, in closed form per pole.
    pub fn total_transmittance(&self) -> [f64; 3] {
        let d = self.thickness_mm;
        self.pole_sum(|z, sigma_tr| pole_energy(d - z, sigma_tr, f64::INFINITY))
    }

    fn reflected_energy(&self, rho: f64) -> [f64; 3] {
        self.pole_sum(|z, sigma_tr| pole_energy(z, sigma_tr, rho))
    }

    /// Per channel, `alpha' * sum over the pole pairs of (f(z_r) - f(z_v))`, with `f(z,
    /// sigma_tr)` one pole's contribution at depth `z`.
    fn pole_sum(&self, f: impl Fn(f64, f64) -> f64) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            let ch = self.dipole.channel(c);
            ch.alpha_prime
                * self
                    .poles(&ch)
                    .map(|(zr, zv)| f(zr, ch.sigma_tr) - f(zv, ch.sigma_tr))
                    .sum::<f64>()
        })
    }

    /// Radius (mm) inside which every channel holds `fraction` of its total
    /// reflectance.
    pub fn energy_radius_mm(&self, fraction: f64) -> f64 {
        let hi = self.dipole.energy_radius_mm(0.999_999) * 4.0;
        let total = self.total_reflectance();
        (0..3)
            .filter(|&c| total[c] > 0.0)
            .map(|c| {
                bisect(
                    |rho| self.reflected_energy(rho)[c] / total[c] - fraction,
                    0.0,
                    hi,
                )
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaussian::simpson;
    use crate::materials::skin1;

    fn integrate_plane(f: impl Fn(f64) -> f64, r_max: f64) -> f64 {
        // Substitute r = u^2 to resolve the peak at the origin.
        let u_max = r_max.sqrt();
        simpson(
            |u| 2.0 * PI * u * u * f(u * u) * 2.0 * u,
            0.0,
            u_max,
            400_000,
        )
    }

    fn marble() -> Dipole {
        Dipole::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3).unwrap()
    }

    #[test]
    fn dipole_integral_matches_jensen_closed_form() {
        for d in [marble(), skin1()] {
            let closed = d.total_reflectance();
            let r_max = d.energy_radius_mm(1.0 - 1e-9);
            for c in 0..3 {
                let numeric = integrate_plane(|r| d.reflectance(r)[c], r_max);
                assert!(
                    (numeric - closed[c]).abs() < 1e-6 * closed[c].max(1e-3),
                    "channel {c}: numeric {numeric} closed {}",
                    closed[c]
                );
            }
        }
    }

    #[test]
    fn jensen_closed_form_hand_value() {
        // Skin1 red by hand: alpha' = 0.74 / 0.772, F_dr(1.3) = 0.44480, A = 2.6026.
        let rd = skin1().total_reflectance()[0];
        assert!((rd - 0.4361).abs() < 5e-4, "{rd}");
        assert!((fresnel_diffuse_reflectance(1.0) - 0.0016).abs() < 1e-12);
    }

    /// Jensen's polynomial F_dr passed 1 at eta = 3.86 (A < 0), so `eta = 4`, inside the
    /// documented 1..=10, had no profile. F_dr must stay in (0, 1), rise with eta and be
    /// continuous, and agree with the exact integral where the polynomial is used.
    #[test]
    fn diffuse_fresnel_stays_below_one_over_the_whole_eta_range() {
        // The exact integral against known values: 0.4445 at 1.3 (Jensen's fit gives 0.4448).
        assert!((fresnel_diffuse_reflectance_exact(1.3) - 0.44446).abs() < 1e-4);
        assert!(fresnel_diffuse_reflectance_exact(1.0).abs() < 1e-9);
        let mut last = fresnel_diffuse_reflectance(1.0);
        for k in 1..=9000 {
            let eta = 1.0 + k as f64 * 1e-3;
            let f = fresnel_diffuse_reflectance(eta);
            assert!(f > last - 1e-12 && f < 1.0, "eta {eta}: F_dr {f}");
            assert!(f - last < 3e-3, "eta {eta}: jump from {last} to {f}");
            if eta <= FDR_POLYNOMIAL_MAX_ETA {
                let e = fresnel_diffuse_reflectance_exact(eta);
                assert!((f - e).abs() < 2e-3, "eta {eta}: {f} vs exact {e}");
            }
            last = f;
        }
        for eta in [4.0, 10.0] {
            let d = Dipole::new([0.01, 0.02, 0.05], [1.0, 1.2, 1.5], eta).unwrap();
            assert!(d.boundary_a() > 1.0, "eta {eta}");
            let r = d.energy_radius_mm(0.999);
            assert!(r.is_finite() && r > 0.0, "eta {eta}: radius {r}");
            for c in 0..3 {
                let ch = d.channel(c);
                assert!(ch.z_v > ch.z_r, "eta {eta}");
            }
            assert!(d.total_reflectance().iter().all(|&x| x > 0.0 && x < 1.0));
        }
    }

    #[test]
    fn thick_multipole_is_the_dipole() {
        let d = skin1();
        let m0 = Multipole::new(d, 1e6, 0).unwrap();
        let m = Multipole::new(d, 1e6, 5).unwrap();
        for r in [0.0, 0.1, 1.0, 5.0] {
            let (a, b, c) = (d.reflectance(r), m0.reflectance(r), m.reflectance(r));
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-12 * a[k].abs().max(1e-30),
                    "r {r}"
                );
                assert!((a[k] - c[k]).abs() <= 1e-9 * a[k].abs().max(1e-30), "r {r}");
            }
        }
        let (a, b) = (d.total_reflectance(), m.total_reflectance());
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn thin_slab_reflects_less_and_transmits() {
        let d = marble();
        let m = Multipole::new(d, 2.0, Multipole::DEFAULT_PAIRS).unwrap();
        let (rd, rm, tm) = (
            d.total_reflectance(),
            m.total_reflectance(),
            m.total_transmittance(),
        );
        for c in 0..3 {
            assert!(rm[c] < rd[c], "channel {c}");
            assert!(tm[c] > 0.05, "channel {c}: {}", tm[c]);
            // Energy cannot exceed the albedo-limited budget.
            assert!(rm[c] + tm[c] < 1.0);
            // The closed forms match numeric integration of the profiles.
            let r_max = 400.0;
            let nr = integrate_plane(|r| m.reflectance(r)[c], r_max);
            let nt = integrate_plane(|r| m.transmittance(r)[c], r_max);
            assert!(
                (nr - rm[c]).abs() < 1e-5,
                "R channel {c}: {nr} vs {}",
                rm[c]
            );
            assert!(
                (nt - tm[c]).abs() < 1e-5,
                "T channel {c}: {nt} vs {}",
                tm[c]
            );
        }
    }

    #[test]
    fn bad_coefficients_are_errors() {
        let e = Dipole::new([0.1, 0.0, 0.1], [1.0; 3], 1.3).unwrap_err();
        assert!(e.to_string().starts_with("sigma_a.g: must be > 0"), "{e}");
        let e = Dipole::new([0.1; 3], [1.0, 1.0, -2.0], 1.3).unwrap_err();
        assert!(
            e.to_string().starts_with("sigma_s_prime.b: must be > 0"),
            "{e}"
        );
        let e = Dipole::new([0.1; 3], [1.0; 3], 0.9).unwrap_err();
        assert!(e.to_string().starts_with("eta: "), "{e}");
        assert!(Dipole::new([0.1; 3], [f64::INFINITY; 3], 1.3).is_err());
        let e = Multipole::new(skin1(), -1.0, 3).unwrap_err();
        assert!(e.to_string().starts_with("thickness_mm: "), "{e}");
    }
}
