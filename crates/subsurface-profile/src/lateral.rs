//! Light that reaches a point from the whole lit surface around it, not only along the light's
//! ray: the lateral part of the `diffusion` transmittance, and its CPU reference.
//!
//! The slab's `T(s)` (multiply scattered light through `s` mm, [`crate::slab_transport`])
//! measures the medium along one chord. Through a curved part the light also arrives from lit
//! surface off that chord, and behind a thick part (a palm) the shortest way through the
//! medium runs to thinner parts beside it (the finger roots): path-traced, the backlit hand's
//! palm receives 3-5x what the chord's slab gives at 24-32 mm, where thickness alone predicts
//! the slab. A point kernel `K(r)` over the lit surface carries that: light entering at
//! distance `r` from the shaded point contributes `K(r)` per unit of lit area (perpendicular
//! to the light). `K` is calibrated on the slab itself: behind a lit plane at distance `s`,
//! `2 pi int_s^inf K(r) r dr = T(s)`, so `K(r) = -T'(r) / (2 pi r)` reproduces the slab
//! exactly and spreads nothing the slab does not.
//!
//! On the GPU the lit surface is the shadow map: taps on the plane through the shaded point
//! across the light, each reading where the light entered there. [`taps`] places them so that
//! on a slab every tap carries the same weight (a stratified exponential in `u = r - s`, the
//! distance past the chord), and [`lateral_transmittance`] is the estimator the shader runs.

use std::f64::consts::PI;

use crate::error::{Result, count, positive};
use crate::lut::TransmittanceLut;
use crate::transport::TransportTable;

/// The golden angle: successive taps turn by it, so any few of them cover every direction.
pub const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;

/// Default number of lateral taps (`render.transmittance.lateral_taps`).
pub const DEFAULT_LATERAL_TAPS: u32 = 12;

/// Most lateral taps a shader evaluates.
pub const MAX_LATERAL_TAPS: u32 = 32;

impl TransportTable {
    fn step_mm(&self) -> f64 {
        self.s_max_mm / (self.multiple.len() - 1) as f64
    }

    /// `T_ms(s)` per channel, interpolating the logarithm between the solved thicknesses (exact
    /// for the exponential decay the slab settles into); 0 past `s_max_mm`.
    pub fn multiple_at(&self, s_mm: f64) -> [f64; 3] {
        self.segment(s_mm).map_or([0.0; 3], |(a, b, f)| {
            [0, 1, 2].map(|c| log_lerp(a[c], b[c], f))
        })
    }

    /// `-dT_ms/ds` per channel at `s_mm` (per mm), the derivative of [`Self::multiple_at`].
    /// Negative below the thickness where the slab transmits most. Past `s_max_mm` it goes on
    /// decaying at [`Self::lateral_decay_per_mm`], as the shader's kernel does: a lit point
    /// 40 mm away still feeds a point behind 30 mm of palm.
    pub fn slope_at(&self, s_mm: f64) -> [f64; 3] {
        let step = self.step_mm();
        if s_mm > self.s_max_mm {
            let tail = (-self.lateral_decay_per_mm() * (s_mm - self.s_max_mm)).exp();
            return self.slope_at(self.s_max_mm).map(|v| v * tail);
        }
        self.segment(s_mm).map_or([0.0; 3], |(a, b, f)| {
            [0, 1, 2].map(|c| {
                if a[c] > 0.0 && b[c] > 0.0 {
                    -log_lerp(a[c], b[c], f) * (b[c] / a[c]).ln() / step
                } else {
                    (a[c] - b[c]) / step
                }
            })
        })
    }

    /// The slowest channel's decay rate deep in the slab (per mm): how fast the light that
    /// travels farthest dies with distance, from the table's last quarter. The lateral taps
    /// are spread by it.
    pub fn lateral_decay_per_mm(&self) -> f64 {
        let (s1, s2) = (0.75 * self.s_max_mm, self.s_max_mm);
        let (t1, t2) = (self.multiple_at(s1), self.multiple_at(s2));
        (0..3)
            .filter(|&c| t1[c] > 0.0 && t2[c] > 0.0)
            .map(|c| (t1[c] / t2[c]).ln() / (s2 - s1))
            .filter(|r| r.is_finite() && *r > 0.0)
            .fold(f64::INFINITY, f64::min)
    }

