//! The transmittance look-up table `T(s)` for the GPU.

use serde::Serialize;

use crate::dipole::{Dipole, Multipole};
use crate::error::{Result, count, positive};
use crate::gaussian::SumOfGaussians;

/// `T(s)` sampled at `resolution` evenly spaced thicknesses over `0..=s_max_mm`.
///
/// Texel `i` holds `T(i / (resolution - 1) * s_max_mm)`, so a GPU linear sampler
/// with clamp-to-edge and `u = (s / s_max_mm * (resolution - 1) + 0.5) / resolution`
/// reproduces [`TransmittanceLut::sample`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransmittanceLut {
    /// Texels, >= 2.
    pub resolution: u32,
    /// Thickness of the last texel, mm; lookups beyond it clamp.
    pub s_max_mm: f32,
    /// RGB `T(s)` per texel, texel `i` at `i / (resolution - 1) * s_max_mm`.
    pub data: Vec<[f32; 3]>,
}

impl TransmittanceLut {
    /// Default texel count. The narrowest skin term (blue, weight 0.649,
    /// v = 0.0064 mm^2) gives `|T''| <= 2 * 0.649 / 0.0064 ~ 203 mm^-2` near s = 0,
    /// and linear interpolation errs by at most `|T''| h^2 / 8`; with
    /// h = 6 mm / 2047 that is ~2.2e-4, well under the 1e-3 target (1024 texels
    /// would give ~8.7e-4, too close to it).
    pub const DEFAULT_RESOLUTION: u32 = 2048;
    /// Default range. Past 6 mm the widest skin term is `0.078 exp(-36 / 7.41)`
    /// ~ 6e-4, so the clamped lookup still stays within 1e-3 of `T(s)` for any
    /// larger thickness.
    pub const DEFAULT_S_MAX_MM: f32 = 6.0;

    /// Tabulates `profile.transmittance` (computed in f64, stored as f32).
    pub fn new(profile: &SumOfGaussians, resolution: u32, s_max_mm: f32) -> Result<Self> {
        count("resolution", resolution as usize, 2, 65536)?;
        positive("s_max_mm", s_max_mm as f64)?;
        let last = (resolution - 1) as f64;
        let data = (0..resolution)
            .map(|i| {
                let s = i as f64 / last * s_max_mm as f64;
                profile.transmittance(s).map(|t| t as f32)
            })
            .collect();
        Ok(Self {
            resolution,
            s_max_mm,
            data,
        })
    }

    /// Range of [`TransmittanceLut::diffusion`]: past 32 mm even skin's red channel (the
    /// least absorbed of the measured materials that transmit) passes under 1e-5.
    pub const DIFFUSION_S_MAX_MM: f32 = 32.0;

    /// Transmittance from diffusion theory for a measured material: light through a slab of
    /// thickness `s` (the multipole of Donner and Jensen 2005, [`Multipole`]), as a factor of
    /// the material's total diffuse reflectance `R_d`: `T(s) = T_t(s) / R_d`, so that the
    /// lighting pass's `albedo * T(s) * E` (with albedo = `R_d`) is the slab's transmitted
    /// `T_t(s) * E`. Unlike the sum-of-Gaussians `T(s)` this decays exponentially, as
    /// diffusion does, so thick parts (fingers, 10-15 mm) still pass red light.
    ///
    /// The multipole is not valid for slabs thinner than about two transport mean free
    /// paths (its total transmittance even turns negative there), so the table is the
    /// non-increasing upper envelope from the thick end, clamped to 0..=1: thin parts
    /// transmit everything, as the Gaussian `T(0) = 1` does.
    pub fn diffusion(dipole: &Dipole, resolution: u32, s_max_mm: f32) -> Result<Self> {
        count("resolution", resolution as usize, 2, 65536)?;
        positive("s_max_mm", s_max_mm as f64)?;
        let rd = dipole.total_reflectance();
        let last = (resolution - 1) as f64;
        let mut data = vec![[0.0f32; 3]; resolution as usize];
        let mut envelope = [0.0f64; 3];
        for i in (0..resolution as usize).rev() {
            // s = 0 is no slab at all; the envelope carries the thinnest valid value there.
            let s = (i as f64 / last * s_max_mm as f64).max(1e-3);
            let t = Multipole::new(*dipole, s, Multipole::DEFAULT_PAIRS)?.total_transmittance();
            for c in 0..3 {
                let v = if t[c].is_finite() && rd[c] > 0.0 {
                    t[c] / rd[c]
                } else {
                    0.0
                };
                envelope[c] = envelope[c].max(v).min(1.0);
                data[i][c] = envelope[c] as f32;
            }
        }
        Ok(Self {
            resolution,
            s_max_mm,
            data,
        })
    }

