//! Screen-space blur kernels: the separable kernel of Separable SSS (Jimenez et al.
//! 2015), the 7-tap Gaussian of the 2009 screen-space shader and Hable et al.'s
//! 13-tap jittered kernel.

use crate::error::{CHANNELS, ProfileError, Result, in_range, non_negative, positive};
use crate::gaussian::{SumOfGaussians, gaussian};

/// Default per-channel `strength` of the separable kernel (Jimenez's SeparableSSS demo).
pub const DEFAULT_STRENGTH: [f32; 3] = [0.48, 0.41, 0.28];
/// Default per-channel `falloff` of the separable kernel (Jimenez's SeparableSSS demo).
pub const DEFAULT_FALLOFF: [f32; 3] = [1.0, 0.37, 0.3];
/// Default tap count (the SeparableSSS demo's default quality).
pub const DEFAULT_SAMPLES: u32 = 17;

/// Weights of the 7-tap 1-D Gaussian of the screen-space skin shader (003_*,
/// `BlurPS`: 0.382 at the centre, then 0.242, 0.061, 0.006 on each side). Tap `j`
/// (index `j + 3`) sits at `j * sigma` for `j = -3..=3`; the weights sum to 1.
pub const GAUSSIAN7_WEIGHTS: [f32; 7] = [0.006, 0.061, 0.242, 0.382, 0.242, 0.061, 0.006];
/// Offsets of the 7 taps in units of the Gaussian's standard deviation.
pub const GAUSSIAN7_OFFSETS_SIGMA: [f32; 7] = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0];

/// Hable et al. 2009's 13-tap jittered kernel, `[x_mm, y_mm, r, g, b]`, copied
/// from Table 1 of 001_*; tap 0 is the centre.
///
/// The raw columns do not sum exactly to 1 (r 0.9977, g 1.0494, b 0.9996), so
/// use [`hable13_kernel`] for the per-channel normalised weights.
pub const HABLE13_TAPS: [[f32; 5]; 13] = [
    [0.0000, 0.0000, 0.2204, 0.4870, 0.6350],
    [1.6339, 0.0367, 0.0763, 0.0644, 0.0390],
    [0.1778, 1.7175, 0.1165, 0.1032, 0.0649],
    [-0.1949, 0.0910, 0.0648, 0.0863, 0.0622],
    [-0.2397, -0.2202, 0.1317, 0.1516, 0.1036],
    [-0.0035, -0.1182, 0.0256, 0.0427, 0.0330],
    [1.3201, -0.1815, 0.0485, 0.0647, 0.0461],
    [5.9706, 0.2533, 0.0480, 0.0030, 0.0004],
    [-1.0892, 4.9583, 0.0488, 0.0054, 0.0012],
    [-4.0154, 4.1566, 0.0513, 0.0060, 0.0014],
    [-4.0630, -4.1101, 0.0614, 0.0091, 0.0025],
    [-0.6386, -6.2976, 0.0309, 0.0028, 0.0006],
    [2.5423, -3.2459, 0.0735, 0.0232, 0.0097],
];

/// [`HABLE13_TAPS`] with each colour channel scaled to sum to 1 (so a constant
/// image stays constant); positions unchanged.
pub fn hable13_kernel() -> [[f32; 5]; 13] {
    let mut sum = [0.0f64; 3];
    for t in &HABLE13_TAPS {
        for c in 0..3 {
            sum[c] += t[2 + c] as f64;
        }
    }
    let mut out = HABLE13_TAPS;
    for t in &mut out {
        for c in 0..3 {
            t[2 + c] = (t[2 + c] as f64 / sum[c]) as f32;
        }
    }
    out
}

/// Parameters of the separable kernel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelParams {
    /// Tap count, odd, in 3..=63.
    pub samples: u32,
    /// Per channel, in 0..=1: 0 leaves the pixel unblurred, 1 uses the full profile.
    pub strength: [f32; 3],
    /// Per channel, >= 0: the profile radius is divided by `0.001 + falloff`, so
    /// smaller values make that channel's kernel narrower.
    pub falloff: [f32; 3],
}

