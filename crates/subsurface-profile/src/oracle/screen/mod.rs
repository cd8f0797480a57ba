//! CPU reference ("oracle") implementations of the screen-space SSS passes. The
//! GPU shaders are written to match these; GPU tests compare against them.
//!
//! # Conventions shared by every pass
//!
//! * Images are row-major, row 0 at the top, `width * height` texels. The centre
//!   of pixel `(x, y)` is `c = (x + 0.5, y + 0.5)` in pixel units; pixel-space
//!   positions `p` below use the same convention (`+y` points down the image).
//! * A pixel with `strength == 0` is copied bit for bit.
//! * Each pixel names its profile (`profile`, an index into the table of
//!   [`ScreenKernels`] every pass takes) and is blurred with that profile's kernel.
//! * At a blurred pixel: `colorM` = the pass input's colour there, `dM` = depth,
//!   `m` = strength, `wpm` = world units per profile millimetre, and
//!   `px_per_mm = wpm * focal_px / dM * m`. Dividing by depth keeps the blur a
//!   fixed size on the skin (perspective); the factor `m` shrinks the footprint
//!   with the SSS strength, as `colorM.a` does in Jimenez's shader (003_*).
//! * A tap at `p` filters the four texels around it bilinearly with clamp to
//!   edge (`t = p - 0.5`, `i0 = floor(t)`, `f = t - i0`, indices clamped to
//!   `0..size`), but each texel is corrected *before* filtering (the
//!   `lerp(color, colorM, s)` of 003_*'s `BlurPS`, per texel): `s = 1` if the
//!   texel's strength is 0 (no background colour bleeds in); else
//!   `s = min(|dM - depth_texel| / (edge_mm * wpm), 1)` with `follow_surface`,
//!   else `s = 0`; `texel = texel + (colorM - texel) * s`. A texel of another
//!   profile counts as not skin (`s = 1`): no kernel mixes two materials. Texels of zero weight
//!   are skipped. 003_* filters colour but point-samples depth, which lets up to
//!   half of a texel across an edge leak into a tap; correcting per texel leaks
//!   nothing. [`sample_bilinear`] and [`nearest_index`] remain as helpers.
//! * Sums run in the order documented per pass, in f32.

use crate::error::{ProfileError, Result, finite, in_range, positive};
use crate::kernel::{GAUSSIAN7_OFFSETS_SIGMA, GAUSSIAN7_WEIGHTS, ScreenKernels};

/// G-buffer data the passes read.
#[derive(Debug, Clone, PartialEq)]
pub struct ScreenInput {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear HDR diffuse radiance.
    pub color: Vec<[f32; 3]>,
    /// Linear view depth in scene units (> 0 where `strength > 0`).
    pub depth: Vec<f32>,
    /// SSS strength in 0..=1; 0 marks non-skin pixels.
    pub strength: Vec<f32>,
    /// Scene units per profile millimetre (> 0 where `strength > 0`).
    pub world_per_mm: Vec<f32>,
    /// Index of each pixel's profile in the kernel table.
    pub profile: Vec<u32>,
}

/// Camera and correction settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenParams {
    /// `0.5 * height_px / tan(fov_y / 2)`.
    pub focal_px: f32,
    /// Depth-edge correction on/off.
    pub follow_surface: bool,
    /// Depth difference, in profile mm, at which a tap is fully replaced by the
    /// centre colour.
    pub edge_mm: f32,
}

