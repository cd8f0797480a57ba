//! `subsurface bench`: GPU time per pass (timestamp queries), medians over many frames.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use serde::Serialize;
use subsurface_render::passes::sss::SssMethod;
use subsurface_render::{GpuContext, PassTiming, Renderer};

use crate::render::{SssArg, SssArgs, TransmittanceArgs, load_scene, options};

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file (default: the embedded default scene).
    pub scene: Option<PathBuf>,
    /// Replace the scene's objects by this glTF/GLB model.
    #[arg(long, value_name = "FILE.glb")]
    pub model: Option<PathBuf>,
    /// Image sizes to measure, WxH, comma-separated.
    #[arg(long, default_value = "1280x720,1920x1080", value_delimiter = ',', value_parser = parse_size)]
    pub sizes: Vec<(u32, u32)>,
    /// SSS methods to measure, comma-separated (none, gaussian6, separable, hable13).
    #[arg(
        long = "methods",
        value_enum,
        value_delimiter = ',',
        default_value = "none,separable,gaussian6,hable13"
    )]
    pub methods: Vec<SssArg>,
    /// Frames rendered and thrown away before timing (shader compilation, caches).
    #[arg(long, default_value_t = 5)]
    pub warmup: u32,
    /// Timed frames; the median of each pass is reported.
    #[arg(long, default_value_t = 30)]
    pub frames: u32,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub sss: SssArgs,
    #[command(flatten)]
    pub transmittance: TransmittanceArgs,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("expected WxH, got {s:?}"))?;
    let w: u32 = w.trim().parse().map_err(|e| format!("width {w:?}: {e}"))?;
    let h: u32 = h.trim().parse().map_err(|e| format!("height {h:?}: {e}"))?;
    if w == 0 || h == 0 {
        return Err(format!("sizes must be at least 1x1 (got {s})"));
    }
    Ok((w, h))
}

#[derive(Serialize)]
struct Run {
    characters: u32,
    width: u32,
    height: u32,
    sss: &'static str,
    frame_ms: f64,
    passes: Vec<PassTiming>,
    /// A plain full-screen copy of the diffuse target, measured in the same frames.
    copy_ms: f64,
    /// SSS GPU time divided by the copy's.
    sss_over_copy: Option<f64>,
}

#[derive(Serialize)]
struct Report {
    adapter: String,
    frames: u32,
    runs: Vec<Run>,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub fn run(args: &BenchArgs) -> Result<()> {
    anyhow::ensure!(
        args.frames >= 1,
        "--frames: must be at least 1 (got {})",
        args.frames
    );
    let mut scene = load_scene(args.scene.as_ref(), args.model.as_ref())?;
    let ctx = GpuContext::new_headless()?;
    anyhow::ensure!(
        ctx.has_timestamps(),
        "{}: the adapter has no timestamp queries",
        ctx.adapter_name()
    );
    let sss_base = args.sss.apply(&mut scene)?;
    let transmittance = args.transmittance.config(&scene)?;
    let total = (args.sizes.len() * args.methods.len()) as u64 * (args.warmup + args.frames) as u64;
    let bar = indicatif::ProgressBar::new(total).with_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames {msg}")
            .expect("static template"),
    );
    let mut runs = Vec::new();
    for &(w, h) in &args.sizes {
        ctx.check_size("--sizes ", w, h)?;
        for &method in &args.methods {
            let method: SssMethod = method.into();
            bar.set_message(format!("{w}x{h} {}", method.name()));
            let mut opts = options(&scene, Some(w), Some(h), None)?;
            opts.sss = sss_base.clone();
            opts.sss.method = method;
            opts.transmittance = transmittance.clone();
            opts.baseline_copy = true;
            let mut renderer =
                Renderer::new(&ctx, &scene, opts).context("creating the renderer")?;
            let mut samples: Vec<Vec<PassTiming>> = Vec::new();
            for i in 0..args.warmup + args.frames {
                let t = renderer.render_timed()?;
                if i >= args.warmup {
                    samples.push(t);
                }
                bar.inc(1);
            }
            let names: Vec<String> = samples.iter().flatten().fold(Vec::new(), |mut acc, t| {
                if !acc.contains(&t.name) {
                    acc.push(t.name.clone());
                }
                acc
            });
            let per_pass = |name: &str| {
                median(
                    samples
                        .iter()
                        .map(|f| f.iter().filter(|t| t.name == name).map(|t| t.ms).sum())
                        .collect(),
                )
            };
            let copy_ms = per_pass("copy");
            let passes: Vec<PassTiming> = names
                .iter()
                .filter(|n| n.as_str() != "copy")
                .map(|n| PassTiming {
                    name: n.clone(),
                    ms: per_pass(n),
                })
                .collect();
            let frame_ms = median(
                samples
                    .iter()
                    .map(|f| f.iter().filter(|t| t.name != "copy").map(|t| t.ms).sum())
                    .collect(),
            );
            let sss_ms = passes.iter().find(|p| p.name == "sss").map(|p| p.ms);
            runs.push(Run {
                characters: 1,
                width: w,
                height: h,
                sss: method.name(),
                frame_ms,
                passes,
                copy_ms,
                sss_over_copy: sss_ms.filter(|_| copy_ms > 0.0).map(|s| s / copy_ms),
            });
        }
    }
    bar.finish_and_clear();
    let report = Report {
        adapter: ctx.adapter_name(),
        frames: args.frames,
        runs,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} — median of {} frames after {} warm-up",
            report.adapter, args.frames, args.warmup
        );
        println!(
            "{:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
            "size", "sss", "frame ms", "shadow", "lighting", "sss ms", "sss/copy"
        );
        for r in &report.runs {
            let p = |n: &str| r.passes.iter().find(|p| p.name == n).map_or(0.0, |p| p.ms);
            println!(
                "{:>10} {:>10} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10}",
                format!("{}x{}", r.width, r.height),
                r.sss,
                r.frame_ms,
                p("shadow"),
                p("lighting"),
                p("sss"),
                r.sss_over_copy.map_or("-".into(), |x| format!("{x:.2}")),
            );
        }
    }
    Ok(())
}
