//! `subsurface compare`: a real-time render against a path-traced reference of the same scene.
//!
//! Errors reported (docs/fidelity.md):
//! - RMSE of linear radiance (diffuse + specular, before exposure and tone mapping) over the
//!   whole image, and relative to the reference's mean radiance;
//! - relative error of region means (luminance) over the skin pixels and the named regions of
//!   a sidecar `SCENE.regions.json` (ears, finger edges, ...);
//! - FLIP (Andersson et al. 2020, LDR) on both images tone-mapped with our own tone map.
//!
//! The command also writes a side-by-side PNG: real-time | reference | FLIP error (black =
//! none, white = 1).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use serde::{Deserialize, Serialize};
use subsurface_render::{GpuContext, RenderOptions, Renderer};

use crate::output::{PendingFile, is_stdout, print_summary};
use crate::settings_args::{SettingsArgs, load_scene};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Path-traced reference: a linear-radiance EXR of the scene (tools/reference/).
    pub reference: PathBuf,
    /// Scene file (TOML). Without it, the embedded default scene. Rendered at the scene's size,
    /// which must be the reference's.
    pub scene: Option<PathBuf>,
    /// Side-by-side image: real-time | reference | FLIP error.
    #[arg(long, short, default_value = "compare.png", value_name = "FILE.png")]
    pub out: PathBuf,
    /// Named regions (JSON, see docs/fidelity.md) [default: SCENE.regions.json beside the
    /// scene, if present].
    #[arg(long, value_name = "FILE.json")]
    pub regions: Option<PathBuf>,
    /// Print the results as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// The settings to render with (--exposure-ev also sets the exposure of the tone-mapped
    /// images that FLIP and the side-by-side image compare).
    #[command(flatten)]
    pub settings: SettingsArgs,
}

/// A named rectangle in normalised image coordinates (0..1, origin top left); its pixels are
/// those of the rectangle that are skin in our render.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    pub name: String,
    /// [x0, y0, x1, y1]
    pub rect: [f32; 4],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionsFile {
    regions: Vec<Region>,
}

#[derive(Debug, Serialize)]
pub struct RegionResult {
    pub name: String,
    pub pixels: usize,
    pub mean_realtime: [f32; 3],
    pub mean_reference: [f32; 3],
    /// (Y_realtime - Y_reference) / Y_reference of the region means' luminance.
    pub rel_error: f32,
    /// Standard error of `rel_error` from the reference's own noise (its `.stderr.exr`; the
    /// channels are taken as fully correlated, so this errs on the large side). None without
    /// a standard-error image.
    pub rel_stderr: Option<f32>,
}

#[derive(Debug, Serialize)]
pub struct Report {
    pub reference: String,
    pub scene: String,
    pub sss: serde_json::Value,
    pub transmittance: serde_json::Value,
    pub width: u32,
    pub height: u32,
    /// Linear radiance, all pixels and channels.
    pub rmse: f32,
    /// `rmse` / mean reference radiance.
    pub rel_rmse: f32,
    /// RMS of the reference's per-pixel standard error: the part of `rmse` that is the path
    /// tracer's noise. None without a standard-error image.
    pub noise_rms: Option<f32>,
    /// RMSE against the noise-free image, estimated: E[(ours - ref)^2] = (ours - truth)^2 +
    /// var(ref), so sqrt(max(0, rmse^2 - noise_rms^2)). Separates methods that `rmse` cannot
    /// when the reference is noisy.
    pub rmse_debiased: Option<f32>,
    /// `rmse_debiased` / mean reference radiance.
    pub rel_rmse_debiased: Option<f32>,
    pub flip_mean: f32,
    pub regions: Vec<RegionResult>,
    /// Largest difference (1/255 steps) between our CPU tone map and the GPU's frame: checks
    /// that FLIP sees what `subsurface render` writes.
    pub tonemap_check_max_diff: u8,
    pub out: String,
}

// ---------------------------------------------------------------- tone map (CPU)

/// Hable's filmic curve as in `passes/tonemap.wgsl`.
fn hable(x: f32) -> f32 {
    let (a, b, c, d, e, f) = (0.15, 0.50, 0.10, 0.20, 0.02, 0.30);
    ((x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f)) - e / f
}

fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Exposure, Hable filmic (white 11.2, exposure bias 2) and the sRGB encode of the output
/// target: the same 8-bit image `subsurface render` writes.
pub fn tone_map(linear: &[[f32; 3]], exposure_ev: f32, w: u32, h: u32) -> image::RgbImage {
    let k = exposure_ev.exp2();
    let white = hable(11.2);
    let px: Vec<u8> = linear
        .iter()
        .flat_map(|c| {
            c.map(|v| {
                let m = (hable(2.0 * v.max(0.0) * k) / white).clamp(0.0, 1.0);
                (srgb_encode(m) * 255.0).round() as u8
            })
        })
        .collect();
    image::RgbImage::from_raw(w, h, px).expect("w * h pixels")
}

// ---------------------------------------------------------------- FLIP (LDR)

/// LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"),
/// following NVIDIA's reference implementation: CSF-filtered YCxCz colour difference
/// (Hunt-adjusted HyAB), edge and point feature differences, default 67.02 pixels per degree.
/// Implemented here (the nv-flip crate is only a dev-dependency); tests/fidelity.rs checks it
/// against nv-flip.
pub mod flip {
    const QC: f32 = 0.7;
    const QF: f32 = 0.5;
    const PC: f32 = 0.4;
    const PT: f32 = 0.95;
    const GW: f32 = 0.082;
    pub const PPD: f32 = 67.02;

    const RGB2XYZ: [[f32; 3]; 3] = [
        [0.412_390_8, 0.357_584_33, 0.180_480_8],
        [0.212_639, 0.715_168_65, 0.072_192_32],
        [0.019_330_818, 0.119_194_78, 0.950_532_15],
    ];
    const XYZ2RGB: [[f32; 3]; 3] = [
        [3.240_97, -1.537_383_2, -0.498_610_76],
        [-0.969_243_6, 1.875_967_5, 0.041_555_06],
        [0.055_630_08, -0.203_976_96, 1.056_971_5],
    ];

    fn mul(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
    }

    fn white() -> [f32; 3] {
        mul(&RGB2XYZ, [1.0; 3])
    }

    fn srgb_to_linear(c: f32) -> f32 {
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    }

    fn xyz_to_ycxcz(x: [f32; 3]) -> [f32; 3] {
        let w = white();
        let (xx, yy, zz) = (x[0] / w[0], x[1] / w[1], x[2] / w[2]);
        [116.0 * yy - 16.0, 500.0 * (xx - yy), 200.0 * (yy - zz)]
    }

    fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
        let w = white();
        let yy = (c[0] + 16.0) / 116.0;
        [
            (c[1] / 500.0 + yy) * w[0],
            yy * w[1],
            (yy - c[2] / 200.0) * w[2],
        ]
    }

    fn xyz_to_lab(x: [f32; 3]) -> [f32; 3] {
        let w = white();
        let d = 6.0f32 / 29.0;
        let f = |t: f32| {
            if t > d * d * d {
                t.cbrt()
            } else {
                t / (3.0 * d * d) + 4.0 / 29.0
            }
        };
        let (fx, fy, fz) = (f(x[0] / w[0]), f(x[1] / w[1]), f(x[2] / w[2]));
        [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
    }

    fn hunt(lab: [f32; 3]) -> [f32; 3] {
        [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
    }

    fn hyab(a: [f32; 3], b: [f32; 3]) -> f32 {
        (a[0] - b[0]).abs() + ((a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    /// Separable convolution of one channel with clamped borders.
    fn convolve(src: &[f32], w: usize, h: usize, kx: &[f32], ky: &[f32]) -> Vec<f32> {
        let (rx, ry) = (kx.len() / 2, ky.len() / 2);
        let rows = convolve_1d(src, w, h, kx, |x, y, i| {
            y * w + (x + i).saturating_sub(rx).min(w - 1)
        });
        convolve_1d(&rows, w, h, ky, |x, y, i| {
            (y + i).saturating_sub(ry).min(h - 1) * w + x
        })
    }

    /// One pass of [`convolve`]: pixel (x, y) is the sum of `k[i] * src[tap(x, y, i)]`.
    fn convolve_1d(
        src: &[f32],
        w: usize,
        h: usize,
        k: &[f32],
        tap: impl Fn(usize, usize, usize) -> usize,
    ) -> Vec<f32> {
        let mut out = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for (i, k) in k.iter().enumerate() {
                    s += k * src[tap(x, y, i)];
                }
                out[y * w + x] = s;
            }
        }
        out
    }

    /// The contrast sensitivity functions as sums of two Gaussians per YCxCz channel
    /// (a1, b1, a2, b2), evaluated on the pixel grid and normalised to sum 1.
    const CSF: [[f32; 4]; 3] = [
        [1.0, 0.0047, 0.0, 1e-5],
        [1.0, 0.0053, 0.0, 1e-5],
        [34.1, 0.04, 13.5, 0.025],
    ];

    /// Filters the YCxCz channels (planar) with the CSF.
    fn csf_filter(ycxcz: &[Vec<f32>; 3], w: usize, h: usize) -> [Vec<f32>; 3] {
        let radius =
            (3.0 * (0.04f32 / (2.0 * std::f32::consts::PI.powi(2))).sqrt() * PPD).ceil() as i32;
        let dx = 1.0 / PPD;
        let pi = std::f32::consts::PI;
        std::array::from_fn(|c| {
            let [a1, b1, a2, b2] = CSF[c];
            // Each term a sqrt(pi/b) exp(-pi^2 r^2 / b) factors as e(x) e(y); the 2-D
            // kernel's sum is sum_i a_i sqrt(pi/b_i) (sum_x e_i(x))^2.
            let terms: Vec<(f32, Vec<f32>)> = [(a1, b1), (a2, b2)]
                .into_iter()
                .filter(|(a, _)| *a != 0.0)
                .map(|(a, b)| {
                    let e: Vec<f32> = (-radius..=radius)
                        .map(|i| (-pi * pi * (i as f32 * dx).powi(2) / b).exp())
                        .collect();
                    (a * (pi / b).sqrt(), e)
                })
                .collect();
            let total: f32 = terms
                .iter()
                .map(|(k, e)| k * e.iter().sum::<f32>().powi(2))
                .sum();
            let mut out = vec![0.0; w * h];
            for (k, e) in &terms {
                let f = convolve(&ycxcz[c], w, h, e, e);
                for (o, v) in out.iter_mut().zip(f) {
                    *o += k / total * v;
                }
            }
            out
        })
    }

    /// Edge (first derivative) and point (second derivative) kernels of a Gaussian, positive
    /// and negative weights each normalised to +-1 as in the reference implementation.
    fn feature_kernels() -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let sd = 0.5 * GW * PPD;
        let r = (3.0 * sd).ceil() as i32;
        let xs: Vec<f32> = (-r..=r).map(|i| i as f32).collect();
        let g: Vec<f32> = xs
            .iter()
            .map(|x| (-x * x / (2.0 * sd * sd)).exp())
            .collect();
        let gsum: f32 = g.iter().sum();
        let norm = |k: Vec<f32>| {
            let pos: f32 = k.iter().filter(|v| **v > 0.0).sum();
            let neg: f32 = -k.iter().filter(|v| **v < 0.0).sum::<f32>();
            k.into_iter()
                .map(|v| {
                    if v > 0.0 {
                        v / pos
                    } else if v < 0.0 {
                        v / neg
                    } else {
                        0.0
                    }
                })
                .collect::<Vec<f32>>()
        };
        let edge = norm(xs.iter().zip(&g).map(|(x, g)| -x * g).collect());
        let point = norm(
            xs.iter()
                .zip(&g)
                .map(|(x, g)| (x * x / (sd * sd) - 1.0) * g)
                .collect(),
        );
        (edge, point, g.iter().map(|v| v / gsum).collect())
    }

    /// Per-pixel FLIP error of two sRGB 8-bit images of the same size.
    pub fn flip(reference: &image::RgbImage, test: &image::RgbImage) -> Vec<f32> {
        let (w, h) = (reference.width() as usize, reference.height() as usize);
        let planes = |img: &image::RgbImage| -> [Vec<f32>; 3] {
            let ycc: Vec<[f32; 3]> = img
                .pixels()
                .map(|p| {
                    xyz_to_ycxcz(mul(
                        &RGB2XYZ,
                        p.0.map(|c| srgb_to_linear(f32::from(c) / 255.0)),
                    ))
                })
                .collect();
            std::array::from_fn(|c| ycc.iter().map(|v| v[c]).collect())
        };
        let (pr, pt) = (planes(reference), planes(test));
        let (fr, ft) = (csf_filter(&pr, w, h), csf_filter(&pt, w, h));
        let to_hunt = |f: &[Vec<f32>; 3], i: usize| {
            let rgb =
                mul(&XYZ2RGB, ycxcz_to_xyz([f[0][i], f[1][i], f[2][i]])).map(|v| v.clamp(0.0, 1.0));
            hunt(xyz_to_lab(mul(&RGB2XYZ, rgb)))
        };
        let green = hunt(xyz_to_lab(mul(&RGB2XYZ, [0.0, 1.0, 0.0])));
        let blue = hunt(xyz_to_lab(mul(&RGB2XYZ, [0.0, 0.0, 1.0])));
        let cmax = hyab(green, blue).powf(QC);
        let pccmax = PC * cmax;
        // Features on the achromatic channel, L* scaled to 0..1.
        let (edge, point, g) = feature_kernels();
        let features = |p: &[Vec<f32>; 3]| {
            let grey: Vec<f32> = p[0].iter().map(|y| (y + 16.0) / 116.0).collect();
            let ex = convolve(&grey, w, h, &edge, &g);
            let ey = convolve(&grey, w, h, &g, &edge);
            let px = convolve(&grey, w, h, &point, &g);
            let py = convolve(&grey, w, h, &g, &point);
            let e: Vec<f32> = ex.iter().zip(&ey).map(|(a, b)| a.hypot(*b)).collect();
            let q: Vec<f32> = px.iter().zip(&py).map(|(a, b)| a.hypot(*b)).collect();
            (e, q)
        };
        let ((er, qr), (et, qt)) = (features(&pr), features(&pt));
        (0..w * h)
            .map(|i| {
                let dc = hyab(to_hunt(&fr, i), to_hunt(&ft, i)).powf(QC);
                let ec = if dc < pccmax {
                    PT / pccmax * dc
                } else {
                    PT + (dc - pccmax) / (cmax - pccmax) * (1.0 - PT)
                };
                let df = (er[i] - et[i]).abs().max((qr[i] - qt[i]).abs());
                let ef = (df / std::f32::consts::SQRT_2).powf(QF);
                ec.powf(1.0 - ef)
            })
            .collect()
    }
}

// ---------------------------------------------------------------- comparison

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Reads a linear-radiance EXR (or any float image the `image` crate reads) as RGB.
pub fn read_reference(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let img = image::open(path)
        .map_err(|e| {
            anyhow::anyhow!(
                "{}: cannot read the reference: {}",
                path.display(),
                crate_one_line(&e.to_string())
            )
        })?
        .to_rgb32f();
    let (w, h) = img.dimensions();
    let px: Vec<[f32; 3]> = img.pixels().map(|p| p.0).collect();
    anyhow::ensure!(
        px.iter().flatten().all(|v| v.is_finite()),
        "{}: the reference has non-finite pixels",
        path.display()
    );
    Ok((w, h, px))
}

/// The standard-error image `tools/reference/render_reference.py` writes beside a reference
/// (REF.stderr.exr for REF.exr), if there is one.
pub fn stderr_path(reference: &Path) -> PathBuf {
    let name = reference
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let stem = name
        .strip_suffix(".exr")
        .or_else(|| name.strip_suffix(".EXR"))
        .unwrap_or(&name);
    reference.with_file_name(format!("{stem}.stderr.exr"))
}

fn read_stderr(reference: &Path, w: u32, h: u32) -> Result<Option<Vec<[f32; 3]>>> {
    let path = stderr_path(reference);
    if !path.is_file() {
        return Ok(None);
    }
    let (sw, sh, se) = read_reference(&path)?;
    anyhow::ensure!(
        (sw, sh) == (w, h),
        "{}: {sw}x{sh}, but the reference is {w}x{h}",
        path.display()
    );
    Ok(Some(se))
}

fn crate_one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

fn load_regions(args: &CompareArgs) -> Result<Vec<Region>> {
    let path = match (&args.regions, &args.scene) {
        (Some(p), _) => p.clone(),
        (None, Some(s)) => {
            let p = s.with_extension("regions.json");
            if !p.is_file() {
                return Ok(Vec::new());
            }
            p
        }
        (None, None) => return Ok(Vec::new()),
    };
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let f: RegionsFile =
        serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    for (i, r) in f.regions.iter().enumerate() {
        let [x0, y0, x1, y1] = r.rect;
        anyhow::ensure!(
            r.rect.iter().all(|v| (0.0..=1.0).contains(v)) && x0 < x1 && y0 < y1,
            "{}: regions[{i}].rect: must be [x0, y0, x1, y1] in 0..=1 with x0 < x1, y0 < y1",
            path.display()
        );
    }
    Ok(f.regions)
}

/// Hot colour map for the error image: black, red, yellow, white.
fn hot(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) * 3.0;
    [t, t - 1.0, t - 2.0].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
}