impl ScreenInput {
    /// A uniform image: every pixel the same colour, depth, strength and scale.
    pub fn uniform(
        width: u32,
        height: u32,
        color: [f32; 3],
        depth: f32,
        strength: f32,
        world_per_mm: f32,
    ) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            color: vec![color; n],
            depth: vec![depth; n],
            strength: vec![strength; n],
            world_per_mm: vec![world_per_mm; n],
            profile: vec![0; n],
        }
    }

    /// Checks sizes, and that strength is in 0..=1 everywhere and depth and
    /// `world_per_mm` are finite and > 0 wherever strength > 0.
    pub fn validate(&self) -> Result<()> {
        positive("width", self.width as f64)?;
        positive("height", self.height as f64)?;
        let n = self.width as usize * self.height as usize;
        for (field, len) in [
            ("color", self.color.len()),
            ("depth", self.depth.len()),
            ("strength", self.strength.len()),
            ("world_per_mm", self.world_per_mm.len()),
            ("profile", self.profile.len()),
        ] {
            if len != n {
                return Err(ProfileError::Length {
                    field: field.into(),
                    expected: n,
                    got: len,
                });
            }
        }
        for i in 0..n {
            let (m, d, s) = (self.strength[i], self.depth[i], self.world_per_mm[i]);
            // Field names are only formatted on failure: this runs per pixel.
            if !(0.0..=1.0).contains(&m) {
                in_range(&format!("strength[{i}]"), m as f64, 0.0, 1.0)?;
            }
            if m > 0.0 && !(d > 0.0 && d.is_finite() && s > 0.0 && s.is_finite()) {
                positive(&format!("depth[{i}]"), d as f64)?;
                positive(&format!("world_per_mm[{i}]"), s as f64)?;
            }
        }
        Ok(())
    }
}

/// Every pixel's profile must name a row of `kernels`, and every row must have the same
/// number of separable taps (one `samples` setting per frame).
fn check_table(input: &ScreenInput, kernels: &[ScreenKernels]) -> Result<()> {
    if kernels.is_empty() {
        return Err(ProfileError::Invalid {
            field: "kernels".into(),
            reason: "the profile table is empty".into(),
        });
    }
    for k in kernels {
        check_kernel(&k.separable)?;
        if k.separable.len() != kernels[0].separable.len() {
            return Err(ProfileError::Invalid {
                field: "kernels".into(),
                reason: "every profile needs the same number of separable taps".into(),
            });
        }
    }
    if let Some((i, p)) = input
        .profile
        .iter()
        .enumerate()
        .find(|(_, p)| **p as usize >= kernels.len())
    {
        return Err(ProfileError::Invalid {
            field: format!("profile[{i}]"),
            reason: format!("{p} is not below the table size {}", kernels.len()),
        });
    }
    Ok(())
}

/// The checks every pass starts with: the input, the parameters and the profile table.
fn check_inputs(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    params: &ScreenParams,
) -> Result<()> {
    input.validate()?;
    params.validate()?;
    check_table(input, kernels)
}

impl ScreenParams {
    /// `focal_px` and `edge_mm` must be finite and > 0.
    pub fn validate(&self) -> Result<()> {
        positive("focal_px", self.focal_px as f64)?;
        positive("edge_mm", self.edge_mm as f64)?;
        Ok(())
    }
}

/// Bilinear clamp-to-edge sample of `img` (`width x height`) at pixel-space `p`.
pub fn sample_bilinear(img: &[[f32; 3]], width: u32, height: u32, p: [f32; 2]) -> [f32; 3] {
    let (w, h) = (width as i64, height as i64);
    let (tx, ty) = (p[0] - 0.5, p[1] - 0.5);
    let (fx0, fy0) = (tx.floor(), ty.floor());
    let (fx, fy) = (tx - fx0, ty - fy0);
    // `as i64` saturates (NaN -> 0), so no input can index out of bounds.
    let (x0, y0) = (fx0 as i64, fy0 as i64);
    let cx = |x: i64| x.clamp(0, w - 1) as usize;
    let cy = |y: i64| y.clamp(0, h - 1) as usize;
    let at = |x: i64, y: i64| img[cy(y) * width as usize + cx(x)];
    let (c00, c10, c01, c11) = (
        at(x0, y0),
        at(x0 + 1, y0),
        at(x0, y0 + 1),
        at(x0 + 1, y0 + 1),
    );
    [0, 1, 2].map(|k| {
        let top = c00[k] + (c10[k] - c00[k]) * fx;
        let bottom = c01[k] + (c11[k] - c01[k]) * fx;
        top + (bottom - top) * fy
    })
}

/// Index of the texel a NEAREST sampler reads at pixel-space `p`:
/// `clamp(floor(p), 0, size - 1)` per axis.
pub fn nearest_index(width: u32, height: u32, p: [f32; 2]) -> usize {
    let x = (p[0].floor() as i64).clamp(0, width as i64 - 1) as usize;
    let y = (p[1].floor() as i64).clamp(0, height as i64 - 1) as usize;
    y * width as usize + x
}