    /// The thickness per channel where the slab transmits most (about 2.6 mm in skin1's red,
    /// 1.5 in green, 0.9 in blue): thinner slabs pass less multiply scattered light, as the
    /// unscattered beam takes the rest.
    pub fn peak_mm(&self) -> [f64; 3] {
        let step = self.step_mm();
        [0, 1, 2].map(|c| {
            let k = (0..self.multiple.len())
                .max_by(|&a, &b| self.multiple[a][c].total_cmp(&self.multiple[b][c]))
                .unwrap_or(0);
            k as f64 * step
        })
    }

    /// `T_ms(s)` over its non-increasing envelope `T_ms(max(s, peak))`, per channel: 1 from the
    /// peak on, falling to 0 at `s = 0`. A kernel of the decaying part sees the envelope; this
    /// scales it back to the slab.
    pub fn rise_at(&self, s_mm: f64) -> [f64; 3] {
        let t = self.multiple_at(s_mm);
        let peak = self.peak_mm();
        [0, 1, 2].map(|c| {
            let env = self.multiple_at(s_mm.max(peak[c]))[c];
            if env > 0.0 {
                (t[c] / env).min(1.0)
            } else {
                0.0
            }
        })
    }

    fn segment(&self, s_mm: f64) -> Option<([f64; 3], [f64; 3], f64)> {
        self.segment_of(&self.multiple, s_mm)
    }

    /// The two rows of `rows` (one per solved thickness, as `multiple`) around `s_mm` and the
    /// fraction between them.
    pub(crate) fn segment_of(
        &self,
        rows: &[[f64; 3]],
        s_mm: f64,
    ) -> Option<([f64; 3], [f64; 3], f64)> {
        // NaN, negative and past the table all read nothing.
        if s_mm.is_nan() || s_mm < 0.0 || s_mm > self.s_max_mm {
            return None;
        }
        let points = rows.len();
        let x = (s_mm / self.step_mm()).min((points - 1) as f64);
        let k = (x.floor() as usize).min(points - 2);
        Some((rows[k], rows[k + 1], x - k as f64))
    }
}

impl TransmittanceLut {
    /// The lateral kernel's row for the GPU: `-T_ms'(r)` per mm over `0..=s_max_mm` as a
    /// factor of `albedo` (as [`TransmittanceLut::transport`] stores `T_ms`), 0 below each
    /// channel's peak. The shader divides by `2 pi r` and decays it past the range at
    /// [`TransportTable::lateral_decay_per_mm`]. (Stored without the `1 / r`, which would push
    /// red at 30 mm under half floats' normal range.)
    pub fn lateral_slope(table: &TransportTable, resolution: u32) -> Result<Self> {
        let peak = table.peak_mm();
        Self::from_table(table, resolution, |s| {
            let slope = table.slope_at(s);
            [0, 1, 2].map(|c| {
                let albedo = table.albedo[c];
                if s >= peak[c] && albedo > 0.0 {
                    slope[c] / albedo
                } else {
                    0.0
                }
            })
        })
    }

    /// [`TransportTable::rise_at`] over `0..=s_max_mm`, for the GPU (the shader reads 1 past it).
    pub fn rise(table: &TransportTable, resolution: u32) -> Result<Self> {
        Self::from_table(table, resolution, |s| table.rise_at(s))
    }

    pub(crate) fn from_table(
        table: &TransportTable,
        resolution: u32,
        f: impl Fn(f64) -> [f64; 3],
    ) -> Result<Self> {
        count("resolution", resolution as usize, 2, 65536)?;
        count("table points", table.multiple.len(), 2, 1 << 16)?;
        let last = f64::from(resolution - 1);
        let data = (0..resolution)
            .map(|i| f(f64::from(i) / last * table.s_max_mm).map(|v| v as f32))
            .collect();
        Ok(Self {
            resolution,
            s_max_mm: table.s_max_mm as f32,
            data,
        })
    }
}

fn log_lerp(a: f64, b: f64, f: f64) -> f64 {
    if a > 0.0 && b > 0.0 {
        (a.ln() * (1.0 - f) + b.ln() * f).exp()
    } else {
        a * (1.0 - f) + b * f
    }
}