pub fn compare(args: &CompareArgs) -> Result<Report> {
    // Check the inputs before the (slow) render and before creating the output.
    let (rw, rh, reference) = read_reference(&args.reference)?;
    let stderr = read_stderr(&args.reference, rw, rh)?;
    let regions = load_regions(args)?;
    let mut scene = load_scene(args.scene.as_ref(), None)?;
    args.settings.apply(&mut scene)?;
    let opts = RenderOptions::from_scene(&scene);
    anyhow::ensure!(
        (rw, rh) == (opts.width(), opts.height()),
        "{}: the reference is {rw}x{rh} but the scene renders {}x{}",
        args.reference.display(),
        opts.width(),
        opts.height()
    );
    let pending = PendingFile::create(&args.out)?;
    let ctx = GpuContext::new_headless()?;
    let mut renderer = Renderer::new(&ctx, &scene, opts.clone())?;
    let frame = renderer.render().context("rendering failed")?;
    let diffuse = renderer.read_diffuse()?;
    let specular = renderer.read_specular()?;
    let mask = renderer.read_sss()?;
    let ours: Vec<[f32; 3]> = diffuse
        .iter()
        .zip(&specular)
        .map(|(d, s)| [d[0] + s[0], d[1] + s[1], d[2] + s[2]])
        .collect();
    let (w, h) = (opts.width(), opts.height());
    let n = (w * h) as usize;

    // RMSE of linear radiance.
    let sq: f64 = ours
        .iter()
        .zip(&reference)
        .flat_map(|(a, b)| (0..3).map(move |c| f64::from(a[c] - b[c]).powi(2)))
        .sum();
    let rmse = (sq / (3 * n) as f64).sqrt();
    let noise_ms = stderr.as_ref().map(|se| {
        se.iter()
            .flatten()
            .map(|v| f64::from(*v).powi(2))
            .sum::<f64>()
            / (3 * n) as f64
    });
    let rmse_debiased = noise_ms.map(|v| (rmse * rmse - v).max(0.0).sqrt());
    let ref_mean = reference
        .iter()
        .flatten()
        .map(|v| f64::from(*v))
        .sum::<f64>()
        / (3 * n) as f64;

    // Region means, always starting with all skin pixels.
    let is_skin = |i: usize| mask[i][0] > 0.0;
    let mut all = vec![Region {
        name: "skin".into(),
        rect: [0.0, 0.0, 1.0, 1.0],
    }];
    all.extend(regions);
    let region_results: Vec<RegionResult> = all
        .into_iter()
        .map(|r| {
            let [x0, y0, x1, y1] = r.rect;
            let (mut a, mut b, mut count) = ([0.0f64; 3], [0.0f64; 3], 0usize);
            let mut var_y = 0.0f64;
            for y in (y0 * h as f32) as u32..((y1 * h as f32).ceil() as u32).min(h) {
                for x in (x0 * w as f32) as u32..((x1 * w as f32).ceil() as u32).min(w) {
                    let i = (y * w + x) as usize;
                    if is_skin(i) {
                        for c in 0..3 {
                            a[c] += f64::from(ours[i][c]);
                            b[c] += f64::from(reference[i][c]);
                        }
                        if let Some(se) = &stderr {
                            // Pixels are independent; channels share paths, so their errors
                            // add linearly (the upper bound).
                            var_y += f64::from(luminance(se[i])).powi(2);
                        }
                        count += 1;
                    }
                }
            }
            let k = 1.0 / count.max(1) as f64;
            let (ma, mb) = (a.map(|v| (v * k) as f32), b.map(|v| (v * k) as f32));
            let (ya, yb) = (luminance(ma), luminance(mb));
            RegionResult {
                name: r.name,
                pixels: count,
                mean_realtime: ma,
                mean_reference: mb,
                rel_error: if count == 0 || yb <= 0.0 {
                    f32::NAN
                } else {
                    (ya - yb) / yb
                },
                rel_stderr: stderr
                    .as_ref()
                    .map(|_| (var_y.sqrt() * k / f64::from(yb.max(1e-12))) as f32),
            }
        })
        .collect();
    if let Some(r) = region_results.iter().find(|r| r.pixels == 0) {
        anyhow::bail!("region {:?}: no skin pixels in its rectangle", r.name);
    }

    // FLIP on the tone-mapped images.
    let ours_ldr = tone_map(&ours, opts.settings.exposure_ev, w, h);
    let ref_ldr = tone_map(&reference, opts.settings.exposure_ev, w, h);
    let check = ours_ldr
        .pixels()
        .zip(frame.image.pixels())
        .flat_map(|(a, b)| (0..3).map(move |c| a.0[c].abs_diff(b.0[c])))
        .max()
        .unwrap_or(0);
    let err = flip::flip(&ref_ldr, &ours_ldr);
    let flip_mean = err.iter().map(|v| f64::from(*v)).sum::<f64>() / n as f64;

    // Side by side: real-time | reference | FLIP error.
    let mut side = image::RgbImage::new(3 * w, h);
    for y in 0..h {
        for x in 0..w {
            side.put_pixel(x, y, *ours_ldr.get_pixel(x, y));
            side.put_pixel(w + x, y, *ref_ldr.get_pixel(x, y));
            side.put_pixel(2 * w + x, y, image::Rgb(hot(err[(y * w + x) as usize])));
        }
    }
    pending.write_png(&side)?;

    Ok(Report {
        reference: args.reference.display().to_string(),
        scene: args
            .scene
            .as_ref()
            .map_or("(default scene)".into(), |p| p.display().to_string()),
        sss: serde_json::to_value(opts.settings.sss.method)?,
        transmittance: serde_json::to_value(opts.settings.transmittance.method)?,
        width: w,
        height: h,
        rmse: rmse as f32,
        rel_rmse: (rmse / ref_mean.max(1e-12)) as f32,
        noise_rms: noise_ms.map(|v| v.sqrt() as f32),
        rmse_debiased: rmse_debiased.map(|v| v as f32),
        rel_rmse_debiased: rmse_debiased.map(|v| (v / ref_mean.max(1e-12)) as f32),
        flip_mean: flip_mean as f32,
        regions: region_results,
        tonemap_check_max_diff: check,
        out: args.out.display().to_string(),
    })
}

