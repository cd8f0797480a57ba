//! Exact light transport through a plane-parallel slab of a medium, by adding-doubling (van de
//! Hulst 1980; Prahl's formulation for tissue optics): the transmittance `T(s)` and diffuse
//! albedo that diffusion theory only approximates.
//!
//! Diffusion (the dipole and multipole) is poor where the reduced albedo is low: through 10 mm
//! of skin1 it passes 0.43 of the green and 0.06 of the blue that a path tracer shows (a grey
//! render per channel, see tools/reference/render_reference.py), because exact transport decays
//! as `exp(-kappa sigma_t' s)` with `kappa` the root of `(alpha' / 2 kappa) ln((1 + kappa) /
//! (1 - kappa)) = 1`, slower than diffusion's `sigma_tr`. This module solves the radiative
//! transfer equation of the same medium the path tracer renders (extinction `sigma_t'`, the sum
//! of `sigma_a` and `sigma_s'`, isotropic phase function, smooth Fresnel boundaries of index
//! `eta` on both faces, collimated light at normal incidence) to quadrature accuracy:
//!
//! * directions inside the slab are Gauss-Legendre nodes in `mu = cos(theta)`, split at the
//!   critical angle so the total internal reflection's kink falls between nodes;
//! * a layer is its reflection and transmission operators on radiance vectors (`R`, `T`) and
//!   its responses to the collimated beam (`r`, `t`); a layer thin enough (`delta` optical
//!   depths) scatters light at most once, in closed form;
//! * two layers add as `T12 = T2 (I - R1 R2)^-1 T1`, `R12 = R1 + T1 (I - R2 R1)^-1 R2 T1`
//!   (homogeneous layers look the same from either side), so doubling reaches any thickness
//!   in a few dozen steps and adding a thin layer steps through a table of thicknesses;
//! * the faces reflect the diffuse field inside by Fresnel's law per direction, and what
//!   crosses them leaves with `1 - F`.
//!
//! Units: `L / E` (radiance per incident irradiance) and fluxes per incident irradiance.

mod matrix;
mod solver;
#[cfg(test)]
mod tests;

use std::f64::consts::PI;

pub use solver::SlabSolver;

use crate::dipole::Dipole;
use crate::error::{Result, count, positive};

/// Unpolarised Fresnel reflectance of light inside a medium of index `eta` reaching its
/// boundary with index 1 at `cos_i` to the normal; 1 past the critical angle.
pub fn fresnel_inside(eta: f64, cos_i: f64) -> f64 {
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// What a slab of one channel's medium does to collimated light at normal incidence (per unit
/// incident irradiance outside, the entry's Fresnel reflection taken off).
#[derive(Clone, Debug, PartialEq)]
pub struct SlabResult {
    /// Scattered light leaving the far face, as a flux: every order of scattering.
    pub transmitted: f64,
    /// The part of `transmitted` that was scattered exactly once (leaving without meeting a
    /// face in between).
    pub transmitted_once: f64,
    /// Scattered light leaving the lit face, as a flux.
    pub reflected: f64,
    /// The unscattered beam leaving the far face.
    pub unscattered: f64,
    /// Radiance of the multiply scattered light (every order but the first) leaving the far
    /// face, per unit incident irradiance, at [`SlabSolver::EXIT_ANGLES`] evenly spaced
    /// cosines of the exit direction outside, from grazing (0) to the normal (1). Diffusion
    /// and a Lambertian exit give `(transmitted - transmitted_once) / pi` at every angle;
    /// exact transport peaks toward the normal behind thick slabs (1.15x that in red behind
    /// 20 mm of skin1, 1.75x in blue) and falls to nothing at grazing.
    pub exit_radiance: Vec<f64>,
    /// The same light just inside the far face, before it crosses: its radiance toward
    /// [`SlabSolver::EXIT_ANGLES`] evenly spaced cosines to the normal (0 to 1), per unit
    /// incident irradiance. `exit_radiance` is this at the refracted direction times `1 - F`
    /// over `eta^2`; kept apart, it is the shape of the light around the direction it flows,
    /// which a renderer can turn toward a surface that is not the slab's.
    pub inside_radiance: Vec<f64>,
}

/// What a half-space of one channel's medium reflects of collimated light at some incidence
/// (`SlabSolver::half_space_reflection`), per unit irradiance on its surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Reflection {
    /// Scattered light leaving the lit face, as a flux: every order of scattering.
    pub reflected: f64,
    /// Its radiance outside at [`SlabSolver::EXIT_ANGLES`] evenly spaced cosines of the exit
    /// direction, from grazing (0) to the normal (1).
    pub radiance: Vec<f64>,
}

