//! CPU reference of the texture-space (UV irradiance map) blur of d'Eon, Luebke and Enderton
//! 2007, as the renderer's GPU passes run it (`texture_space/blur.wgsl` in subsurface-render).
//!
//! # Conventions
//!
//! * Maps are square, `size` x `size` texels, row-major, row 0 first. A texel is covered (lies
//!   on a UV island) where its alpha exceeds 0.5.
//! * `stretch` holds, per texel, the profile millimetres one texel spans along u and along v.
//! * The profile's Gaussians are applied as separable 7-tap blurs ([`G7`], taps one standard
//!   deviation apart), each Gaussian made from the previous one by its variance increment
//!   ([`BlurKernel`]), converted from millimetres to texels through the stretch map (at most
//!   [`MAX_SIGMA_TEXELS`]).
//! * A tap filters the two texels around it linearly with clamp to edge (`t = p - 0.5`,
//!   `i0 = floor(t)`, `f = t - i0`), each texel replaced by the centre colour first when it is
//!   not covered, so the blur never pulls black in at seams and island borders.
//! * Every intermediate map is rounded to half floats ([`f16_round`]), as the GPU stores them
//!   in `Rgba16Float` targets.

use crate::gaussian::{GaussianTerm, SumOfGaussians};
use crate::kernel::GAUSSIAN7_WEIGHTS;

/// The 7-tap weights, one standard deviation apart.
pub const G7: [f32; 7] = GAUSSIAN7_WEIGHTS;
/// Largest standard deviation of one blur pass, in texels: a degenerate (zero-area) texel
/// would otherwise send its taps across the whole map.
pub const MAX_SIGMA_TEXELS: f32 = 256.0;

/// One Gaussian after the narrowest: its variance increment over the previous one (as a
/// standard deviation in profile millimetres) and its RGB weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlurStep {
    /// Standard deviation of the increment, profile millimetres.
    pub sigma_mm: f32,
    /// RGB weight of this Gaussian, normalised per channel with the others.
    pub weight: [f32; 3],
}

/// The sum of Gaussians as texture-space passes: the narrowest Gaussian is the irradiance
/// itself (its variance is under a texel on skin), each later one is the previous blurred by
/// `sigma_mm`.
#[derive(Clone, Debug, PartialEq)]
pub struct BlurKernel {
    /// RGB weight of the narrowest Gaussian: the unblurred irradiance.
    pub first_weight: [f32; 3],
    /// The later Gaussians, narrowest first.
    pub steps: Vec<BlurStep>,
}

impl BlurKernel {
    /// The profile's terms with weights normalised per channel.
    pub fn from_profile(profile: &SumOfGaussians) -> Self {
        let total = profile.total_weight();
        let w = |t: &GaussianTerm| {
            [0, 1, 2].map(|c| {
                if total[c] > 0.0 {
                    (t.weight[c] / total[c]) as f32
                } else {
                    0.0
                }
            })
        };
        let terms = profile.terms();
        let steps = terms
            .windows(2)
            .map(|p| BlurStep {
                sigma_mm: (p[1].variance - p[0].variance).max(0.0).sqrt() as f32,
                weight: w(&p[1]),
            })
            .collect();
        Self {
            first_weight: w(&terms[0]),
            steps,
        }
    }
}

/// `v` rounded to the nearest half float (ties to even; beyond the largest half, infinity),
/// as an `f32`: what a value stored in an `Rgba16Float` texture reads back as.
pub fn f16_round(v: f32) -> f32 {
    if !v.is_finite() {
        return v;
    }
    let a = v.abs();
    // Exponent of `a`, at least that of the smallest normal half (2^-14): below it the
    // quantum is the subnormal step 2^-24.
    let exponent = if a < f32::from_bits(113 << 23) {
        -14
    } else {
        ((a.to_bits() >> 23) & 0xff) as i32 - 127
    };
    // The half's quantum at that exponent (10 mantissa bits): a power of two, so the scaling
    // below is exact and only `round_ties_even` rounds.
    let quantum = f32::from_bits(((exponent - 10 + 127) as u32) << 23);
    let r = (a / quantum).round_ties_even() * quantum;
    let r = if r > 65504.0 { f32::INFINITY } else { r };
    r.copysign(v)
}

fn round4(c: [f32; 4]) -> [f32; 4] {
    c.map(f16_round)
}