/// The point kernel `K(r) = -T'(r) / (2 pi r)` per channel (per mm^2), 0 where the slab still
/// gains with thickness (under [`TransportTable::peak_mm`]): it is the kernel of the slab's
/// non-increasing envelope, and [`TransportTable::rise_at`] of the chord takes that back.
pub fn kernel(table: &TransportTable, r_mm: f64) -> [f64; 3] {
    let slope = table.slope_at(r_mm);
    [0, 1, 2].map(|c| {
        if r_mm > 0.0 {
            (slope[c] / (2.0 * PI * r_mm)).max(0.0)
        } else {
            0.0
        }
    })
}

/// One lateral tap: where it lies on the plane across the light through the shaded point, and
/// the lit area it stands for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tap {
    /// Distance from the chord on that plane (mm).
    pub rho_mm: f64,
    /// Direction on that plane (radians).
    pub phi: f64,
    /// The area it stands for, over `2 pi`: the tap's contribution is `K(r) 2 pi weight` for
    /// the lit point at distance `r` found there (mm^2 / 2 pi).
    pub weight: f64,
}

/// `n` taps for the chord `s_mm` (at least 1 mm) and decay rate `sigma` per mm. Behind a plane
/// at distance `s` the lit point at `rho` is `r = sqrt(s^2 + rho^2)` away, `rho d rho = r dr`,
/// and `K(r) r dr` is close to `sigma e^(-sigma u) du` in `u = r - s`; stratifying `u` over
/// that exponential makes every tap of a slab weigh the same, so twelve taps reproduce `T(s)`.
pub fn taps(n: u32, s_mm: f64, sigma: f64) -> Result<Vec<Tap>> {
    count("lateral taps", n as usize, 1, MAX_LATERAL_TAPS as usize)?;
    positive("lateral decay", sigma)?;
    let s = s_mm.max(1.0);
    Ok((0..n)
        .map(|i| {
            let xi = (f64::from(i) + 0.5) / f64::from(n);
            let u = -(1.0 - xi).ln() / sigma;
            let r = s + u;
            Tap {
                rho_mm: (r * r - s * s).sqrt(),
                phi: f64::from(i) * GOLDEN_ANGLE,
                // 1 / (n pdf) in area, pdf = sigma e^(-sigma u) / (2 pi r).
                weight: r / (f64::from(n) * sigma * (-sigma * u).exp()),
            }
        })
        .collect())
}