impl Default for KernelParams {
    fn default() -> Self {
        Self {
            samples: DEFAULT_SAMPLES,
            strength: DEFAULT_STRENGTH,
            falloff: DEFAULT_FALLOFF,
        }
    }
}

impl KernelParams {
    /// Checks `samples`, `strength` and `falloff`.
    pub fn validate(&self) -> Result<()> {
        if self.samples < 3 || self.samples > 63 || self.samples.is_multiple_of(2) {
            return Err(ProfileError::Samples(self.samples));
        }
        for c in 0..3 {
            in_range(
                &format!("strength.{}", CHANNELS[c]),
                self.strength[c] as f64,
                0.0,
                1.0,
            )?;
            non_negative(&format!("falloff.{}", CHANNELS[c]), self.falloff[c] as f64)?;
        }
        Ok(())
    }
}

/// Half-width (mm, before falloff) that Separable SSS spreads its taps over:
/// 2 mm up to 20 taps, 3 mm above (SeparableSSS.h's `RANGE`).
pub fn separable_range_mm(samples: u32) -> f64 {
    if samples > 20 { 3.0 } else { 2.0 }
}

/// The Separable SSS skin kernel: `[r, g, b, offset_mm]` per tap, centre tap
/// first, the other taps in increasing offset order.
///
/// Same as [`separable_kernel_for`] with [`SumOfGaussians::separable_skin`] and
/// the range [`separable_range_mm`].
pub fn separable_kernel(params: &KernelParams) -> Result<Vec<[f32; 4]>> {
    separable_kernel_for(
        &SumOfGaussians::separable_skin(),
        params,
        separable_range_mm(params.samples),
    )
}

/// The half-width that gives `profile` the same coverage the skin kernel gets
/// from [`separable_range_mm`]: that range scaled by the ratio of standard
/// deviations `sqrt(mean_variance(profile) / mean_variance(separable skin))`.
/// For [`SumOfGaussians::separable_skin`] it equals `separable_range_mm`.
pub fn separable_range_for(profile: &SumOfGaussians, samples: u32) -> f64 {
    let reference = SumOfGaussians::separable_skin().mean_variance();
    separable_range_mm(samples) * (profile.mean_variance() / reference).sqrt()
}

/// Half-width for [`separable_kernel_projected`]: the radial range of
/// [`separable_range_for`], widened to 2.5 standard deviations of the widest Gaussian that
/// holds at least 2 % of some channel. The projection keeps a measured material's heavy tail
/// (skin1's red: 18 % of the light in a term of sigma 5.3 mm), which the radial range cut.
pub fn separable_range_projected(profile: &SumOfGaussians, samples: u32) -> f64 {
    let total = profile.total_weight();
    let widest = profile
        .terms()
        .iter()
        .filter(|t| (0..3).any(|c| total[c] > 0.0 && t.weight[c] >= 0.02 * total[c]))
        .map(|t| t.variance)
        .fold(0.0, f64::max);
    separable_range_for(profile, samples).max(2.5 * widest.sqrt())
}