/// Per-pixel values every tap needs.
struct Centre {
    p: [f32; 2],
    color: [f32; 3],
    depth: f32,
    wpm: f32,
    px_per_mm: f32,
    profile: u32,
}

impl Centre {
    fn new(input: &ScreenInput, color: &[[f32; 3]], params: &ScreenParams, i: usize) -> Self {
        let w = input.width as usize;
        let (x, y) = (i % w, i / w);
        let (depth, wpm) = (input.depth[i], input.world_per_mm[i]);
        Self {
            p: [x as f32 + 0.5, y as f32 + 0.5],
            color: color[i],
            depth,
            wpm,
            px_per_mm: wpm * params.focal_px / depth * input.strength[i],
            profile: input.profile[i],
        }
    }

    /// One texel's colour as a tap sees it: pulled back to the centre colour if
    /// the texel is not skin, or (follow-surface) by its depth difference.
    fn corrected(
        &self,
        input: &ScreenInput,
        color: &[[f32; 3]],
        params: &ScreenParams,
        j: usize,
    ) -> [f32; 3] {
        let c = color[j];
        let s = if input.strength[j] == 0.0 || input.profile[j] != self.profile {
            1.0
        } else if params.follow_surface {
            ((self.depth - input.depth[j]).abs() / (params.edge_mm * self.wpm)).min(1.0)
        } else {
            0.0
        };
        [0, 1, 2].map(|k| c[k] + (self.color[k] - c[k]) * s)
    }