/// The lateral transmittance at a point whose chord is `s_mm`: `sum K(r_i) 2 pi weight_i` over
/// [`taps`] times [`TransportTable::rise_at`] of the chord, per channel, in the units of
/// [`TransportTable::multiple`]. Behind a lit plane it is the slab's `T(s)` at any `s`.
/// `lit(rho, phi)` returns the distance (mm) from the point to where the light entered at that
/// tap and a weight in 0..=1 for how much of it counts (the shader's: entries below the
/// point's tangent plane, times the boundary's transmittance there over normal incidence's),
/// or `None` where no light enters (nothing there).
pub fn lateral_transmittance(
    table: &TransportTable,
    s_mm: f64,
    sigma: f64,
    n: u32,
    mut lit: impl FnMut(f64, f64) -> Option<(f64, f64)>,
) -> Result<[f64; 3]> {
    let mut sum = [0.0; 3];
    for tap in taps(n, s_mm, sigma)? {
        if let Some((r, w)) = lit(tap.rho_mm, tap.phi) {
            let k = kernel(table, r);
            for c in 0..3 {
                sum[c] += k[c] * 2.0 * PI * tap.weight * w;
            }
        }
    }
    let rise = table.rise_at(s_mm);
    Ok([0, 1, 2].map(|c| sum[c] * rise[c]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::skin1;
    use crate::slab_transport;

    fn table() -> TransportTable {
        slab_transport(&skin1(), 129, 32.0).unwrap()
    }

    /// The kernel is the slab's: integrated over a lit plane at distance s it gives T(s).
    #[test]
    fn the_kernel_over_a_lit_plane_is_the_slab() {
        let t = table();
        for s in [3.0, 5.0, 10.0, 20.0] {
            // Past every channel's peak. 2 pi int_s^32 K(r) r dr by the midpoint rule on 0.01 mm.
            let mut sum = [0.0; 3];
            let h = 0.01;
            let mut r = s + h / 2.0;
            while r < 32.0 {
                let k = kernel(&t, r);
                for c in 0..3 {
                    sum[c] += 2.0 * PI * k[c] * r * h;
                }
                r += h;
            }
            let want = t.multiple_at(s);
            let tail = t.multiple_at(32.0);
            for c in 0..3 {
                let got = sum[c] + tail[c];
                assert!(
                    (got / want[c] - 1.0).abs() < 2e-3,
                    "s {s} channel {c}: {got} vs {}",
                    want[c]
                );
            }
        }
    }

    /// Twelve stratified taps behind a lit plane give the slab's T(s): within 2 % in red (the
    /// channel they are spread for) and 10 % in green and blue, which die faster.
    #[test]
    fn twelve_taps_behind_a_plane_give_the_slab() {
        let t = table();
        let sigma = t.lateral_decay_per_mm();
        for s in [0.3, 1.0, 2.0, 4.0, 8.0, 14.0, 20.0, 28.0] {
            let got = lateral_transmittance(&t, s, sigma, 12, |rho, _| {
                Some(((s * s + rho * rho).sqrt(), 1.0))
            })
            .unwrap();
            let want = t.multiple_at(s);
            let tol = [0.02, 0.10, 0.10];
            for c in 0..3 {
                // Green and blue past ~15 mm pass under 1e-6: nothing a pixel shows.
                if want[c] < 1e-6 {
                    continue;
                }
                assert!(
                    (got[c] / want[c] - 1.0).abs() < tol[c],
                    "s {s} channel {c}: {} vs {}",
                    got[c],
                    want[c]
                );
            }
        }
    }

    /// Red light decays at exact transport's rate, which for skin1 is about 0.26 per mm (a
    /// factor of 14 every 10 mm), slower than green and blue.
    #[test]
    fn the_slowest_decay_is_reds() {
        let t = table();
        let sigma = t.lateral_decay_per_mm();
        assert!((0.24..0.29).contains(&sigma), "{sigma}");
        let red = (t.multiple_at(10.0)[0] / t.multiple_at(20.0)[0]).ln() / 10.0;
        assert!((red / sigma - 1.0).abs() < 0.03, "{red} vs {sigma}");
    }

    /// A thick part beside a thin one (a palm beside a finger's root): the light that crossed
    /// the thin part and spreads under the thick one is more than the thick chord's slab, and
    /// the estimate falls toward the slab's away from the step.
    #[test]
    fn a_thin_neighbour_feeds_a_thick_part() {
        let t = table();
        let sigma = t.lateral_decay_per_mm();
        // Thick (25 mm) for x < 0 along phi = 0, thin (10 mm) beyond; the shaded point sits
        // at distance `d` from the step on the thick side, on the far face.
        let estimate = |d: f64| {
            lateral_transmittance(&t, 25.0, sigma, 32, |rho, phi| {
                let x = rho * phi.cos() - d;
                let depth = if x > 0.0 { 10.0 } else { 25.0 };
                Some(((depth * depth + rho * rho).sqrt(), 1.0))
            })
            .unwrap()[0]
        };
        let slab = t.multiple_at(25.0)[0];
        let (near, mid, far) = (estimate(3.0), estimate(8.0), estimate(20.0));
        assert!(near > 5.0 * slab, "{near} vs {slab}");
        assert!(near > mid && mid > far, "{near} {mid} {far}");
        assert!(far < 1.5 * slab && far >= 0.95 * slab, "{far} vs {slab}");
    }

    #[test]
    fn bad_arguments_are_errors() {
        assert!(taps(0, 5.0, 0.3).is_err());
        assert!(taps(MAX_LATERAL_TAPS + 1, 5.0, 0.3).is_err());
        assert!(taps(12, 5.0, 0.0).is_err());
        assert!(taps(12, 5.0, f64::NAN).is_err());
        assert_eq!(table().multiple_at(f64::NAN), [0.0; 3]);
        assert_eq!(table().multiple_at(40.0), [0.0; 3]);
    }
}