/// Separable SSS kernel (Jimenez et al. 2015, as in its SeparableSSS.h) built
/// from any sum-of-Gaussians `profile`, `[r, g, b, offset_mm]`, centre first.
///
/// 1. Offsets: `o_i = -R + i * 2R / (N - 1)`, remapped to `sign(o) o^2 / R`
///    so taps crowd near the centre where the profile is steep.
/// 2. Each tap's weight is its footprint (half the distance to each neighbour;
///    the end taps have one neighbour) times the profile at its offset, where
///    channel `c` evaluates `sum_i w_i[c] G(v_i, |o| / (0.001 + falloff[c]))`.
/// 3. The centre tap is moved first, the rest keep increasing offset order.
/// 4. Each channel is normalised to sum 1.
/// 5. `strength`: centre `= lerp(1, centre, strength)`, other taps `*= strength`,
///    so every channel still sums to 1.
pub fn separable_kernel_for(
    profile: &SumOfGaussians,
    params: &KernelParams,
    range_mm: f64,
) -> Result<Vec<[f32; 4]>> {
    params.validate()?;
    positive("range_mm", range_mm)?;
    let n = params.samples as usize;
    let range = range_mm;
    let offsets: Vec<f64> = (0..n)
        .map(|i| {
            // -R + i * 2R / (N - 1), written so the middle tap is exactly 0.
            let o = (2.0 * i as f64 - (n - 1) as f64) * range / (n - 1) as f64;
            // SeparableSSS.h's EXPONENT = 2 importance spacing.
            o.signum() * o * o / range
        })
        .collect();
    let falloff = params.falloff.map(|f| 0.001 + f as f64);
    let mut taps: Vec<[f64; 4]> = (0..n)
        .map(|i| {
            let left = if i > 0 {
                offsets[i] - offsets[i - 1]
            } else {
                0.0
            };
            let right = if i + 1 < n {
                offsets[i + 1] - offsets[i]
            } else {
                0.0
            };
            let area = 0.5 * (left + right);
            let mut tap = [0.0, 0.0, 0.0, offsets[i]];
            for (c, f) in falloff.iter().enumerate() {
                let r = offsets[i] / f;
                let p: f64 = profile
                    .terms()
                    .iter()
                    .map(|t| t.weight[c] * gaussian(t.variance, r))
                    .sum();
                tap[c] = area * p;
            }
            tap
        })
        .collect();
    // The middle tap of an odd count is offset 0; rotate it to the front.
    let centre = taps.remove(n / 2);
    taps.insert(0, centre);
    let mut sum = [0.0; 3];
    for t in &taps {
        for c in 0..3 {
            sum[c] += t[c];
        }
    }
    for (c, &s) in sum.iter().enumerate() {
        positive(&format!("kernel sum.{} (profile vanishes)", CHANNELS[c]), s)?;
    }
    for t in &mut taps {
        for c in 0..3 {
            t[c] /= sum[c];
        }
    }
    for c in 0..3 {
        let s = params.strength[c] as f64;
        taps[0][c] = (1.0 - s) + s * taps[0][c];
        for t in taps.iter_mut().skip(1) {
            t[c] *= s;
        }
    }
    Ok(taps
        .into_iter()
        .map(|t| [t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32])
        .collect())
}

/// [`separable_kernel_for`] with each Gaussian's 1-D projection, `G1(v, x) = sqrt(2 pi v)
/// G(v, x)`, in place of the radial profile sampled along a line: the kernel a separable
/// pass needs for the right response to a straight edge (the knife-edge measurement,
/// docs/lab/fidelity.md). Blurring along x then y with it, every edge's profile across it is
/// exactly the 2-D profile's, because the pass along the edge integrates to 1. The radial
/// sampling of SeparableSSS.h (`separable_kernel_for`) weighs each term by `1 / sqrt(v)` on
/// top, which for skin's tabulated kernel is part of the paper's look but for a measured
/// material's heavy red tail halved the edge width against the path tracer.
pub fn separable_kernel_projected(
    profile: &SumOfGaussians,
    params: &KernelParams,
    range_mm: f64,
) -> Result<Vec<[f32; 4]>> {
    separable_kernel_for(&profile.projected(), params, range_mm)
}

/// Half-width (mm) over which the jittered few-sample mode moves each separable tap: a quarter
/// of the tap's footprint (the distance to its neighbours in offset order, as
/// [`separable_kernel_for`] measures it for the weights), so a tap wanders over the interval
/// whose profile its weight stands for and the mean position stays at the tap. In kernel order
/// (centre first); the centre tap, whose weight multiplies the pixel itself, is not moved (0).
pub fn separable_jitter_widths(kernel: &[[f32; 4]]) -> Vec<f32> {
    let mut sorted: Vec<f32> = kernel.iter().map(|t| t[3]).collect();
    sorted.sort_by(f32::total_cmp);
    kernel
        .iter()
        .enumerate()
        .map(|(i, t)| {
            if i == 0 {
                return 0.0;
            }
            let o = t[3];
            let left = sorted.iter().rev().find(|&&s| s < o).map_or(0.0, |s| o - s);
            let right = sorted.iter().find(|&&s| s > o).map_or(0.0, |s| s - o);
            0.25 * (left + right)
        })
        .collect()
}