    /// The tap at `self.p + offset_px`: bilinear (clamp to edge) filtering of the
    /// four texels around it, each [`Self::corrected`] first, so no fraction of a
    /// background texel leaks into a skin tap. Texels of zero weight are skipped,
    /// as the GPU does.
    fn tap(
        &self,
        input: &ScreenInput,
        color: &[[f32; 3]],
        params: &ScreenParams,
        offset_px: [f32; 2],
    ) -> [f32; 3] {
        let (w, h) = (input.width as i64, input.height as i64);
        let (tx, ty) = (
            self.p[0] + offset_px[0] - 0.5,
            self.p[1] + offset_px[1] - 0.5,
        );
        let (fx0, fy0) = (tx.floor(), ty.floor());
        let (fx, fy) = (tx - fx0, ty - fy0);
        // `as i64` saturates (NaN -> 0), so no input can index out of bounds.
        let (x0, y0) = (fx0 as i64, fy0 as i64);
        let at = |x: i64, y: i64| (y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize;
        let get = |x, y| self.corrected(input, color, params, at(x, y));
        let lerp = |a: [f32; 3], b: [f32; 3], t: f32| [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t);
        let mut top = get(x0, y0);
        if fx > 0.0 {
            top = lerp(top, get(x0 + 1, y0), fx);
        }
        if fy > 0.0 {
            let mut bottom = get(x0, y0 + 1);
            if fx > 0.0 {
                bottom = lerp(bottom, get(x0 + 1, y0 + 1), fx);
            }
            top = lerp(top, bottom, fy);
        }
        top
    }
}

fn accumulate(acc: &mut [f32; 3], w: [f32; 3], c: [f32; 3]) {
    for k in 0..3 {
        acc[k] += w[k] * c[k];
    }
}

fn check_kernel(kernel: &[[f32; 4]]) -> Result<()> {
    if kernel.is_empty() {
        return Err(ProfileError::Invalid {
            field: "kernel".into(),
            reason: "must have at least one tap".into(),
        });
    }
    for (i, t) in kernel.iter().enumerate() {
        for (k, &v) in t.iter().enumerate() {
            finite(&format!("kernel[{i}][{k}]"), v as f64)?;
        }
    }
    Ok(())
}

/// One 1-D pass of the Separable SSS (2015) blur along `dir` over `color`.
fn separable_pass_on(
    input: &ScreenInput,
    color: &[[f32; 3]],
    kernels: &[ScreenKernels],
    dir: [f32; 2],
    params: &ScreenParams,
) -> Vec<[f32; 3]> {
    blur_with_taps(
        input,
        color,
        kernels,
        params,
        |k| &k.separable,
        |t| [t[0], t[1], t[2]],
        |t, px_per_mm| {
            let d = t[3] * px_per_mm;
            [dir[0] * d, dir[1] * d]
        },
    )
}

/// The blur every tap-table method shares: pixels without SSS keep their colour; each other
/// pixel sums `weight(kernel[0]) * colorM` and, in kernel order, `weight(t) * tap(c +
/// offset_px(t, px_per_mm))` for the rest of its profile's `kernel`.
fn blur_with_taps<const N: usize>(
    input: &ScreenInput,
    color: &[[f32; 3]],
    kernels: &[ScreenKernels],
    params: &ScreenParams,
    kernel: impl Fn(&ScreenKernels) -> &[[f32; N]],
    weight: impl Fn(&[f32; N]) -> [f32; 3],
    offset_px: impl Fn(&[f32; N], f32) -> [f32; 2],
) -> Vec<[f32; 3]> {
    each_skin_pixel(input, color, params, |c| {
        let kernel = kernel(&kernels[c.profile as usize]);
        let mut acc = [0.0; 3];
        accumulate(&mut acc, weight(&kernel[0]), c.color);
        for t in &kernel[1..] {
            let tap = c.tap(input, color, params, offset_px(t, c.px_per_mm));
            accumulate(&mut acc, weight(t), tap);
        }
        acc
    })
}

/// `color` with each pixel that has SSS (strength > 0) replaced by `blur` of its centre.
fn each_skin_pixel(
    input: &ScreenInput,
    color: &[[f32; 3]],
    params: &ScreenParams,
    blur: impl Fn(&Centre) -> [f32; 3],
) -> Vec<[f32; 3]> {
    (0..color.len())
        .map(|i| {
            if input.strength[i] == 0.0 {
                return color[i];
            }
            blur(&Centre::new(input, color, params, i))
        })
        .collect()
}

/// One 1-D pass of the Separable SSS blur of `input.color` along `dir`.
///
/// Each pixel's kernel is `kernels[profile].separable`, `[r, g, b, offset_mm]` with the
/// centre tap first (as [`crate::separable_kernel`] returns it). Per pixel:
/// `out = kernel[0].rgb * colorM + sum_{i >= 1} kernel[i].rgb * tap(c + dir * kernel[i].offset * px_per_mm)`,
/// summed in kernel order. `kernel[0]`'s offset is ignored.
pub fn separable_pass(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    dir: [f32; 2],
    params: &ScreenParams,
) -> Result<Vec<[f32; 3]>> {
    check_inputs(input, kernels, params)?;
    finite("dir.x", dir[0] as f64)?;
    finite("dir.y", dir[1] as f64)?;
    Ok(separable_pass_on(input, &input.color, kernels, dir, params))
}

/// The full separable blur: the horizontal pass (`dir = (1, 0)`) of
/// `input.color`, then the vertical pass (`dir = (0, 1)`) of that result, with
/// depth, strength, `world_per_mm` and profiles unchanged.
pub fn separable(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    params: &ScreenParams,
) -> Result<Vec<[f32; 3]>> {
    let dirs = [[1.0, 0.0], [0.0, 1.0]];
    two_passes(input, kernels, params, |color, pass| {
        separable_pass_on(input, color, kernels, dirs[pass as usize], params)
    })
}

/// The inputs checked, then `pass(color, 0)` (horizontal) of `input.color` and `pass(color,
/// 1)` (vertical) of its result.
fn two_passes(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    params: &ScreenParams,
    pass: impl Fn(&[[f32; 3]], u32) -> Vec<[f32; 3]>,
) -> Result<Vec<[f32; 3]>> {
    check_inputs(input, kernels, params)?;
    Ok(pass(&pass(&input.color, 0), 1))
}

/// PCG's output hash (Jarzynski and Olano 2020, "Hash Functions for GPU Rendering"): integer
/// arithmetic only, so the shader draws exactly the numbers the oracle draws.
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The hash of pixel `(x, y)` in pass `pass` (0 = horizontal, 1 = vertical):
/// `pcg(x + pcg(y + pcg(pass)))`, drawn once per pixel and pass.
pub fn jitter_seed(x: u32, y: u32, pass: u32) -> u32 {
    pcg_hash(x.wrapping_add(pcg_hash(y.wrapping_add(pcg_hash(pass)))))
}

/// The jitter of tap `tap` at a pixel of hash `seed` ([`jitter_seed`]), in [0, 1): the top
/// 24 bits of `pcg(seed + tap)` (exact in f32). Every pixel, pass and tap draws its own
/// number, so the error of few taps becomes per-pixel noise (high frequency, which a later
/// temporal or spatial filter removes and the eye forgives) instead of the ghost copies of
/// features that fixed tap positions leave.
pub fn jitter_value(seed: u32, tap: u32) -> f32 {
    (pcg_hash(seed.wrapping_add(tap)) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// One jittered 1-D pass (`pass` 0 = horizontal, 1 = vertical) over `color`.
fn separable_jittered_pass_on(
    input: &ScreenInput,
    color: &[[f32; 3]],
    kernels: &[ScreenKernels],
    pass: u32,
    params: &ScreenParams,
) -> Vec<[f32; 3]> {
    let dir = if pass == 0 { [1.0, 0.0] } else { [0.0, 1.0] };
    let widths: Vec<Vec<f32>> = kernels
        .iter()
        .map(|k| crate::kernel::separable_jitter_widths(&k.separable))
        .collect();
    each_skin_pixel(input, color, params, |c| {
        let kernel = &kernels[c.profile as usize].separable;
        let widths = &widths[c.profile as usize];
        let seed = jitter_seed(c.p[0] as u32, c.p[1] as u32, pass);
        let mut acc = [0.0; 3];
        accumulate(
            &mut acc,
            [kernel[0][0], kernel[0][1], kernel[0][2]],
            c.color,
        );
        let n = kernel.len();
        for (i, t) in kernel.iter().enumerate().skip(1) {
            let xi = jitter_value(seed, i.min(n - i) as u32);
            let outward = if t[3] >= 0.0 { 1.0 } else { -1.0 };
            let d = (t[3] + outward * (2.0 * xi - 1.0) * widths[i]) * c.px_per_mm;
            let tap = c.tap(input, color, params, [dir[0] * d, dir[1] * d]);
            accumulate(&mut acc, [t[0], t[1], t[2]], tap);
        }
        acc
    })
}

/// Separable SSS's few-sample mode (Jimenez et al. 2015 reach seven samples by jittering):
/// [`separable`] with each tap `i >= 1` moved, per pixel and pass, to
/// `offset_i + sign(offset_i) (2 xi - 1) width_i` mm, `xi` = [`jitter_value`]`([`jitter_seed`]`(x, y, pass),
/// min(i, N - i))` and `width_i` = [`crate::separable_jitter_widths`] of the pixel's profile.
/// The two taps at `+o` and `-o` (kernel rows `i` and `N - i`) draw the same number and move
/// outward or inward together, a random scale of that pair: on a linear gradient their errors
/// cancel, so the noise is of the image's curvature only. The weights are unchanged, so every
/// channel still sums to 1: a flat surface keeps its energy exactly, and over the jitter the
/// expected kernel spreads each tap's weight over the interval it stands for.
pub fn separable_jittered(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    params: &ScreenParams,
) -> Result<Vec<[f32; 3]>> {
    two_passes(input, kernels, params, |color, pass| {
        separable_jittered_pass_on(input, color, kernels, pass, params)
    })
}

/// One 7-tap Gaussian pass of standard deviation `sigma_mm` along `dir`.
fn gauss7_pass(
    input: &ScreenInput,
    color: &[[f32; 3]],
    sigma_mm: &dyn Fn(u32) -> f32,
    dir: [f32; 2],
    params: &ScreenParams,
    min_sigma_px: f32,
) -> Vec<[f32; 3]> {
    each_skin_pixel(input, color, params, |c| {
        let sigma_px = sigma_mm(c.profile) * c.px_per_mm;
        if sigma_px < min_sigma_px {
            return c.color;
        }
        let mut acc = [0.0; 3];
        accumulate(&mut acc, [GAUSSIAN7_WEIGHTS[3]; 3], c.color);
        for j in [0, 1, 2, 4, 5, 6] {
            let d = GAUSSIAN7_OFFSETS_SIGMA[j] * sigma_px;
            let tap = c.tap(input, color, params, [dir[0] * d, dir[1] * d]);
            accumulate(&mut acc, [GAUSSIAN7_WEIGHTS[j]; 3], tap);
        }
        acc
    })
}

/// The sum-of-Gaussians blur of Jimenez et al. 2009 / GPU Pro (003_*).
///
/// Each pixel's profile row `kernels[profile].gaussians` holds six Gaussians
/// `[r, g, b, variance]` by increasing variance, weights summing to 1 per channel.
/// `blurred_0 = input.color`; for each `k` in `1..6` whose switch `enabled[k - 1]` is on,
/// `blurred_k = V(H(blurred_prev))` with `sigma_mm = sqrt(v_k - v_prev)`, `prev` the last
/// Gaussian computed (d'Eon's incremental convolution: each Gaussian is the previous one
/// blurred further; switching one off leaves the others at their true width). A 1-D pass
/// H (`dir (1,0)`) or V (`dir (0,1)`) is
/// `0.382 * colorM + sum_{j = -3..=3, j != 0} w_j * tap(c + dir * j * sigma_px)`,
/// `w` = [`GAUSSIAN7_WEIGHTS`], `sigma_px = sigma_mm * px_per_mm` of the centre's profile,
/// summed for `j = -3, -2, -1, 1, 2, 3` after the centre; where `sigma_px < min_sigma_px`
/// the pass copies its input pixel (GPU Pro's removal of sub-pixel Gaussians).
/// Result: `w_0 * blurred_0 + sum_k w_k * blurred_k` per channel over the computed `k`, in
/// that order, with each pixel's own weights; pixels with strength 0 keep the input colour.
pub fn gaussian6(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    enabled: [bool; 5],
    params: &ScreenParams,
    min_sigma_px: f32,
) -> Result<Vec<[f32; 3]>> {
    check_inputs(input, kernels, params)?;
    finite("min_sigma_px", min_sigma_px as f64)?;
    let row = |i: usize, k: usize| kernels[input.profile[i] as usize].gaussians[k];
    let mut blurred = input.color.clone();
    let mut out: Vec<[f32; 3]> = vec![[0.0; 3]; blurred.len()];
    for (i, (o, &b)) in out.iter_mut().zip(&blurred).enumerate() {
        let w = row(i, 0);
        accumulate(o, [w[0], w[1], w[2]], b);
    }

    let mut previous = 0;
    for k in (1..6).filter(|&k| enabled[k - 1]) {
        let prev = previous;
        let sigma = move |p: u32| {
            let g = &kernels[p as usize].gaussians;
            (g[k][3] - g[prev][3]).max(0.0).sqrt()
        };
        let h = gauss7_pass(input, &blurred, &sigma, [1.0, 0.0], params, min_sigma_px);
        blurred = gauss7_pass(input, &h, &sigma, [0.0, 1.0], params, min_sigma_px);
        for (i, (o, &b)) in out.iter_mut().zip(&blurred).enumerate() {
            let w = row(i, k);
            accumulate(o, [w[0], w[1], w[2]], b);
        }

        previous = k;
    }
    for (i, o) in out.iter_mut().enumerate() {
        if input.strength[i] == 0.0 {
            *o = input.color[i];
        }
    }
    Ok(out)
}

/// Hable et al. 2009's single 2-D pass with the 13 jittered taps of 001_*,
/// Table 1, whose positions are in mm on the skin and whose weights are
/// normalised per channel ([`crate::kernel::hable13_kernel`]; the raw table sums to 0.9977,
/// 1.0494, 0.9996). `out = w_0 * colorM + sum_{i = 1..13} w_i * tap(c + (X_i, Y_i) * px_per_mm)`,
/// in table order, with `+Y` down the image. Each pixel uses its profile's row
/// `kernels[profile].hable13` (for skin, that table itself).
pub fn hable13(
    input: &ScreenInput,
    kernels: &[ScreenKernels],
    params: &ScreenParams,
) -> Result<Vec<[f32; 3]>> {
    check_inputs(input, kernels, params)?;
    Ok(blur_with_taps(
        input,
        &input.color,
        kernels,
        params,
        |k| &k.hable13,
        |t| [t[2], t[3], t[4]],
        |t, px_per_mm| [t[0] * px_per_mm, t[1] * px_per_mm],
    ))
}

#[cfg(test)]
mod tests;
