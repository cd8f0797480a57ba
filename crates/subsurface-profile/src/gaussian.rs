//! Normalised 2-D Gaussians and sums of them (d'Eon's skin profile).

use serde::Serialize;

use crate::error::{CHANNELS, Result, non_negative, positive};

/// Variances (mm^2) of d'Eon's six-Gaussian skin profile, as listed in the
/// transmittance paper's shader (000_*, Figure 7).
pub const SKIN_VARIANCES_MM2: [f64; 6] = [0.0064, 0.0484, 0.187, 0.567, 1.99, 7.41];

/// RGB weights matching [`SKIN_VARIANCES_MM2`] (000_*, Figure 7). Each channel sums to 1.
pub const SKIN_WEIGHTS: [[f64; 3]; 6] = [
    [0.233, 0.455, 0.649],
    [0.100, 0.336, 0.344],
    [0.118, 0.198, 0.000],
    [0.113, 0.007, 0.007],
    [0.358, 0.004, 0.000],
    [0.078, 0.000, 0.000],
];

/// The radially symmetric Gaussian normalised over the plane:
/// `G(v, r) = exp(-r^2 / 2v) / (2 pi v)`, `v` in mm^2, `r` in mm, result in mm^-2.
pub fn gaussian(variance: f64, r: f64) -> f64 {
    (-r * r / (2.0 * variance)).exp() / (2.0 * std::f64::consts::PI * variance)
}

/// One term `w * G(v, r)` of a sum-of-Gaussians profile; `weight` is per RGB channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GaussianTerm {
    /// Variance `v` in mm^2.
    pub variance: f64,
    /// Weight per channel (dimensionless: the term's share of the total reflectance).
    pub weight: [f64; 3],
}

/// A diffusion profile `R(r) = sum_i w_i G(v_i, r)` with per-channel weights.
///
/// Invariants (checked by [`SumOfGaussians::new`]): 1..=64 terms, every variance
/// finite and > 0, every weight finite and >= 0. Terms are kept sorted by variance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SumOfGaussians {
    terms: Vec<GaussianTerm>,
}

impl SumOfGaussians {
    /// Validates and sorts the terms by increasing variance.
    pub fn new(mut terms: Vec<GaussianTerm>) -> Result<Self> {
        crate::error::count("gaussians", terms.len(), 1, 64)?;
        for (i, t) in terms.iter().enumerate() {
            positive(&format!("gaussians[{i}].variance"), t.variance)?;
            for (c, &w) in t.weight.iter().enumerate() {
                non_negative(&format!("gaussians[{i}].weight.{}", CHANNELS[c]), w)?;
            }
        }
        terms.sort_by(|a, b| a.variance.total_cmp(&b.variance));
        Ok(Self { terms })
    }

    /// d'Eon's six-Gaussian skin profile with the weights of 000_*, Figure 7.
    pub fn skin() -> Self {
        let terms = SKIN_VARIANCES_MM2
            .iter()
            .zip(SKIN_WEIGHTS)
            .map(|(&variance, weight)| GaussianTerm { variance, weight })
            .collect();
        Self { terms }
    }

    /// The profile Jimenez's Separable SSS (2015) builds its kernel from: the skin
    /// profile's red weights for all three channels (the channels then differ only
    /// through `falloff`), without the narrowest term, whose light the kernel's
    /// `strength` carries instead.
    pub fn separable_skin() -> Self {
        let terms = SKIN_VARIANCES_MM2
            .iter()
            .zip(SKIN_WEIGHTS)
            .skip(1)
            .map(|(&variance, w)| GaussianTerm {
                variance,
                weight: [w[0]; 3],
            })
            .collect();
        Self { terms }
    }

    /// The terms, sorted by increasing variance.
    pub fn terms(&self) -> &[GaussianTerm] {
        &self.terms
    }

    /// `R(r)` per channel, mm^-2.
    pub fn eval(&self, r_mm: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for t in &self.terms {
            let g = gaussian(t.variance, r_mm);
            for c in 0..3 {
                out[c] += t.weight[c] * g;
            }
        }
        out
    }

