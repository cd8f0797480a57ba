//! `subsurface compare`: a real-time render against a path-traced reference of the same scene.
//!
//! Errors reported (docs/lab/fidelity.md):
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

use crate::output::{PendingFile, is_stdout, png_bytes, print_summary};
use crate::plot;
use crate::settings_args::{SettingsArgs, load_scene};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Path-traced reference: a linear-radiance EXR of the scene (tools/reference/).
    reference: PathBuf,
    /// Scene file (TOML). Without it, the embedded default scene. Rendered at the scene's size,
    /// which must be the reference's.
    scene: Option<PathBuf>,
    /// Side-by-side image: real-time | reference | FLIP error.
    #[arg(long, short, default_value = "compare.png", value_name = "FILE.png")]
    out: PathBuf,
    /// Named regions (JSON, see docs/lab/fidelity.md) [default: SCENE.regions.json beside the
    /// scene, if present].
    #[arg(long, value_name = "FILE.json")]
    regions: Option<PathBuf>,
    /// Knife-edge scenes (an `edge` in the regions file): plot the curves across the edge,
    /// real-time and reference per channel, as a PNG (`-`: standard output).
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
    /// Also write the real-time linear radiance that was compared (diffuse after SSS plus
    /// specular, the reference's units, before exposure and tone mapping) as an RGB float EXR,
    /// for analysis beside the reference.
    #[arg(long, value_name = "FILE.exr")]
    linear: Option<PathBuf>,
    /// Render N x N samples per reference pixel (at N times the size) and average them, as
    /// the path tracer's box filter averages each pixel's area: a silhouette's thin rim, where
    /// light crosses a fraction of a millimetre of skin, is far brighter than the pixel
    /// centre that one sample shades, so at one sample the comparison measures the sampling
    /// as much as the method. 1..=8.
    #[arg(long, default_value_t = 1, value_name = "N")]
    supersample: u32,
    /// Print the results as one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// The settings to render with (--exposure-ev also sets the exposure of the tone-mapped
    /// images that FLIP and the side-by-side image compare).
    #[command(flatten)]
    settings: SettingsArgs,
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

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionsFile {
    #[serde(default)]
    regions: Vec<Region>,
    /// A straight shadow edge to measure (the knife-edge scene).
    #[serde(default)]
    edge: Option<edge::EdgeSpec>,
    /// Pixels to bin by the thickness the light crosses (backlit scenes).
    #[serde(default)]
    thickness: Option<thickness::ThicknessSpec>,
}

#[derive(Debug, Serialize)]
pub struct RegionResult {
    pub name: String,
    pub pixels: usize,
    pub mean_realtime: [f32; 3],
    pub mean_reference: [f32; 3],
    /// (Y_realtime - Y_reference) / Y_reference of the region means' luminance; None (null)
    /// where the reference is black, with the reason in `note`.
    pub rel_error: Option<f32>,
    /// Standard error of `rel_error` from the reference's own noise (its `.stderr.exr`; the
    /// channels are taken as fully correlated, so this errs on the large side). None without
    /// a standard-error image or a relative error.
    pub rel_stderr: Option<f32>,
    /// Why `rel_error` is missing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Why a relative error is None: dividing by a black reference gave NaN% (0/0) or inf%.
const BLACK_REFERENCE: &str = "the reference is black here (mean 0): no relative error";

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
    /// `rmse` / mean reference radiance; None (null) for a black reference.
    pub rel_rmse: Option<f32>,
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
    /// The knife-edge measurement, when the regions file names an edge.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge: Option<edge::EdgeResult>,
    /// Radiance against thickness, when the regions file asks for it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thickness: Option<thickness::ThicknessResult>,
    /// Largest difference (1/255 steps) between our CPU tone map and the GPU's frame: checks
    /// that FLIP sees what `subsurface render` writes.
    pub tonemap_check_max_diff: u8,
    pub out: String,
}

// ---------------------------------------------------------------- tone map (CPU)

/// Hable's filmic curve as in `passes/tonemap.wgsl`.
///
/// In f64: a reference of 3e38 squared to infinity in f32, the curve gave inf / inf = NaN and
/// the reference panel came out black.
fn hable(x: f64) -> f64 {
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
    let k = f64::from(exposure_ev.exp2());
    let white = hable(11.2);
    let px: Vec<u8> = linear
        .iter()
        .flat_map(|c| {
            c.map(|v| {
                let m = (hable(2.0 * f64::from(v.max(0.0)) * k) / white).clamp(0.0, 1.0) as f32;
                (srgb_encode(m) * 255.0).round() as u8
            })
        })
        .collect();
    image::RgbImage::from_raw(w, h, px).expect("w * h pixels")
}