/// Number of Gaussians the six-Gaussian screen-space method chains (d'Eon's skin has six).
pub const SCREEN_GAUSSIANS: usize = 6;

/// Everything the screen-space passes need of one diffusion profile: one row of the profile
/// table that the GPU indexes by each pixel's profile id.
#[derive(Debug, Clone, PartialEq)]
pub struct ScreenKernels {
    /// Separable SSS: `[r, g, b, offset_mm]`, centre first ([`separable_kernel_for`]).
    pub separable: Vec<[f32; 4]>,
    /// Hable's 13 taps `[x_mm, y_mm, r, g, b]`, centre first, each channel summing to 1.
    pub hable13: [[f32; 5]; 13],
    /// The six Gaussians `[r, g, b, variance_mm2]`, by increasing variance, each channel's
    /// weights summing to 1 (the albedo carries the colour).
    pub gaussians: [[f32; 4]; SCREEN_GAUSSIANS],
}

impl ScreenKernels {
    /// Skin as the papers give it: Jimenez's separable kernel ([`separable_kernel`]), Hable's
    /// table ([`hable13_kernel`]) and d'Eon's six Gaussians.
    pub fn skin(params: &KernelParams) -> Result<Self> {
        Ok(Self {
            separable: separable_kernel(params)?,
            hable13: hable13_kernel(),
            gaussians: gaussian_table(&SumOfGaussians::skin())?,
        })
    }

    /// Any profile given as Gaussians (a measured material's fit): the separable kernel of
    /// the profile's 1-D projection ([`separable_kernel_projected`]) over
    /// [`separable_range_projected`], Hable's taps re-weighted to it, and
    /// its Gaussians.
    pub fn for_profile(profile: &SumOfGaussians, params: &KernelParams) -> Result<Self> {
        Ok(Self {
            separable: separable_kernel_projected(
                profile,
                params,
                separable_range_projected(profile, params.samples),
            )?,
            hable13: hable13_for(profile)?,
            gaussians: gaussian_table(profile)?,
        })
    }
}

/// The profile's Gaussians as `[r, g, b, variance]` rows, weights normalised per channel; a
/// profile of fewer terms is padded with weightless copies of its widest one (a blur step of
/// zero width, which changes nothing).
pub fn gaussian_table(profile: &SumOfGaussians) -> Result<[[f32; 4]; SCREEN_GAUSSIANS]> {
    let p = profile.normalized()?;
    let terms = p.terms();
    if terms.len() > SCREEN_GAUSSIANS {
        return Err(ProfileError::Invalid {
            field: "gaussians".into(),
            reason: format!(
                "the screen-space six-Gaussian method takes at most {SCREEN_GAUSSIANS} (got {})",
                terms.len()
            ),
        });
    }
    let widest = terms[terms.len() - 1].variance as f32;
    let mut out = [[0.0, 0.0, 0.0, widest]; SCREEN_GAUSSIANS];
    for (row, t) in out.iter_mut().zip(terms) {
        *row = [
            t.weight[0] as f32,
            t.weight[1] as f32,
            t.weight[2] as f32,
            t.variance as f32,
        ];
    }
    Ok(out)
}