pub fn run(args: &CompareArgs) -> Result<()> {
    let r = compare(args)?;
    let text = if args.json {
        serde_json::to_string(&r)?
    } else {
        let regions: Vec<String> = r
            .regions
            .iter()
            .map(|g| match g.rel_stderr {
                Some(se) => format!(
                    "{} {:+.1}% (±{:.1}%)",
                    g.name,
                    100.0 * g.rel_error,
                    100.0 * se
                ),
                None => format!("{} {:+.1}%", g.name, 100.0 * g.rel_error),
            })
            .collect();
        let noise = match (r.rmse_debiased, r.noise_rms) {
            (Some(d), Some(n)) => {
                format!(" ({:.4} with the reference's noise {n:.4} taken out)", d)
            }
            _ => String::new(),
        };
        format!(
            "{} vs {}: sss {} transmittance {}: RMSE {:.4} ({:.1}% of mean){noise}, FLIP {:.4}, region means {}; wrote {}",
            r.scene,
            r.reference,
            r.sss.as_str().unwrap_or("?"),
            r.transmittance.as_str().unwrap_or("?"),
            r.rmse,
            100.0 * r.rel_rmse,
            r.flip_mean,
            regions.join(", "),
            r.out
        )
    };
    // With the image on stdout (`--out -`), the report goes to stderr.
    print_summary(is_stdout(&args.out), &format!("{text}\n"));
    Ok(())
}