    /// Thicknesses at which [`TransmittanceLut::transport`] solves the slab (every 0.25 mm
    /// over 32 mm); between them it interpolates the logarithm, exact for the exponential
    /// decay that transport settles into.
    pub const TRANSPORT_POINTS: usize = 129;

    /// Transmittance of light scattered two or more times through a slab of the medium, by
    /// exact transport ([`crate::slab_transport`], adding-doubling), as a factor of `albedo`:
    /// `T(s) = T_ms(s) / albedo`, so that the lighting pass's `albedo * T(s) * E` is the
    /// slab's transmitted `T_ms(s) * E`. `albedo` is the medium's diffuse albedo from the same
    /// solver, [`crate::TransportTable::albedo`]. The renderer adds single scattering (along the view
    /// ray) and the unscattered beam (a narrow lobe) on their own, with their directions.
    /// Unlike diffusion's multipole this holds at low reduced albedo too (through 10 mm of
    /// skin1: 1.8x the multipole's green and 13x its blue, as a path tracer shows), and it
    /// vanishes for a vanishing slab instead of needing an envelope where diffusion fails.
    pub fn transport(table: &crate::TransportTable, resolution: u32) -> Result<Self> {
        Self::transport_row(table, resolution, None)
    }

    /// [`TransmittanceLut::transport`] with the angular shape of the light arriving at the far
    /// face, toward direction `angle` of [`crate::SlabSolver::EXIT_ANGLES`] inside (cosines to
    /// the direction the light flows, evenly spaced from 0 to 1; see
    /// [`crate::TransportTable::inside`]): times `1 - F` of its crossing, the radiance leaving
    /// in that direction as a factor of `albedo * E`. Behind 10 mm of skin1 seen along the
    /// normal, 1.14x the Lambertian mean in red, 1.28x in green, 1.57x in blue.
    pub fn transport_at(
        table: &crate::TransportTable,
        resolution: u32,
        angle: usize,
    ) -> Result<Self> {
        count("angle", angle, 0, crate::SlabSolver::EXIT_ANGLES - 1)?;
        Self::transport_row(table, resolution, Some(angle))
    }