/// One 1-D blur pass (`axis` 0 = u, 1 = v), the same arithmetic as `ts_blur` in the GPU
/// shader. Uncovered texels are copied.
pub fn cpu_pass(
    size: u32,
    src: &[[f32; 4]],
    stretch: &[[f32; 2]],
    axis: usize,
    sigma_mm: f32,
) -> Vec<[f32; 4]> {
    let n = size as i32;
    let at = |x: i32, y: i32| src[(y * n + x) as usize];
    let mut out = vec![[0.0; 4]; src.len()];
    for y in 0..n {
        for x in 0..n {
            let c = at(x, y);
            let i = (y * n + x) as usize;
            if c[3] <= 0.5 {
                out[i] = c;
                continue;
            }
            let centre = [c[0], c[1], c[2]];
            let mm = stretch[i][axis];
            let sigma = (sigma_mm / mm.max(1e-12)).min(MAX_SIGMA_TEXELS);
            let texel = |tx: i32, ty: i32| {
                let t = at(tx, ty);
                if t[3] > 0.5 {
                    [t[0], t[1], t[2]]
                } else {
                    centre
                }
            };
            let mut sum = centre.map(|v| v * G7[3]);
            for (j, w) in G7.iter().enumerate() {
                if j == 3 {
                    continue;
                }
                let off = (j as f32 - 3.0) * sigma;
                // Position along the axis in pixel coordinates (texel centres at +0.5).
                let (px, py) = if axis == 0 {
                    (x as f32 + 0.5 + off, y as f32 + 0.5)
                } else {
                    (x as f32 + 0.5, y as f32 + 0.5 + off)
                };
                let (tx, ty) = (px - 0.5, py - 0.5);
                let (fx0, fy0) = (tx.floor(), ty.floor());
                let (fx, fy) = (tx - fx0, ty - fy0);
                let (ax, ay) = ((fx0 as i32).clamp(0, n - 1), (fy0 as i32).clamp(0, n - 1));
                let (bx, by) = (
                    (fx0 as i32 + 1).clamp(0, n - 1),
                    (fy0 as i32 + 1).clamp(0, n - 1),
                );
                let mix =
                    |a: [f32; 3], b: [f32; 3], f: f32| [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * f);
                let mut top = texel(ax, ay);
                if fx > 0.0 {
                    top = mix(top, texel(bx, ay), fx);
                }
                if fy > 0.0 {
                    let mut bottom = texel(ax, by);
                    if fx > 0.0 {
                        bottom = mix(bottom, texel(bx, by), fx);
                    }
                    top = mix(top, bottom, fy);
                }
                for k in 0..3 {
                    sum[k] += w * top[k];
                }
            }
            out[i] = [sum[0], sum[1], sum[2], c[3]];
        }
    }
    out
}

/// The texture-space blur on the CPU, mirroring the GPU passes (including the `Rgba16Float`
/// rounding of every intermediate map). `irradiance` is row-major `size` x `size` RGBA (a
/// texel is covered where alpha exceeds 0.5), `stretch` profile mm per texel along u and v.
/// Returns the accumulated sum of Gaussians and the widest Gaussian alone, before padding.
pub fn cpu_blur(
    size: u32,
    irradiance: &[[f32; 4]],
    stretch: &[[f32; 2]],
    kernel: &BlurKernel,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let w0 = kernel.first_weight;
    let src: Vec<[f32; 4]> = irradiance.iter().map(|c| round4(*c)).collect();
    let mut accum: Vec<[f32; 4]> = src
        .iter()
        .map(|c| round4([c[0] * w0[0], c[1] * w0[1], c[2] * w0[2], c[3]]))
        .collect();
    let mut current = src;
    for step in &kernel.steps {
        let h: Vec<[f32; 4]> = cpu_pass(size, &current, stretch, 0, step.sigma_mm)
            .into_iter()
            .map(round4)
            .collect();
        let v: Vec<[f32; 4]> = cpu_pass(size, &h, stretch, 1, step.sigma_mm)
            .into_iter()
            .map(round4)
            .collect();
        for (a, b) in accum.iter_mut().zip(&v) {
            let w = step.weight;
            *a = round4([
                a[0] + b[0] * w[0],
                a[1] + b[1] * w[1],
                a[2] + b[2] * w[2],
                b[3],
            ]);
        }
        current = v;
    }
    (accum, current)
}