// ---------------------------------------------------------------- FLIP (LDR): flip.rs

pub mod edge;
pub mod flip;
mod inputs;
pub mod thickness;

use inputs::read_reference;
use inputs::{load_regions, read_stderr};

// ---------------------------------------------------------------- comparison

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
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
    let (
        regions_path,
        RegionsFile {
            regions,
            edge: edge_spec,
            thickness: thickness_spec,
        },
    ) = load_regions(args)?;
    let mut scene = load_scene(args.scene.as_ref(), None)?;
    args.settings.apply(&mut scene)?;
    let opts = RenderOptions::from_scene(&scene);
    let ss = args.supersample;
    anyhow::ensure!(
        (1..=8).contains(&ss),
        "--supersample: must be in 1..=8 (got {ss})"
    );
    anyhow::ensure!(
        (rw, rh) == (opts.width(), opts.height()),
        "{}: the reference is {rw}x{rh} but the scene renders {}x{}",
        args.reference.display(),
        opts.width(),
        opts.height()
    );
    anyhow::ensure!(
        args.plot.is_none() || edge_spec.is_some() || thickness_spec.is_some(),
        "--plot: the regions file names no edge or thickness curve to plot"
    );
    anyhow::ensure!(
        !(is_stdout(&args.out) && args.plot.as_deref().is_some_and(is_stdout)),
        "--plot: --out is standard output already"
    );
    anyhow::ensure!(
        !args.linear.as_deref().is_some_and(is_stdout)
            || !(is_stdout(&args.out) || args.plot.as_deref().is_some_and(is_stdout)),
        "--linear: standard output is taken by another output already"
    );
    let plot_file = args.plot.as_deref().map(plot::create_plot).transpose()?;
    let linear_file = args
        .linear
        .as_deref()
        .map(PendingFile::create)
        .transpose()?;
    let mut pending = PendingFile::create(&args.out)?;
    let ctx = GpuContext::new_headless()?;
    let (w, h) = (opts.width(), opts.height());
    let mut fine = opts.clone();
    fine.settings.width = w * ss;
    fine.settings.height = h * ss;
    ctx.check_size("--supersample: the render ", fine.width(), fine.height())?;
    let mut renderer = Renderer::new(&ctx, &scene, fine.clone())?;
    let frame = renderer.render().context("rendering failed")?;
    let diffuse = renderer.read_diffuse()?;
    let specular = renderer.read_specular()?;
    let mask = renderer.read_sss()?;
    let ours_fine: Vec<[f32; 3]> = diffuse
        .iter()
        .zip(&specular)
        .map(|(d, s)| [d[0] + s[0], d[1] + s[1], d[2] + s[2]])
        .collect();
    // The CPU tone map must reproduce the GPU frame (at the size it was rendered).
    let check = tone_map(
        &ours_fine,
        opts.settings.exposure_ev,
        fine.width(),
        fine.height(),
    )
    .pixels()
    .zip(frame.image.pixels())
    .flat_map(|(a, b)| (0..3).map(move |c| a.0[c].abs_diff(b.0[c])))
    .max()
    .unwrap_or(0);
    let ours = box_down(&ours_fine, w, h, ss);
    // A pixel is skin where most of its samples are (the SSS target's r is the strength).
    let skin: Vec<[f32; 3]> = mask
        .iter()
        .map(|m| [f32::from(u8::from(m[0] > 0.0)); 3])
        .collect();
    let skin = box_down(&skin, w, h, ss);
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
    // Relative to the reference's mean, which must be positive to divide by, and large enough
    // for the quotient to be finite (a 1e-40 reference printed "inf% of mean").
    let relative = |v: f64| {
        let r = (v / ref_mean) as f32;
        (ref_mean > 0.0 && r.is_finite()).then_some(r)
    };

    // Region means, always starting with all skin pixels.
    let is_skin = |i: usize| skin[i][0] > 0.5;
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
            let (ya, yb) = (f64::from(luminance(ma)), f64::from(luminance(mb)));
            let rel = ((ya - yb) / yb) as f32;
            // A near-black reference (1e-40) gave "+inf%": only a finite quotient is kept.
            let defined = yb > 0.0 && rel.is_finite();
            RegionResult {
                name: r.name,
                pixels: count,
                mean_realtime: ma,
                mean_reference: mb,
                rel_error: defined.then_some(rel),
                rel_stderr: stderr
                    .as_ref()
                    .filter(|_| defined)
                    .map(|_| (var_y.sqrt() * k / yb) as f32)
                    .filter(|v| v.is_finite()),
                note: (!defined).then(|| {
                    if yb > 0.0 {
                        format!(
                            "the reference is too dark here (mean luminance {yb:e}) for a \
                             finite relative error"
                        )
                    } else {
                        BLACK_REFERENCE.to_string()
                    }
                }),
            }
        })
        .collect();
    if let Some(k) = region_results.iter().position(|r| r.pixels == 0) {
        // Region 0 is the whole image's skin, the scene's; the others are the regions file's.
        let scene_name = args
            .scene
            .as_ref()
            .map_or("<default scene>".into(), |p| p.display().to_string());
        match (k, &regions_path) {
            (0, _) | (_, None) => {
                anyhow::bail!("{scene_name}: no skin pixels in the render to compare")
            }
            (k, Some(p)) => anyhow::bail!(
                "{}: regions[{}] {:?}: no skin pixels in its rectangle",
                p.display(),
                k - 1,
                region_results[k].name
            ),
        }
    }

    let edge = edge_spec
        .map(|spec| edge::measure(&ours, &reference, w, h, &spec, mm_per_pixel(&scene, h)));
    let thickness = match thickness_spec {
        Some(spec) => {
            // The thickness each pixel's light crosses, from the same shadow maps: the
            // thickness debug view writes it into the diffuse target (< 0: unknown).
            let mut o = fine.clone();
            o.view = subsurface_render::DebugView::Thickness;
            renderer.update(&scene, &o)?;
            renderer
                .render()
                .context("rendering the thickness view failed")?;
            // A pixel's thickness is its samples' mean, over those where it is known.
            let fine_s = renderer.read_diffuse()?;
            let known: Vec<[f32; 3]> = fine_s
                .iter()
                .map(|v| {
                    if v[0] >= 0.0 {
                        [v[0], 1.0, 0.0]
                    } else {
                        [0.0; 3]
                    }
                })
                .collect();
            let s: Vec<f32> = box_down(&known, w, h, ss)
                .iter()
                .map(|v| if v[1] > 0.0 { v[0] / v[1] } else { -1.0 })
                .collect();
            Some(thickness::measure(&ours, &reference, &s, w, h, &spec))
        }
        None => None,
    };

    // FLIP on the tone-mapped images.
    let ours_ldr = tone_map(&ours, opts.settings.exposure_ev, w, h);
    let ref_ldr = tone_map(&reference, opts.settings.exposure_ev, w, h);
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
    // Every output is encoded and written before any is committed: `--linear /dev/full`
    // failed after out.png was already in place.
    pending.write_bytes(&png_bytes(&side, &args.out)?)?;
    let mut written = vec![pending];
    if let Some(mut file) = linear_file {
        let img = image::Rgb32FImage::from_raw(w, h, ours.iter().flatten().copied().collect())
            .expect("w * h pixels");
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, image::ImageFormat::OpenExr)
            .context("--linear: EXR encoding failed")?;
        file.write_bytes(bytes.get_ref())?;
        written.push(file);
    }
    if let Some(mut file) = plot_file {
        let title = format!(
            "{}: {} + {}",
            args.scene
                .as_ref()
                .map_or("default scene".into(), |p| p.display().to_string()),
            serde_json::to_value(opts.settings.sss.method)?
                .as_str()
                .unwrap_or("?"),
            serde_json::to_value(opts.settings.transmittance.method)?
                .as_str()
                .unwrap_or("?"),
        );
        let img = plot::draw_image((900, 560), |root| match (&edge, &thickness) {
            (Some(e), _) => edge::draw(root, e, &title),
            (None, Some(t)) => thickness::draw(root, t, &title),
            (None, None) => Ok(()),
        })
        .context("--plot")?;
        let bytes =
            png_bytes(&img, args.plot.as_deref().unwrap_or(Path::new("-"))).context("--plot")?;
        file.write_bytes(&bytes).context("--plot")?;
        written.push(file);
    }
    for file in written {
        file.commit()?;
    }

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
        rel_rmse: relative(rmse),
        noise_rms: noise_ms.map(|v| v.sqrt() as f32),
        rmse_debiased: rmse_debiased.map(|v| v as f32),
        rel_rmse_debiased: rmse_debiased.and_then(relative),
        flip_mean: flip_mean as f32,
        regions: region_results,
        edge,
        thickness,
        tonemap_check_max_diff: check,
        out: args.out.display().to_string(),
    })
}