    /// Transmittance `T(s) = sum_i w_i exp(-s^2 / v_i)` for a thickness `s` in mm.
    ///
    /// This is the function of the transmittance paper's shader (000_*, Figure 7,
    /// the closed form of its equations 8-9); note the exponent divides by `v`,
    /// not `2v`, exactly as that code does. `T(0)` is the sum of the weights.
    pub fn transmittance(&self, s_mm: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for t in &self.terms {
            let e = (-s_mm * s_mm / t.variance).exp();
            for c in 0..3 {
                out[c] += t.weight[c] * e;
            }
        }
        out
    }

    /// Sum of the weights per channel: the profile's integral over the plane
    /// (total diffuse reflectance), and `T(0)`.
    pub fn total_weight(&self) -> [f64; 3] {
        let mut out = [0.0; 3];
        for t in &self.terms {
            for c in 0..3 {
                out[c] += t.weight[c];
            }
        }
        out
    }

    /// Each term's 1-D projection, `G1(v, x) = sqrt(2 pi v) G(v, x)`, as a term of weight
    /// `w sqrt(2 pi v)`: what a line of the profile integrates to across it, so that
    /// [`Self::eval`] gives the profile's response across a straight edge.
    pub fn projected(&self) -> Self {
        let terms = self
            .terms
            .iter()
            .map(|t| {
                let k = (2.0 * std::f64::consts::PI * t.variance).sqrt();
                GaussianTerm {
                    variance: t.variance,
                    weight: t.weight.map(|w| w * k),
                }
            })
            .collect();
        Self { terms }
    }

    /// The same profile with each channel's weights scaled to sum to 1.
    pub fn normalized(&self) -> Result<Self> {
        let total = self.total_weight();
        for (c, &t) in total.iter().enumerate() {
            positive(&format!("weights.{} (sum)", CHANNELS[c]), t)?;
        }
        let terms = self
            .terms
            .iter()
            .map(|t| GaussianTerm {
                variance: t.variance,
                weight: [
                    t.weight[0] / total[0],
                    t.weight[1] / total[1],
                    t.weight[2] / total[2],
                ],
            })
            .collect();
        Ok(Self { terms })
    }

    /// Radius (mm) inside which each channel holds `fraction` of its energy; the
    /// maximum over channels. A Gaussian holds `1 - exp(-r^2 / 2v)` of its energy
    /// inside `r`, so this is solved by bisection on the exact cumulative sum.
    pub fn energy_radius_mm(&self, fraction: f64) -> f64 {
        let total = self.total_weight();
        let hi0 = self
            .terms
            .iter()
            .map(|t| (2.0 * t.variance).sqrt())
            .fold(0.0, f64::max)
            * 10.0;
        let mut radius: f64 = 0.0;
        for c in 0..3 {
            if total[c] <= 0.0 {
                continue;
            }
            let inside = |r: f64| {
                self.terms
                    .iter()
                    .map(|t| t.weight[c] * (1.0 - (-r * r / (2.0 * t.variance)).exp()))
                    .sum::<f64>()
                    / total[c]
            };
            radius = radius.max(bisect(|r| inside(r) - fraction, 0.0, hi0));
        }
        radius
    }

    /// Energy-weighted mean variance of the widest channel, `max_c sum w v / sum w`
    /// (half the mean squared radius of the profile).
    pub fn mean_variance(&self) -> f64 {
        let total = self.total_weight();
        (0..3)
            .filter(|&c| total[c] > 0.0)
            .map(|c| {
                self.terms
                    .iter()
                    .map(|t| t.weight[c] * t.variance)
                    .sum::<f64>()
                    / total[c]
            })
            .fold(0.0, f64::max)
    }
}