/// Hable's 13 jittered taps for another profile. The table samples d'Eon's skin profile: each
/// weight is the skin profile at the tap times the area the tap stands for. For a profile of
/// another size the positions scale by the ratio of standard deviations `s`, and each weight
/// by `R(s r) / R_skin(r)` per channel (the same samples, importance-weighted for the new
/// profile), then each channel is normalised. For skin itself this is [`hable13_kernel`].
pub fn hable13_for(profile: &SumOfGaussians) -> Result<[[f32; 5]; 13]> {
    let skin = SumOfGaussians::skin();
    let scale = (profile.mean_variance() / skin.mean_variance()).sqrt();
    positive("profile size", scale)?;
    let mut out = hable13_kernel();
    let mut sum = [0.0f64; 3];
    for t in &mut out {
        let r = ((t[0] as f64).powi(2) + (t[1] as f64).powi(2)).sqrt();
        let ours = profile.eval(r * scale);
        let theirs = skin.eval(r);
        for c in 0..3 {
            let w = t[2 + c] as f64 * ours[c] / theirs[c].max(1e-300);
            t[2 + c] = w as f32;
            sum[c] += w;
        }
        t[0] = (t[0] as f64 * scale) as f32;
        t[1] = (t[1] as f64 * scale) as f32;
    }
    for (c, &s) in sum.iter().enumerate() {
        positive(&format!("hable13 weight sum.{}", CHANNELS[c]), s)?;
    }
    for t in &mut out {
        for c in 0..3 {
            t[2 + c] = (t[2 + c] as f64 / sum[c]) as f32;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{SKIN_VARIANCES_MM2, SKIN_WEIGHTS};
    use std::f64::consts::PI;

    #[test]
    fn screen_kernels_of_skin_are_the_papers_tables() {
        let params = KernelParams::default();
        let k = ScreenKernels::skin(&params).unwrap();
        assert_eq!(k.separable, separable_kernel(&params).unwrap());
        assert_eq!(k.hable13, hable13_kernel());
        for (row, (v, w)) in k
            .gaussians
            .iter()
            .zip(SKIN_VARIANCES_MM2.iter().zip(SKIN_WEIGHTS))
        {
            assert_eq!(row[3], *v as f32);
            for c in 0..3 {
                assert!((row[c] as f64 - w[c]).abs() < 1e-6);
            }
        }
        // Re-weighting Hable's table for skin itself changes nothing.
        let again = hable13_for(&SumOfGaussians::skin()).unwrap();
        for (a, b) in again.iter().zip(hable13_kernel().iter()) {
            for i in 0..5 {
                assert!((a[i] - b[i]).abs() < 1e-6, "{a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn a_wider_profile_spreads_hable_taps_further_and_keeps_unit_sums() {
        let wide = crate::gaussian::widened_skin(4.0);
        let k = hable13_for(&wide).unwrap();
        let skin = hable13_kernel();
        // Scaling the profile by 2 scales the taps by 2 and leaves the weights.
        for (a, b) in k.iter().zip(skin.iter()) {
            assert!((a[0] - 2.0 * b[0]).abs() < 1e-4 && (a[1] - 2.0 * b[1]).abs() < 1e-4);
            for c in 2..5 {
                assert!((a[c] - b[c]).abs() < 1e-4, "{a:?} vs {b:?}");
            }
        }
        let table = gaussian_table(&wide).unwrap();
        for c in 0..3 {
            let s: f32 = table.iter().map(|r| r[c]).sum();
            assert!((s - 1.0).abs() < 1e-5);
        }
    }

    fn unit_strength(samples: u32) -> KernelParams {
        KernelParams {
            samples,
            strength: [1.0; 3],
            ..KernelParams::default()
        }
    }

    #[test]
    fn channels_sum_to_one_before_and_after_strength() {
        for n in (3..=63).step_by(2) {
            for params in [
                unit_strength(n),
                KernelParams {
                    samples: n,
                    ..Default::default()
                },
            ] {
                let k = separable_kernel(&params).unwrap();
                assert_eq!(k.len(), n as usize);
                for c in 0..3 {
                    let s: f64 = k.iter().map(|t| t[c] as f64).sum();
                    assert!((s - 1.0).abs() < 1e-5, "n = {n}, c = {c}: {s}");
                }
            }
        }
    }

    #[test]
    fn strength_lerps_centre_and_scales_the_rest() {
        let full = separable_kernel(&unit_strength(17)).unwrap();
        let params = KernelParams::default();
        let k = separable_kernel(&params).unwrap();
        for c in 0..3 {
            let s = params.strength[c];
            assert!((k[0][c] - (1.0 - s + s * full[0][c])).abs() < 1e-6);
            for i in 1..k.len() {
                assert!((k[i][c] - s * full[i][c]).abs() < 1e-7);
            }
        }
    }

    #[test]
    fn offsets_are_symmetric_increasing_and_quadratic() {
        for n in [3, 5, 11, 17, 19, 21, 25, 63] {
            let k = separable_kernel(&KernelParams {
                samples: n,
                ..Default::default()
            })
            .unwrap();
            assert_eq!(k[0][3], 0.0, "centre tap first");
            let rest: Vec<f32> = k[1..].iter().map(|t| t[3]).collect();
            for w in rest.windows(2) {
                assert!(w[0] < w[1], "n = {n}: not increasing {rest:?}");
            }
            let m = rest.len();
            for i in 0..m / 2 {
                assert!(
                    (rest[i] + rest[m - 1 - i]).abs() < 1e-6,
                    "n = {n}: not symmetric"
                );
                // Weights mirror too, since the profile is radial.
                for c in 0..3 {
                    assert!((k[1 + i][c] - k[m - i][c]).abs() < 1e-7);
                }
            }
            let range = separable_range_mm(n) as f32;
            assert!(
                (rest[m - 1] - range).abs() < 1e-6,
                "n = {n}: last offset {}",
                rest[m - 1]
            );
            // Quadratic spacing: the first tap right of centre sits at step^2 / R.
            let step = 2.0 * range / (n - 1) as f32;
            assert!((rest[m / 2] - step * step / range).abs() < 1e-6);
        }
        assert_eq!(separable_range_mm(19), 2.0);
        assert_eq!(separable_range_mm(21), 3.0);
    }

    #[test]
    fn matches_a_hand_computed_three_tap_kernel() {
        // N = 3, R = 2: offsets -2, 0, 2; areas 1, 2, 1.
        let params = KernelParams {
            samples: 3,
            strength: [1.0; 3],
            falloff: [1.0; 3],
        };
        let k = separable_kernel(&params).unwrap();
        let p = |r: f64| -> f64 {
            SumOfGaussians::separable_skin()
                .terms()
                .iter()
                .map(|t| t.weight[0] * gaussian(t.variance, r / 1.001))
                .sum()
        };
        let (side, centre) = (p(2.0), 2.0 * p(0.0));
        let total = centre + 2.0 * side;
        assert!((k[0][0] as f64 - centre / total).abs() < 1e-6);
        assert!((k[1][0] as f64 - side / total).abs() < 1e-6);
        assert_eq!([k[0][3], k[1][3], k[2][3]], [0.0, -2.0, 2.0]);
    }

    #[test]
    fn falloff_narrows_channels() {
        // Smaller falloff (blue) concentrates more weight in the centre tap.
        let k = separable_kernel(&unit_strength(25)).unwrap();
        assert!(k[0][2] > k[0][1] && k[0][1] > k[0][0], "{:?}", k[0]);
    }

    #[test]
    fn bad_params_are_errors() {
        for n in [0, 1, 2, 4, 64, 65, 100] {
            let e = separable_kernel(&KernelParams {
                samples: n,
                ..Default::default()
            })
            .unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("samples: must be odd and in 3..=63 (got {n})")
            );
        }
        let e = separable_kernel(&KernelParams {
            strength: [0.5, 1.5, 0.5],
            ..Default::default()
        })
        .unwrap_err();
        assert!(e.to_string().starts_with("strength.g: "), "{e}");
        let e = separable_kernel(&KernelParams {
            falloff: [0.5, 0.5, f32::NAN],
            ..Default::default()
        })
        .unwrap_err();
        assert!(
            e.to_string().starts_with("falloff.b: must be finite"),
            "{e}"
        );
        let e = separable_kernel(&KernelParams {
            falloff: [-0.5, 0.5, 0.5],
            ..Default::default()
        })
        .unwrap_err();
        assert!(e.to_string().starts_with("falloff.r: must be >= 0"), "{e}");
    }

    #[test]
    fn range_for_skin_profile_is_the_default_range() {
        let p = SumOfGaussians::separable_skin();
        assert!((separable_range_for(&p, 17) - 2.0).abs() < 1e-12);
        assert!((separable_range_for(&p, 33) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn hable_table_sums_and_normalisation() {
        let mut raw = [0.0f64; 3];
        for t in &HABLE13_TAPS {
            for c in 0..3 {
                raw[c] += t[2 + c] as f64;
            }
        }
        assert!((raw[0] - 0.9977).abs() < 1e-4 && (raw[1] - 1.0494).abs() < 1e-4);
        assert!((raw[2] - 0.9996).abs() < 1e-4, "{raw:?}");
        let k = hable13_kernel();
        for c in 0..3 {
            let s: f64 = k.iter().map(|t| t[2 + c] as f64).sum();
            assert!((s - 1.0).abs() < 1e-6);
        }
        assert_eq!(k[0][0..2], [0.0, 0.0]);
    }

    #[test]
    fn gaussian7_weights_sum_to_one() {
        let s: f32 = GAUSSIAN7_WEIGHTS.iter().sum();
        assert!((s - 1.0).abs() < 1e-6);
    }

    /// The fraction of a 2-D sum of Gaussians on one side of a straight edge at distance x:
    /// sum w_i Phi(x / sigma_i), Phi by Simpson's rule on the 1-D Gaussian.
    fn edge_response(p: &SumOfGaussians, c: usize, x: f64) -> f64 {
        let total: f64 = p.terms().iter().map(|t| t.weight[c]).sum();
        p.terms()
            .iter()
            .map(|t| {
                let sd = t.variance.sqrt();
                let n = 2000;
                let (a, b) = (-10.0 * sd, x);
                let h = (b - a) / n as f64;
                let g = |y: f64| (-y * y / (2.0 * t.variance)).exp() / (sd * (2.0 * PI).sqrt());
                let mut sum = g(a) + g(b);
                for i in 1..n {
                    sum += g(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
                }
                t.weight[c] * (sum * h / 3.0).max(0.0)
            })
            .sum::<f64>()
            / total
    }

    #[test]
    fn the_projected_kernel_has_the_profiles_own_edge_response() {
        // Skin1's fitted profile, red (its heavy tail): the separable kernel's running sum
        // across an edge must be the 2-D profile's edge response, what the knife-edge scene
        // measures; the radial sampling of SeparableSSS.h falls well short of it.
        let d = crate::materials::skin1();
        let fit = crate::Material::Dipole {
            name: "skin1".into(),
            dipole: d,
        }
        .fit(6)
        .unwrap();
        let params = KernelParams {
            samples: 63,
            strength: [1.0; 3],
            falloff: [1.0; 3],
        };
        let range = separable_range_projected(&fit.profile, 63);
        let worst = |k: &[[f32; 4]]| -> f64 {
            let mut taps: Vec<[f32; 4]> = k.to_vec();
            taps.sort_by(|a, b| a[3].total_cmp(&b[3]));
            let mut run = 0.0;
            let mut worst = 0.0f64;
            for t in &taps {
                // Half the tap's own weight: its footprint straddles its offset.
                let at = run + 0.5 * f64::from(t[0]);
                let x = f64::from(t[3]);
                if x.abs() <= 8.0 {
                    worst = worst.max((at - edge_response(&fit.profile, 0, x)).abs());
                }
                run += f64::from(t[0]);
            }
            worst
        };
        let projected = worst(&separable_kernel_projected(&fit.profile, &params, range).unwrap());
        let radial = worst(&separable_kernel_for(&fit.profile, &params, range).unwrap());
        eprintln!("edge error: projected {projected}, radial {radial}");
        assert!(
            projected < 0.03,
            "projected kernel's edge off by {projected}"
        );
        assert!(
            radial > 2.0 * projected,
            "radial {radial} vs projected {projected}"
        );
    }
}