/// The mean of each `ss` x `ss` block of a `(w ss) x (h ss)` image: a box filter, as the path
/// tracer's film applies to every pixel.
fn box_down(fine: &[[f32; 3]], w: u32, h: u32, ss: u32) -> Vec<[f32; 3]> {
    if ss == 1 {
        return fine.to_vec();
    }
    let fw = (w * ss) as usize;
    let k = 1.0 / (ss * ss) as f32;
    let mut out = vec![[0.0f32; 3]; (w * h) as usize];
    for (i, px) in fine.iter().enumerate() {
        let (x, y) = ((i % fw) as u32 / ss, (i / fw) as u32 / ss);
        let o = &mut out[(y * w + x) as usize];
        for c in 0..3 {
            o[c] += px[c] * k;
        }
    }
    out
}

/// Millimetres of skin per pixel in the plane through the camera's target, square to the view:
/// the image height there is 2 d tan(fov / 2) scene units, and the first scattering object
/// says how many scene units its profile millimetre is.
fn mm_per_pixel(scene: &subsurface_render::Scene, h: u32) -> f32 {
    let cam = &scene.desc.camera;
    let d = (glam::Vec3::from(cam.target) - glam::Vec3::from(cam.position)).length();
    let world = 2.0 * d * (cam.fov_y_deg.to_radians() / 2.0).tan() / h as f32;
    let per_mm = scene
        .objects
        .iter()
        .find(|o| o.material.sss_strength > 0.0)
        .map_or(1.0, subsurface_render::gpu_scene::world_per_mm);
    world / per_mm
}