/// Root of an increasing function on `[lo, hi]` by bisection (returns `hi` when
/// the root lies beyond it).
pub(crate) fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    if f(hi) < 0.0 {
        return hi;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi.max(1e-300) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// Composite Simpson rule of `f` over `[a, b]` with `n` (made even) intervals.
#[cfg(test)]
pub(crate) fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let n = n.max(2) & !1;
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        let x = a + h * i as f64;
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(x);
    }
    s * h / 3.0
}

/// d'Eon's skin profile with every variance times `factor` (every radius times its square
/// root), the weights unchanged: a wider material for tests.
#[cfg(test)]
pub(crate) fn widened_skin(factor: f64) -> SumOfGaussians {
    SumOfGaussians::new(
        SumOfGaussians::skin()
            .terms()
            .iter()
            .map(|t| GaussianTerm {
                variance: t.variance * factor,
                weight: t.weight,
            })
            .collect(),
    )
    .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A profile of a single Gaussian term.
    fn one_term(variance: f64, weight: [f64; 3]) -> Result<SumOfGaussians> {
        SumOfGaussians::new(vec![GaussianTerm { variance, weight }])
    }

    #[test]
    fn gaussians_integrate_to_one_over_the_plane() {
        for v in [0.0064f64, 0.187, 1.0, 7.41, 40.0] {
            let r_max = 12.0 * v.sqrt();
            let integral = simpson(|r| 2.0 * PI * r * gaussian(v, r), 0.0, r_max, 20_000);
            assert!((integral - 1.0).abs() < 1e-9, "v = {v}: {integral}");
        }
    }

    #[test]
    fn skin_weights_are_normalised_and_profile_integrates_to_one() {
        let skin = SumOfGaussians::skin();
        for (c, t) in skin.total_weight().into_iter().enumerate() {
            assert!((t - 1.0).abs() < 1e-12, "channel {c}: {t}");
        }
        for c in 0..3 {
            let integral = simpson(|r| 2.0 * PI * r * skin.eval(r)[c], 0.0, 40.0, 200_000);
            assert!((integral - 1.0).abs() < 1e-6, "channel {c}: {integral}");
        }
    }

    #[test]
    fn transmittance_is_positive_monotone_and_starts_at_weight_sum() {
        let skin = SumOfGaussians::skin();
        let t0 = skin.transmittance(0.0);
        assert_eq!(t0, skin.total_weight());
        let mut prev = t0;
        for i in 1..=400 {
            let s = i as f64 * 0.01;
            let t = skin.transmittance(s);
            for c in 0..3 {
                assert!(t[c] > 0.0, "T({s})[{c}] = {}", t[c]);
                assert!(t[c] < prev[c], "T not decreasing at s = {s}, channel {c}");
            }
            prev = t;
        }
        // The paper's curve: the deeper red survives longest.
        let t = skin.transmittance(2.0);
        assert!(t[0] > t[1] && t[1] > t[2], "{t:?}");
    }

    #[test]
    fn separable_skin_drops_narrowest_term_and_uses_red() {
        let p = SumOfGaussians::separable_skin();
        assert_eq!(p.terms().len(), 5);
        assert_eq!(p.terms()[0].variance, 0.0484);
        let w: Vec<f64> = p.terms().iter().map(|t| t.weight[1]).collect();
        assert_eq!(w, vec![0.100, 0.118, 0.113, 0.358, 0.078]);
    }

    #[test]
    fn bad_terms_are_rejected_with_field_names() {
        let e = one_term(0.0, [1.0; 3]).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("gaussians[0].variance: must be > 0")
        );
        let e = one_term(1.0, [1.0, f64::NAN, 1.0]).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("gaussians[0].weight.g: must be finite")
        );
        assert!(SumOfGaussians::new(vec![]).is_err());
    }

    #[test]
    fn energy_radius_matches_single_gaussian_closed_form() {
        let p = one_term(2.0, [1.0; 3]).unwrap();
        // 1 - exp(-r^2 / 2v) = 0.999  =>  r = sqrt(2 v ln 1000)
        let expect = (2.0 * 2.0 * 1000f64.ln()).sqrt();
        assert!((p.energy_radius_mm(0.999) - expect).abs() < 1e-9);
    }
}