/// The diffuse transmittance of a medium per channel: light scattered two or more times
/// through a slab `s` mm thick (the renderer adds single scattering and the unscattered beam
/// with their own directions), as a flux per incident irradiance, at `i / (points - 1) *
/// s_max_mm`; and the medium's total diffuse reflectance (every order), its diffuse albedo.
pub fn slab_transport(dipole: &Dipole, points: usize, s_max_mm: f64) -> Result<TransportTable> {
    count("points", points, 2, 1 << 16)?;
    positive("s_max_mm", s_max_mm)?;
    let solver = SlabSolver::new(dipole.eta)?;
    let step = s_max_mm / (points - 1) as f64;
    let mut multiple = vec![[0.0; 3]; points];
    let mut inside = vec![[[1.0; 3]; SlabSolver::EXIT_ANGLES]; points];
    let mut albedo = [0.0; 3];
    let mut reflected = vec![[0.0; 3]; points];
    for c in 0..3 {
        let ch = dipole.channel(c);
        albedo[c] = solver.diffuse_reflectance(ch.sigma_t_prime, ch.alpha_prime)?;
        let slabs = solver.slabs(ch.sigma_t_prime, ch.alpha_prime, step, points - 1)?;
        for (i, s) in slabs.iter().enumerate() {
            let t = (s.transmitted - s.transmitted_once).max(0.0);
            multiple[i + 1][c] = t;
            reflected[i + 1][c] = if albedo[c] > 0.0 {
                (s.reflected / albedo[c]).min(1.0)
            } else {
                1.0
            };
            // pi L / T_ms, over eta^2 for the radiance that widens on its way out: times
            // 1 - F of the crossing it is the exit's factor of a Lambertian radiance.
            let eta2 = dipole.eta * dipole.eta;
            for (k, l) in s.inside_radiance.iter().enumerate() {
                inside[i + 1][k][c] = if t > 0.0 { PI * l / (eta2 * t) } else { 1.0 };
            }
        }
    }
    // No slab has no exit distribution; the thinnest one's stands in.
    inside[0] = inside[1];
    Ok(TransportTable {
        s_max_mm,
        multiple,
        inside,
        albedo,
        reflected,
    })
}

impl TransportTable {
    /// [`TransportTable::reflected`] at `s_mm`, interpolated; 1 past the table (a part that
    /// thick reflects as the half-space), 0 for NaN or a negative thickness.
    pub fn reflected_at(&self, s_mm: f64) -> [f64; 3] {
        if s_mm >= self.s_max_mm {
            return [1.0; 3];
        }
        self.segment_of(&self.reflected, s_mm)
            .map_or([0.0; 3], |(a, b, f)| {
                [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * f)
            })
    }
}

/// See [`slab_transport`].
#[derive(Clone, Debug, PartialEq)]
pub struct TransportTable {
    /// Thickness of the last row, mm; rows are evenly spaced from 0.
    pub s_max_mm: f64,
    /// Diffuse transmittance of light scattered at least twice, per channel, at evenly spaced
    /// thicknesses from 0 (no slab: 0) to `s_max_mm`.
    pub multiple: Vec<[f64; 3]>,
    /// How the multiply scattered light arrives at the far face, per thickness: its radiance
    /// inside toward [`SlabSolver::EXIT_ANGLES`] evenly spaced cosines `c` to the direction it
    /// flows (the slab's normal), as `pi L(c) / (eta^2 T_ms)`. Leaving through a surface at
    /// exit cosine `mu_o` with its refracted direction at `c`, the light's radiance is `(1 -
    /// F(mu_o))` times this times a Lambertian exit's: in a slab `c` is the refracted `mu_o`,
    /// and the cosine-weighted mean over the hemisphere is 1.
    pub inside: Vec<[[f64; 3]; SlabSolver::EXIT_ANGLES]>,
    /// Total diffuse reflectance of the half-space per channel.
    pub albedo: [f64; 3],
    /// What a slab of each thickness reflects (every order of scattering) as a share of
    /// `albedo`, per channel, at the same thicknesses as `multiple` (no slab: 0). Below a few
    /// diffusion lengths the far face lets out light the half-space would have sent back: 1 mm
    /// of skin1 keeps 0.52 of its red albedo, 2 mm 0.75.
    pub reflected: Vec<[f64; 3]>,
}