/// Padding of UV islands on the CPU, as `fs_ts_dilate`: empty texels within `radius` take
/// the mean of the covered texels on the nearest square ring (alpha 0.5).
pub fn cpu_dilate(size: u32, map: &[[f32; 4]], radius: u32) -> Vec<[f32; 4]> {
    let n = size as i32;
    let mut out = map.to_vec();
    for y in 0..n {
        for x in 0..n {
            let i = (y * n + x) as usize;
            if map[i][3] > 0.5 {
                continue;
            }
            'rings: for r in 1..=radius as i32 {
                let (mut sum, mut count) = ([0.0f32; 3], 0.0f32);
                for dy in -r..=r {
                    for dx in -r..=r {
                        if dx.abs().max(dy.abs()) != r {
                            continue;
                        }
                        let (qx, qy) = (x + dx, y + dy);
                        if qx < 0 || qy < 0 || qx >= n || qy >= n {
                            continue;
                        }
                        let q = map[(qy * n + qx) as usize];
                        if q[3] > 0.5 {
                            for k in 0..3 {
                                sum[k] += q[k];
                            }
                            count += 1.0;
                        }
                    }
                }
                if count > 0.0 {
                    out[i] = [sum[0] / count, sum[1] / count, sum[2] / count, 0.5];
                    break 'rings;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_from_skin_matches_the_screen_space_increments() {
        let k = BlurKernel::from_profile(&SumOfGaussians::skin());
        assert_eq!(k.steps.len(), 5);
        let v = crate::SKIN_VARIANCES_MM2;
        assert!((k.steps[0].sigma_mm - ((v[1] - v[0]).sqrt() as f32)).abs() < 1e-6);
        for c in 0..3 {
            let sum: f32 = k.first_weight[c] + k.steps.iter().map(|s| s.weight[c]).sum::<f32>();
            assert!((sum - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn cpu_blur_keeps_a_constant_island_constant() {
        let size = 16;
        let mut map = vec![[0.0f32; 4]; 256];
        for y in 4..12 {
            for x in 2..14 {
                map[y * 16 + x] = [0.5, 0.25, 0.125, 1.0];
            }
        }
        let stretch = vec![[0.3f32, 0.2]; 256];
        let (acc, _) = cpu_blur(
            size,
            &map,
            &stretch,
            &BlurKernel::from_profile(&SumOfGaussians::skin()),
        );
        for (a, m) in acc.iter().zip(&map) {
            if m[3] > 0.5 {
                for c in 0..3 {
                    assert!((a[c] - m[c]).abs() < 2e-3, "{a:?} vs {m:?}");
                }
            }
        }
    }

    #[test]
    fn cpu_dilate_pads_with_the_nearest_ring() {
        // One covered texel in the middle of a 5x5 map: every other texel is within 2 rings.
        let mut map = vec![[0.0f32; 4]; 25];
        map[12] = [1.0, 2.0, 3.0, 1.0];
        let out = cpu_dilate(5, &map, 1);
        assert_eq!(out[12], map[12]);
        assert_eq!(out[6], [1.0, 2.0, 3.0, 0.5]);
        assert_eq!(out[0], [0.0; 4], "two rings away, beyond the radius");
        assert_eq!(cpu_dilate(5, &map, 2)[0], [1.0, 2.0, 3.0, 0.5]);
    }

    #[test]
    fn f16_round_matches_half_floats() {
        // Exactly representable halves stay; the rest round to the nearest, ties to even.
        for v in [0.0f32, 1.0, -2.5, 65504.0, 6.103_515_6e-5, 5.960_464_5e-8] {
            assert_eq!(f16_round(v), v);
        }
        assert_eq!(
            f16_round(1.0 + 1.0 / 4096.0),
            1.0,
            "half a quantum, tie to even"
        );
        assert_eq!(
            f16_round(1.0 + 3.0 / 2048.0),
            1.0 + 2.0 / 1024.0,
            "tie to even, up"
        );
        assert_eq!(f16_round(0.1), 0.099_975_586);
        assert_eq!(f16_round(2.0e-8), 0.0);
        assert_eq!(
            f16_round(4.0e-8),
            5.960_464_5e-8,
            "rounds up to the least subnormal"
        );
        assert_eq!(f16_round(65519.0), 65504.0);
        assert_eq!(f16_round(65520.0), f32::INFINITY);
        assert_eq!(f16_round(-1.0e6), f32::NEG_INFINITY);
        assert!(f16_round(f32::NAN).is_nan());
        assert!(f16_round(-0.0).is_sign_negative());
    }
}