/// `x` with `digits` decimals, or "n/a" where a black reference left it undefined (the edge
/// widths come out NaN without light on either side).
fn n_a(x: f32, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "n/a".into()
    }
}

pub fn run(args: &CompareArgs) -> Result<()> {
    let r = compare(args)?;
    let text = if args.json {
        serde_json::to_string(&r)?
    } else {
        let regions: Vec<String> = r
            .regions
            .iter()
            .map(|g| match (g.rel_error, g.rel_stderr) {
                (Some(e), Some(se)) => {
                    format!("{} {:+.1}% (±{:.1}%)", g.name, 100.0 * e, 100.0 * se)
                }
                (Some(e), None) => format!("{} {:+.1}%", g.name, 100.0 * e),
                (None, _) => format!("{} n/a (black reference)", g.name),
            })
            .collect();
        let noise = match (r.rmse_debiased, r.noise_rms) {
            (Some(d), Some(n)) => {
                format!(" ({:.4} with the reference's noise {n:.4} taken out)", d)
            }
            _ => String::new(),
        };
        let edge = r.edge.as_ref().map_or(String::new(), |e| {
            let f = |v: [f32; 3]| v.map(|x| n_a(x, 2)).join("/");
            format!(
                ", edge width (10-90 %, R/G/B mm) {} vs reference {}",
                f(e.edge_width_mm),
                f(e.edge_width_mm_reference)
            )
        });
        let edge = edge
            + &r.thickness.as_ref().map_or(String::new(), |t| {
                let m = t.max_abs_rel_error;
                format!(
                    ", against thickness worst {:.0}/{:.0}/{:.0}% (R/G/B)",
                    100.0 * m[0],
                    100.0 * m[1],
                    100.0 * m[2]
                )
            });
        format!(
            "{} vs {}: sss {} transmittance {}: RMSE {:.4} ({} of mean){noise}, FLIP {:.4}, region means {}{edge}; wrote {}",
            r.scene,
            r.reference,
            r.sss.as_str().unwrap_or("?"),
            r.transmittance.as_str().unwrap_or("?"),
            r.rmse,
            r.rel_rmse
                .map_or("n/a: black reference".into(), |v| format!(
                    "{:.1}%",
                    100.0 * v
                )),
            r.flip_mean,
            regions.join(", "),
            r.out
        )
    };
    // With the image on stdout (`--out -`), the report goes to stderr.
    let stdout_taken = is_stdout(&args.out) || args.plot.as_deref().is_some_and(is_stdout);
    print_summary(stdout_taken, &format!("{text}\n"));
    Ok(())
}