    fn transport_row(
        table: &crate::TransportTable,
        resolution: u32,
        angle: Option<usize>,
    ) -> Result<Self> {
        count("resolution", resolution as usize, 2, 65536)?;
        let points = table.multiple.len();
        count("table points", points, 2, 1 << 16)?;
        let last = (resolution - 1) as f64;
        let step = table.s_max_mm / (points - 1) as f64;
        let data = (0..resolution)
            .map(|i| {
                let s = i as f64 / last * table.s_max_mm;
                let x = (s / step).min((points - 1) as f64);
                let k = (x.floor() as usize).min(points - 2);
                let f = x - k as f64;
                let exit = |i: usize, c: usize| angle.map_or(1.0, |j| table.inside[i][j][c]);
                let a = [0, 1, 2].map(|c| table.multiple[k][c] * exit(k, c));
                let b = [0, 1, 2].map(|c| table.multiple[k + 1][c] * exit(k + 1, c));
                [0, 1, 2].map(|c| {
                    let v = if a[c] > 0.0 && b[c] > 0.0 {
                        (a[c].ln() * (1.0 - f) + b[c].ln() * f).exp()
                    } else {
                        a[c] * (1.0 - f) + b[c] * f
                    };
                    let albedo = table.albedo[c];
                    if albedo > 0.0 {
                        (v / albedo) as f32
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        Ok(Self {
            resolution,
            s_max_mm: table.s_max_mm as f32,
            data,
        })
    }

    /// What a part `s` mm thick reflects of the light entering its lit face, as a share of the
    /// half-space's albedo ([`crate::TransportTable::reflected_at`]), over `0..=s_max_mm` of
    /// the table: the rest leaves through the far face (an ear or an eyelid lit from the front
    /// reflects less red than the cheek).
    pub fn thin_reflectance(table: &crate::TransportTable, resolution: u32) -> Result<Self> {
        Self::from_table(table, resolution, |s| table.reflected_at(s))
    }

    /// The skin `T(s)` at the default resolution and range.
    pub fn skin() -> Self {
        Self::new(
            &SumOfGaussians::skin(),
            Self::DEFAULT_RESOLUTION,
            Self::DEFAULT_S_MAX_MM,
        )
        .expect("default LUT parameters are valid")
    }

    /// Linear interpolation between texels, `s` clamped to `0..=s_max_mm`
    /// (NaN reads texel 0).
    pub fn sample(&self, s_mm: f32) -> [f32; 3] {
        let last = (self.resolution - 1) as f32;
        let x = (s_mm / self.s_max_mm * last).clamp(0.0, last);
        let x = if x.is_nan() { 0.0 } else { x };
        let i0 = (x.floor() as usize).min(self.resolution as usize - 2);
        let f = x - i0 as f32;
        let (a, b) = (self.data[i0], self.data[i0 + 1]);
        [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * f)
    }

    /// The texels as RGBA (alpha 1), for an `Rgba32Float` / `Rgba16Float` texture.
    pub fn to_rgba(&self) -> Vec<[f32; 4]> {
        self.data.iter().map(|t| [t[0], t[1], t[2], 1.0]).collect()
    }

    /// Largest `|sample(s) - T(s)|` over a dense set of thicknesses in
    /// `0..=2 * s_max_mm` (texel centres, midpoints and ten points between each).
    pub fn max_error(&self, profile: &SumOfGaussians) -> f64 {
        let n = (self.resolution as usize - 1) * 10 * 2;
        (0..=n)
            .map(|i| {
                let s = i as f64 / n as f64 * 2.0 * self.s_max_mm as f64;
                let exact = profile.transmittance(s);
                let lut = self.sample(s as f32);
                (0..3)
                    .map(|c| (lut[c] as f64 - exact[c]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::skin1;

    #[test]
    fn default_lut_error_is_below_1e_3() {
        let skin = SumOfGaussians::skin();
        let lut = TransmittanceLut::skin();
        assert_eq!(lut.data.len(), 2048);
        let err = lut.max_error(&skin);
        assert!(err < 1e-3, "max error {err}");
        // The budget is dominated by interpolation, so a coarser table must do worse.
        let coarse = TransmittanceLut::new(&skin, 256, 6.0).unwrap();
        assert!(coarse.max_error(&skin) > 1e-3);
    }

    #[test]
    fn texels_hold_exact_values_and_sample_clamps() {
        let skin = SumOfGaussians::skin();
        let lut = TransmittanceLut::new(&skin, 5, 4.0).unwrap();
        let t1 = skin.transmittance(1.0);
        for c in 0..3 {
            assert!((lut.data[1][c] as f64 - t1[c]).abs() < 1e-7);
            assert!((lut.sample(1.0)[c] as f64 - t1[c]).abs() < 1e-7);
        }
        assert_eq!(lut.sample(-3.0), lut.data[0]);
        for c in 0..3 {
            assert!(
                (lut.sample(100.0)[c] - lut.data[4][c]).abs() <= 1e-7 * lut.data[3][c].max(1e-30)
            );
        }
        let mid = lut.sample(0.5);
        for c in 0..3 {
            assert!((mid[c] - 0.5 * (lut.data[0][c] + lut.data[1][c])).abs() < 1e-7);
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let skin = SumOfGaussians::skin();
        assert!(
            TransmittanceLut::new(&skin, 1, 4.0)
                .unwrap_err()
                .to_string()
                .starts_with("resolution:")
        );
        assert!(
            TransmittanceLut::new(&skin, 16, 0.0)
                .unwrap_err()
                .to_string()
                .starts_with("s_max_mm:")
        );
        assert!(TransmittanceLut::new(&skin, 16, f32::INFINITY).is_err());
    }

    #[test]
    fn diffusion_lut_is_the_slab_transmittance_where_the_multipole_holds() {
        let d = skin1();
        let lut = TransmittanceLut::diffusion(&d, 1024, 32.0).unwrap();
        let rd = d.total_reflectance();
        // From 3 mm on (over two transport mean free paths for every channel) the table is
        // T_t(s) / R_d itself.
        for s in [3.0, 5.0, 8.0, 12.0, 20.0] {
            let t = Multipole::new(d, s, Multipole::DEFAULT_PAIRS)
                .unwrap()
                .total_transmittance();
            let got = lut.sample(s as f32);
            for c in 0..3 {
                let want = (t[c] / rd[c]).min(1.0);
                assert!(
                    (f64::from(got[c]) - want).abs() <= 2e-3 * want.max(1e-3) + 1e-6,
                    "s = {s}, channel {c}: {} vs {want}",
                    got[c]
                );
            }
        }
        // Red through a 15 mm finger: about 3% of what the surface reflects (a visible
        // glow), where the sum of Gaussians gives nothing.
        let red15 = lut.sample(15.0)[0];
        assert!((0.02..0.04).contains(&red15), "{red15}");
        assert!(SumOfGaussians::skin().transmittance(15.0)[0] < 1e-10);
    }

    /// A thin slab reflects less than the half-space: the LUT holds the solver's own ratio,
    /// rises to 1, and agrees with the multipole (Donner and Jensen 2005, diffusion theory, an
    /// independent method) where diffusion holds: marble and skin2 from 2 and 3 mm (a few transport mean free paths).
    #[test]
    fn thin_reflectance_is_the_slab_over_the_half_space() {
        let skin2 = crate::Dipole::new([0.013, 0.070, 0.145], [1.09, 1.59, 1.79], 1.3).unwrap();
        let marble = crate::Dipole::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3).unwrap();
        for (d, from_mm, tol) in [(&marble, 2.0, 0.01), (&skin2, 3.0, 0.03)] {
            let table = crate::slab_transport(d, TransmittanceLut::TRANSPORT_POINTS, 32.0).unwrap();
            let lut = TransmittanceLut::thin_reflectance(&table, 2049).unwrap();
            let solver = crate::SlabSolver::new(d.eta).unwrap();
            let deep = crate::Multipole::new(*d, 200.0, 20)
                .unwrap()
                .total_reflectance();
            let mut last = [0.0f32; 3];
            for i in 0..=64 {
                let s = f64::from(i) * 0.5;
                let got = lut.sample(s as f32);
                for c in 0..3 {
                    assert!(
                        got[c] >= last[c] - 1e-6 && got[c] <= 1.0,
                        "s = {s}: {got:?}"
                    );
                }
                last = got;
            }
            assert_eq!(lut.sample(0.0), [0.0; 3]);
            assert!(lut.sample(32.0).iter().all(|v| (v - 1.0).abs() < 1e-2));
            for s in [1.0, 2.0, 3.0, 5.0] {
                let got = lut.sample(s as f32);
                let m = crate::Multipole::new(*d, s, 20)
                    .unwrap()
                    .total_reflectance();
                for c in 0..3 {
                    let ch = d.channel(c);
                    let slab = solver.slab(ch.sigma_t_prime, ch.alpha_prime, s).unwrap();
                    let want = slab.reflected / table.albedo[c];
                    assert!(
                        (f64::from(got[c]) - want).abs() < 2e-3,
                        "{s} mm, {c}: {got:?} vs {want}"
                    );
                    if s >= from_mm {
                        let diffusion = m[c] / deep[c];
                        assert!(
                            (want - diffusion).abs() < tol,
                            "{s} mm, {c}: {want} vs multipole {diffusion}"
                        );
                    }
                }
            }
        }
        // 1 mm of skin1 keeps about half its red albedo, most of its blue.
        let table =
            crate::slab_transport(&skin1(), TransmittanceLut::TRANSPORT_POINTS, 32.0).unwrap();
        let r = table.reflected_at(1.0);
        assert!((0.45..0.6).contains(&r[0]) && r[2] > 0.9, "{r:?}");
    }

    #[test]
    fn transport_lut_holds_the_solvers_values_and_interpolates_between_them() {
        let d = skin1();
        let table = crate::slab_transport(&d, TransmittanceLut::TRANSPORT_POINTS, 32.0).unwrap();
        let lut = TransmittanceLut::transport(&table, 2049).unwrap();
        let solver = crate::SlabSolver::new(d.eta).unwrap();
        // At a solved thickness and between two, against the solver run at that thickness.
        for s in [5.0, 10.125, 15.0] {
            let got = lut.sample(s as f32);
            for c in 0..3 {
                let ch = d.channel(c);
                let r = solver.slab(ch.sigma_t_prime, ch.alpha_prime, s).unwrap();
                let want = (r.transmitted - r.transmitted_once) / table.albedo[c];
                assert!(
                    (f64::from(got[c]) / want - 1.0).abs() < 2e-3,
                    "s = {s}, channel {c}: {} vs {want}",
                    got[c]
                );
            }
        }
        // Nothing through nothing; multiple scattering peaks within a few mean free paths.
        assert_eq!(lut.sample(0.0), [0.0; 3]);
        assert!(lut.sample(2.0)[0] > lut.sample(0.25)[0]);
        // Exact transport passes far more green and blue than diffusion where their reduced
        // albedo is low (path-traced 10 mm slab: the multipole shows 0.43 of the green).
        let multipole = TransmittanceLut::diffusion(&d, 1024, 32.0).unwrap();
        let (t, m) = (lut.sample(10.0), multipole.sample(10.0));
        let rd = d.total_reflectance();
        let ratio = |c: usize| f64::from(t[c]) * table.albedo[c] / (f64::from(m[c]) * rd[c]);
        assert!((0.95..1.15).contains(&ratio(0)), "red {}", ratio(0));
        assert!((1.6..2.2).contains(&ratio(1)), "green {}", ratio(1));
        assert!(ratio(2) > 8.0, "blue {}", ratio(2));
        assert!(TransmittanceLut::transport(&table, 1).is_err());
        // Seen along the normal behind 10 mm, more than the mean, bluer channels more so;
        // less light travels across the flow than along it.
        let last = crate::SlabSolver::EXIT_ANGLES - 1;
        let normal = TransmittanceLut::transport_at(&table, 2049, last).unwrap();
        let sideways = TransmittanceLut::transport_at(&table, 2049, 0).unwrap();
        let through = 1.0 - crate::fresnel_inside(d.eta, 1.0) as f32;
        let k = [0, 1, 2].map(|c| through * normal.sample(10.0)[c] / t[c]);
        assert!(1.05 < k[0] && k[0] < k[1] && k[1] < k[2], "{k:?}");
        for c in 0..3 {
            assert!(sideways.sample(10.0)[c] < 0.7 * normal.sample(10.0)[c]);
        }
        assert!(TransmittanceLut::transport_at(&table, 64, last + 1).is_err());
    }

    #[test]
    fn diffusion_lut_is_monotone_bounded_and_redder_with_depth() {
        let lut = TransmittanceLut::diffusion(&skin1(), 1024, 32.0).unwrap();
        assert_eq!(lut.data[0], [1.0, 1.0, 1.0]);
        for w in lut.data.windows(2) {
            for c in 0..3 {
                assert!(w[1][c] <= w[0][c], "{w:?}");
                assert!((0.0..=1.0).contains(&w[1][c]), "{w:?}");
            }
        }
        let ratio = |s: f32| {
            let t = lut.sample(s);
            t[0] / t[1].max(1e-30)
        };
        assert!(
            ratio(8.0) > 5.0 * ratio(3.0),
            "{} vs {}",
            ratio(8.0),
            ratio(3.0)
        );
        assert!(TransmittanceLut::diffusion(&skin1(), 1, 32.0).is_err());
    }
}
