//! `subsurface bench`: GPU time per pass (timestamp queries), medians over many frames, for
//! each image size, number of characters, SSS method and transmittance method.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use plotters::prelude::*;
use serde::Serialize;
use subsurface_profile::Medium;
use subsurface_render::{
    GpuContext, LateralPass, PassTiming, RenderOptions, Renderer, Scene, SssFetch, SssMethod,
    TransmittanceMethod,
};

use crate::output::{PendingFile, print_summary};
use memory::{Traffic, flip_means, traffic_of, traffic_table};

mod memory;
use crate::plot;
use crate::settings_args::{load_scene, replicate};

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file (default: the embedded default scene, the hand and the wedge).
    pub scene: Option<PathBuf>,
    /// Replace the scene's objects by this glTF/GLB model.
    #[arg(long, value_name = "FILE.glb")]
    pub model: Option<PathBuf>,
    /// Image width; with --height, a single size instead of --sizes.
    #[arg(long, requires = "height")]
    pub width: Option<u32>,
    /// Image height; with --width, a single size instead of --sizes.
    #[arg(long, requires = "width")]
    pub height: Option<u32>,
    /// Image sizes to measure, WxH, comma-separated.
    #[arg(long, default_value = "1280x720,1920x1080", value_delimiter = ',', value_parser = parse_size)]
    pub sizes: Vec<(u32, u32)>,
    /// Numbers of characters (copies of the scene's objects, in a grid covering about the
    /// same screen area at every count), comma-separated.
    #[arg(long, default_value = "1", value_delimiter = ',')]
    pub characters: Vec<u32>,
    /// SSS methods to measure, comma-separated (none, gaussian6, separable, hable13, texture).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "none,separable,gaussian6,hable13",
        value_name = "METHOD,.."
    )]
    pub sss: Vec<SssMethod>,
    /// Transmittance methods to measure, comma-separated (e.g. paper,off for the cost of
    /// transmittance side by side).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "paper",
        value_name = "METHOD,.."
    )]
    pub transmittance: Vec<TransmittanceMethod>,
    /// Diffusion runs: numbers of lateral shadow-map taps (0..=32), comma-separated, e.g. 0,12
    /// for what gathering the light around the chord costs against the chord's slab alone
    /// [default: the scene's render.transmittance.lateral_taps].
    #[arg(long, value_delimiter = ',', value_name = "N,..")]
    pub lateral_taps: Vec<u32>,
    /// Diffusion runs: the lateral map's texel sizes in profile millimetres (0..=50),
    /// comma-separated, e.g. 0,2 for `diffusion` at every pixel inside the lighting pass against
    /// the lateral pass's map [default: the scene's render.transmittance.lateral_texel_mm].
    /// The table names each run by the reduction it gave (`diffusion/12:4`: 12 taps, one
    /// texel per 4x4 pixels).
    #[arg(long, value_delimiter = ',', value_name = "MM,..")]
    pub lateral_texel_mm: Vec<f32>,
    /// Diffusion runs: how the lateral map is evaluated, compute and/or fragment,
    /// comma-separated; the same map, so `compute,fragment` compares their cost [default: the
    /// scene's render.transmittance.lateral_pass]. The table marks fragment runs
    /// (`diffusion/12:8 frag`).
    #[arg(long, value_delimiter = ',', value_name = "PASS,..")]
    pub lateral_pass: Vec<LateralPass>,
    /// The bounce's ring (0..=8; 0 = off), comma-separated, e.g. 0,2 for what gathering the
    /// light between parts costs [default: the scene's render.bounce.ring]. The table names
    /// each run's ring after its transmittance (`paper b2`).
    #[arg(long, value_delimiter = ',', value_name = "N,..")]
    pub bounce_ring: Vec<u32>,
    /// Numbers of distinct diffusion profiles on screen, comma-separated: the objects (with
    /// --characters, the copies) take the material presets in turn, so the cost of a profile
    /// per material shows beside one profile for all.
    #[arg(long, default_value = "1", value_delimiter = ',', value_name = "N,..")]
    pub profiles: Vec<u32>,
    /// How the screen-space passes fetch a tap's texels, comma-separated: packed (one
    /// Rgba32Uint texel per texel, after a pack step), workgroup (packed, and separable's
    /// passes as compute shaders reading workgroup memory) and/or direct (colour, depth and SSS
    /// textures per texel); the same image, so `packed,workgroup,direct` compares their cost.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "workgroup",
        value_name = "FETCH,.."
    )]
    pub fetch: Vec<SssFetch>,
    /// Numbers of the scene's lights to keep (its first N), comma-separated, e.g. 1,5 on the
    /// head: the table then gives the lighting and shadow passes' cost per light (the slope
    /// between the smallest and the largest N) [default: all of the scene's lights].
    #[arg(long, value_delimiter = ',', value_name = "N,..")]
    pub lights: Vec<u32>,
    /// Separable kernel taps.
    #[arg(long, default_value_t = 17, value_name = "N")]
    pub samples: u32,
    /// Separable: jitter the taps per pixel (the few-sample mode, e.g. --samples 7 --jitter).
    #[arg(long)]
    pub jitter: bool,
    /// Separable runs: also render the frame with N fixed taps and report the FLIP mean (LDR)
    /// of the measured settings against it, over the whole frame and over the skin pixels, e.g.
    /// --samples 7 --jitter --flip-vs 33 for the quality the few-sample mode gives up.
    #[arg(long, value_name = "N")]
    pub flip_vs: Option<u32>,
    /// Memory bandwidth of the adapter in GB/s (10^9 bytes/s): prints each modelled pass's
    /// time against the time its compulsory bytes take at that rate (1 = at the memory limit).
    #[arg(long, value_name = "GBPS")]
    pub bandwidth: Option<f64>,
    /// Frames rendered and thrown away before timing (shader compilation, caches).
    #[arg(long, default_value_t = 5)]
    pub warmup: u32,
    /// Timed frames; the median of each pass is reported.
    #[arg(long, default_value_t = 30)]
    pub frames: u32,
    /// Measure every configuration this many times in turn (A, B, A, B, ...), each round with
    /// its own warm-up and frames, and report the median over all rounds' frames: a machine
    /// whose speed drifts over minutes (a CPU driver, a laptop's clocks) then shifts every
    /// configuration alike instead of whichever ran last. JSON gives each round's frame time.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub rounds: u32,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Draw GPU time against the number of characters, one line per method; `-` writes the
    /// PNG to standard output and the table to standard error.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,
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
    /// Rows of the screen-space profile table (distinct profiles on screen).
    profiles: u32,
    /// Lights kept of the scene's (`--lights`).
    lights: u32,
    width: u32,
    height: u32,
    sss: &'static str,
    /// How the screen-space passes fetched their texels (`packed`, `workgroup`, `direct`).
    fetch: &'static str,
    transmittance: String,
    /// Diffusion runs: the lateral shadow-map taps per shadowed light.
    #[serde(skip_serializing_if = "Option::is_none")]
    lateral_taps: Option<u32>,
    /// Diffusion runs: the lateral map's texel size asked for, and the reduction it gave (1:
    /// the taps run at every pixel).
    #[serde(skip_serializing_if = "Option::is_none")]
    lateral_texel_mm: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lateral_downsample: Option<u32>,
    /// Diffusion runs: how the lateral map was evaluated (`compute`, `fragment`; `fragment`
    /// also where the adapter cannot run the compute evaluation).
    #[serde(skip_serializing_if = "Option::is_none")]
    lateral_pass: Option<&'static str>,
    /// The bounce's ring (0: none).
    bounce_ring: u32,
    /// Median frame time (sum of the passes, copy baseline excluded).
    frame_ms: f64,
    /// `--rounds`: each round's median frame time, in the order they ran.
    round_frame_ms: Vec<f64>,
    passes: Vec<PassTiming>,
    /// A plain full-screen copy of the diffuse target, measured in the same frames.
    copy_ms: f64,
    /// GPU time of the subsurface-scattering passes divided by the copy's.
    sss_over_copy: Option<f64>,
    /// Separable taps and whether they were jittered.
    samples: u32,
    jitter: bool,
    /// FLIP mean of the frame against the `--flip-vs` fixed-tap frame (separable runs): over
    /// the whole frame, and over the skin pixels only (where SSS changes anything).
    #[serde(skip_serializing_if = "Option::is_none")]
    flip_vs_fixed: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    flip_vs_fixed_skin: Option<f64>,
    /// Bytes the modelled passes must move (passes::traffic), with the measured time.
    traffic: Vec<Traffic>,
}

impl Run {
    /// The transmittance as the table names it: `diffusion/12:4` for diffusion with 12 lateral
    /// taps once per 4x4 pixels, so that `--lateral-taps 0,12` shows two rows.
    fn transmittance_label(&self) -> String {
        let label = match (self.lateral_taps, self.lateral_downsample) {
            (Some(taps), Some(d)) => format!("{}/{taps}:{d}", self.transmittance),
            (Some(taps), None) => format!("{}/{taps}", self.transmittance),
            _ => self.transmittance.clone(),
        };
        let label = match self.lateral_pass {
            Some("fragment") => format!("{label} frag"),
            _ => label,
        };
        match self.bounce_ring {
            0 => label,
            ring => format!("{label} b{ring}"),
        }
    }
}

/// The lateral tap counts, texel sizes and passes a transmittance method is measured at:
/// `--lateral-taps` x `--lateral-texel-mm` x `--lateral-pass` for diffusion (the scene's own
/// where a list is empty), nothing to vary for the others.
fn lateral_counts(
    tm: TransmittanceMethod,
    taps: &[u32],
    texel_mm: &[f32],
    passes: &[LateralPass],
) -> Vec<LateralRun> {
    if tm != TransmittanceMethod::Diffusion {
        return vec![LateralRun::default()];
    }
    let taps: Vec<_> = if taps.is_empty() {
        vec![None]
    } else {
        taps.iter().map(|t| Some(*t)).collect()
    };
    let texel_mm: Vec<_> = if texel_mm.is_empty() {
        vec![None]
    } else {
        texel_mm.iter().map(|d| Some(*d)).collect()
    };
    let passes: Vec<_> = if passes.is_empty() {
        vec![None]
    } else {
        passes.iter().map(|p| Some(*p)).collect()
    };
    let mut out = Vec::new();
    for t in &taps {
        for d in &texel_mm {
            for p in &passes {
                out.push(LateralRun {
                    taps: *t,
                    texel_mm: *d,
                    pass: *p,
                });
            }
        }
    }
    out
}

/// One diffusion run's lateral settings (`None`: the scene's own).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct LateralRun {
    taps: Option<u32>,
    texel_mm: Option<f32>,
    pass: Option<LateralPass>,
}

#[derive(Serialize)]
struct Report {
    adapter: String,
    warmup: u32,
    frames: u32,
    rounds: u32,
    /// `--bandwidth`, GB/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    bandwidth_gbps: Option<f64>,
    /// `--flip-vs`: the fixed-tap count the FLIP figures compare with.
    #[serde(skip_serializing_if = "Option::is_none")]
    flip_vs: Option<u32>,
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

/// Gives the scattering objects `n` distinct profiles in turn: the material presets (skin
/// first), then skin again with a slightly different kernel strength for each further one, so
/// that every one is its own row of the profile table.
fn distinct_profiles(scene: &mut Scene, n: u32) {
    if n <= 1 {
        return;
    }
    let names = subsurface_profile::material_names();
    let mut k = 0usize;
    for i in 0..scene.objects.len() {
        if scene.objects[i].material.sss_strength <= 0.0 {
            continue;
        }
        let p = k % n as usize;
        k += 1;
        let edit = |m: &mut subsurface_render::scene::MaterialDesc| {
            if p < names.len() {
                m.medium = Medium::Preset(names[p].to_string());
            } else {
                m.medium = Medium::default();
                let s = 1.0 - 0.01 * p as f32;
                m.kernel_strength = Some([0.48 * s, 0.41 * s, 0.28 * s]);
            }
        };
        edit(&mut scene.objects[i].material);
        edit(&mut scene.desc.objects[i].material);
    }
}

/// Passes that belong to subsurface scattering (screen or texture space).
fn is_sss_pass(name: &str) -> bool {
    name == "sss" || name.starts_with("texture")
}

/// GPU time of the subsurface-scattering passes among `passes`.
fn sss_ms(passes: &[PassTiming]) -> f64 {
    // A fold from +0.0, not `sum` (which starts at -0.0): no SSS pass prints as 0.000.
    passes
        .iter()
        .filter(|p| is_sss_pass(&p.name))
        .map(|p| p.ms)
        .fold(0.0, |a, b| a + b)
}

pub fn run(args: &BenchArgs) -> Result<()> {
    anyhow::ensure!(
        args.frames >= 1,
        "--frames: must be at least 1 (got {})",
        args.frames
    );
    anyhow::ensure!(
        (1..=100).contains(&args.rounds),
        "--rounds: must be in 1..=100 (got {})",
        args.rounds
    );
    if let Some(b) = args.bandwidth {
        anyhow::ensure!(
            b.is_finite() && b > 0.0,
            "--bandwidth: must be finite and > 0 (got {b})"
        );
    }
    if let Some(n) = args.flip_vs {
        let fixed = subsurface_render::SssSettings {
            samples: n,
            ..Default::default()
        };
        if let Err(e) = fixed.validate() {
            anyhow::bail!("--flip-vs: {}", e.message);
        }
    }
    for &c in &args.characters {
        anyhow::ensure!(
            (1..=256).contains(&c),
            "--characters: each must be in 1..=256 (got {c})"
        );
    }
    let sizes = match (args.width, args.height) {
        (Some(w), Some(h)) => vec![
            parse_size(&format!("{w}x{h}"))
                .map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?,
        ],
        _ => args.sizes.clone(),
    };
    let base = load_scene(args.scene.as_ref(), args.model.as_ref())?;
    let ctx = GpuContext::new_headless()?;
    anyhow::ensure!(
        ctx.has_timestamps(),
        "{}: the adapter has no timestamp queries",
        ctx.adapter_name()
    );
    let pending_plot = args
        .plot
        .as_ref()
        .map(|p| PendingFile::create(p))
        .transpose()?;
    for &p in &args.profiles {
        anyhow::ensure!(
            (1..=256).contains(&p),
            "--profiles: each must be in 1..=256 (got {p})"
        );
    }
    let all_lights = base.desc.lights.len() as u32;
    let light_counts = if args.lights.is_empty() {
        vec![all_lights]
    } else {
        args.lights.clone()
    };
    if let Some(n) = light_counts.iter().find(|n| **n > all_lights) {
        anyhow::bail!("--lights: {n} is more than the scene's {all_lights} lights");
    }
    let diffusion = lateral_counts(
        TransmittanceMethod::Diffusion,
        &args.lateral_taps,
        &args.lateral_texel_mm,
        &[],
    );
    for LateralRun { taps, texel_mm, .. } in diffusion {
        let mut t = subsurface_render::TransmittanceSettings::default();
        if let Some(taps) = taps {
            t.lateral_taps = taps;
        }
        if let Some(mm) = texel_mm {
            t.lateral_texel_mm = mm;
        }
        t.validate()
            .map_err(|e| anyhow::anyhow!("--{}: {}", e.field.replace('_', "-"), e.message))?;
    }
    let rings: Vec<Option<u32>> = if args.bounce_ring.is_empty() {
        vec![None]
    } else {
        args.bounce_ring.iter().map(|r| Some(*r)).collect()
    };
    for ring in rings.iter().flatten() {
        subsurface_render::BounceSettings {
            ring: *ring,
            ..Default::default()
        }
        .validate()
        .map_err(|e| anyhow::anyhow!("--bounce-ring: {}", e.message))?;
    }
    let configs = sizes.len()
        * light_counts.len()
        * args.characters.len()
        * args.profiles.len()
        * args.sss.len()
        * args.fetch.len()
        * rings.len()
        * args
            .transmittance
            .iter()
            .map(|tm| {
                lateral_counts(
                    *tm,
                    &args.lateral_taps,
                    &args.lateral_texel_mm,
                    &args.lateral_pass,
                )
                .len()
            })
            .sum::<usize>();
    let bar = indicatif::ProgressBar::new(
        configs as u64 * (args.warmup + args.frames) as u64 * args.rounds as u64,
    )
    .with_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames {msg}")
            .expect("static template"),
    );
    // Every configuration first, so that `--rounds` can measure them in turn.
    let mut scenes = Vec::new();
    let mut plans = Vec::new();
    let counts = args.characters.iter().flat_map(|n| {
        let lights = &light_counts;
        args.profiles
            .iter()
            .flat_map(move |p| lights.iter().map(move |l| (*n, *p, *l)))
    });
    for (n, profiles, lights) in counts {
        let mut scene = replicate(&base, n);
        scene.desc.lights.truncate(lights as usize);
        distinct_profiles(&mut scene, profiles);
        for &(w, h) in &sizes {
            ctx.check_size("--sizes ", w, h)?;
            let methods = args.sss.iter().flat_map(|m| {
                // The fetch only matters to the screen-space methods.
                let fetches = if m.is_screen_space() {
                    args.fetch.clone()
                } else {
                    vec![args.fetch[0]]
                };
                fetches.into_iter().map(move |f| (*m, f))
            });
            for (method, fetch) in methods {
                let transmittances = args.transmittance.iter().flat_map(|tm| {
                    lateral_counts(
                        *tm,
                        &args.lateral_taps,
                        &args.lateral_texel_mm,
                        &args.lateral_pass,
                    )
                    .into_iter()
                    .flat_map(|lateral| rings.iter().map(move |r| (lateral, *r)))
                    .map(move |(lateral, ring)| (*tm, lateral, ring))
                });
                for (tm, lateral, ring) in transmittances {
                    let mut opts = RenderOptions::from_scene(&scene);
                    let s = &mut opts.settings;
                    if let Some(ring) = ring {
                        s.bounce.ring = ring;
                    }
                    if let Some(taps) = lateral.taps {
                        s.transmittance.lateral_taps = taps;
                    }
                    if let Some(mm) = lateral.texel_mm {
                        s.transmittance.lateral_texel_mm = mm;
                    }
                    if let Some(pass) = lateral.pass {
                        s.transmittance.lateral_pass = pass;
                    }
                    (s.width, s.height) = (w, h);
                    s.sss.method = method;
                    s.sss.samples = args.samples;
                    s.sss.jitter = args.jitter;
                    s.sss.fetch = fetch;
                    s.transmittance.method = tm;
                    opts.baseline_copy = true;
                    plans.push(Plan {
                        scene: scenes.len(),
                        characters: n,
                        lights,
                        method,
                        fetch,
                        transmittance: tm,
                        opts,
                    });
                }
            }
        }
        scenes.push(scene);
    }
    let mut samples: Vec<Vec<Vec<PassTiming>>> = plans.iter().map(|_| Vec::new()).collect();
    let mut round_frame_ms: Vec<Vec<f64>> = plans.iter().map(|_| Vec::new()).collect();
    let mut runs = Vec::new();
    for round in 0..args.rounds {
        for (i, plan) in plans.iter().enumerate() {
            let (n, tm, method) = (plan.characters, plan.transmittance, plan.method);
            let (w, h) = (plan.opts.settings.width, plan.opts.settings.height);
            bar.set_message(format!("{n} x {w}x{h} {method} {tm}"));
            let scene = &scenes[plan.scene];
            let mut renderer =
                Renderer::new(&ctx, scene, plan.opts.clone()).context("creating the renderer")?;
            let mut frames = Vec::new();
            for f in 0..args.warmup + args.frames {
                let t = renderer.render_timed()?;
                if f >= args.warmup {
                    frames.push(t);
                }
                bar.inc(1);
            }
            round_frame_ms[i].push(median(frames.iter().map(|f| frame_sum(f)).collect()));
            samples[i].extend(frames);
            if round + 1 < args.rounds {
                continue;
            }
            // The last round: everything that needs the renderer, then the run.
            let opts = &plan.opts;
            let sss_settings = opts.settings.sss.clone();
            let mut run = summarise(std::mem::take(&mut samples[i]), n, w, h, method, tm);
            run.round_frame_ms = std::mem::take(&mut round_frame_ms[i]);
            run.lateral_taps = (tm == TransmittanceMethod::Diffusion)
                .then_some(opts.settings.transmittance.lateral_taps);
            if tm == TransmittanceMethod::Diffusion {
                run.lateral_texel_mm = Some(opts.settings.transmittance.lateral_texel_mm);
                run.lateral_downsample = Some(renderer.targets.lateral_downsample());
                run.lateral_pass = renderer.targets.lateral_computed().map(|computed| {
                    if computed {
                        LateralPass::Compute.name()
                    } else {
                        LateralPass::Fragment.name()
                    }
                });
            }
            run.profiles = renderer.profile_table().kernels.len() as u32;
            run.bounce_ring = opts.settings.bounce.ring;
            run.lights = plan.lights;
            (run.samples, run.jitter) = (args.samples, args.jitter);
            run.fetch = plan.fetch.name();
            run.traffic = traffic_of(&run, &sss_settings, args.bandwidth);
            if let (Some(fixed), SssMethod::Separable) = (args.flip_vs, method) {
                let ours = renderer.render()?.image;
                let skin: Vec<bool> = renderer.read_sss()?.iter().map(|m| m[0] > 0.0).collect();
                let mut o = opts.clone();
                (o.settings.sss.samples, o.settings.sss.jitter) = (fixed, false);
                let reference = Renderer::new(&ctx, scene, o)
                    .context("--flip-vs")?
                    .render()?
                    .image;
                let (all, on_skin) = flip_means(&reference, &ours, &skin);
                (run.flip_vs_fixed, run.flip_vs_fixed_skin) = (Some(all), on_skin);
            }
            runs.push(run);
        }
    }
    bar.finish_and_clear();
    let report = Report {
        adapter: ctx.adapter_name(),
        warmup: args.warmup,
        frames: args.frames,
        rounds: args.rounds,
        bandwidth_gbps: args.bandwidth,
        flip_vs: args.flip_vs,
        runs,
    };
    // With the plot on stdout (`--plot -`), the table goes to stderr.
    let stdout_taken = pending_plot
        .as_ref()
        .is_some_and(PendingFile::writes_to_stdout);
    if let Some(p) = pending_plot {
        plot(p, &report)?;
    }
    let text = if args.json {
        format!("{}\n", serde_json::to_string_pretty(&report)?)
    } else {
        table(&report)
    };
    print_summary(stdout_taken, &text);
    Ok(())
}

/// One configuration `run` measures: the scene (an index into its replicated scenes) and the
/// options it renders with.
struct Plan {
    scene: usize,
    characters: u32,
    lights: u32,
    method: SssMethod,
    fetch: SssFetch,
    transmittance: TransmittanceMethod,
    opts: RenderOptions,
}

/// A frame's GPU time: its passes, the copy baseline left out.
fn frame_sum(frame: &[PassTiming]) -> f64 {
    frame
        .iter()
        .filter(|t| t.name != "copy")
        .map(|t| t.ms)
        .sum()
}

fn summarise(
    samples: Vec<Vec<PassTiming>>,
    n: u32,
    w: u32,
    h: u32,
    method: SssMethod,
    tm: TransmittanceMethod,
) -> Run {
    let mut names: Vec<String> = Vec::new();
    for t in samples.iter().flatten() {
        if !names.contains(&t.name) {
            names.push(t.name.clone());
        }
    }
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
    let frame_ms = median(samples.iter().map(|f| frame_sum(f)).collect());
    let sss_ms = sss_ms(&passes);
    Run {
        characters: n,
        profiles: 1,
        lights: 0,
        width: w,
        height: h,
        sss: method.name(),
        fetch: "",
        transmittance: tm.name().to_string(),
        lateral_taps: None,
        lateral_texel_mm: None,
        lateral_downsample: None,
        lateral_pass: None,
        bounce_ring: 0,
        frame_ms,
        round_frame_ms: Vec::new(),
        passes,
        copy_ms,
        sss_over_copy: (sss_ms > 0.0 && copy_ms > 0.0).then(|| sss_ms / copy_ms),
        samples: 0,
        jitter: false,
        flip_vs_fixed: None,
        flip_vs_fixed_skin: None,
        traffic: Vec::new(),
    }
}

fn table(report: &Report) -> String {
    let mut out = if report.rounds > 1 {
        format!(
            "{} — median of {} rounds x {} frames, each after {} warm-up, configurations in turn\n",
            report.adapter, report.rounds, report.frames, report.warmup
        )
    } else {
        format!(
            "{} — median of {} frames after {} warm-up\n",
            report.adapter, report.frames, report.warmup
        )
    };
    out += &format!(
        "{:>5} {:>8} {:>6} {:>10} {:>10} {:>9} {:>17} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}\n",
        "chars",
        "profiles",
        "lights",
        "size",
        "sss",
        "fetch",
        "transm.",
        "frame ms",
        "shadow",
        "lateral",
        "bounce",
        "lighting",
        "sss ms",
        "sss/copy"
    );
    for r in &report.runs {
        let p = |n: &str| r.passes.iter().find(|p| p.name == n).map_or(0.0, |p| p.ms);
        let sss = sss_ms(&r.passes);
        out += &format!(
            "{:>5} {:>8} {:>6} {:>10} {:>10} {:>9} {:>17} {:>10.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9}\n",
            r.characters,
            r.profiles,
            r.lights,
            format!("{}x{}", r.width, r.height),
            r.sss,
            r.fetch,
            r.transmittance_label(),
            r.frame_ms,
            p("shadow"),
            p("lateral"),
            p("bounce build") + p("bounce"),
            p("lighting"),
            sss,
            r.sss_over_copy.map_or("-".into(), |x| format!("{x:.2}")),
        );
    }
    if let Some(n) = report.flip_vs {
        out += &format!("\nFLIP mean of the frame against {n} fixed taps (separable runs)\n");
        for r in report.runs.iter().filter(|r| r.flip_vs_fixed.is_some()) {
            out += &format!(
                "{:>10} {} taps{}: {:.4} (skin pixels: {})\n",
                format!("{}x{}", r.width, r.height),
                r.samples,
                if r.jitter { " jittered" } else { "" },
                r.flip_vs_fixed.unwrap_or(0.0),
                r.flip_vs_fixed_skin
                    .map_or("-".into(), |f| format!("{f:.4}"))
            );
        }
    }
    out + &per_light(report) + &traffic_table(report)
}

/// With several `--lights` counts: the lighting and shadow passes' cost per light, the slope
/// between the fewest and the most lights of runs that differ in nothing else.
fn per_light(report: &Report) -> String {
    let mut out = String::new();
    let same = |a: &Run, b: &Run| {
        (a.characters, a.profiles, a.width, a.height, a.sss, a.fetch)
            == (b.characters, b.profiles, b.width, b.height, b.sss, b.fetch)
            && (
                &a.transmittance,
                a.lateral_taps,
                a.lateral_downsample,
                a.bounce_ring,
            ) == (
                &b.transmittance,
                b.lateral_taps,
                b.lateral_downsample,
                b.bounce_ring,
            )
    };
    let pass = |r: &Run, n: &str| r.passes.iter().find(|p| p.name == n).map_or(0.0, |p| p.ms);
    for (i, r) in report.runs.iter().enumerate() {
        // Each group once, from its first run.
        if report.runs[..i].iter().any(|o| same(o, r)) {
            continue;
        }
        let group: Vec<&Run> = report.runs.iter().filter(|o| same(o, r)).collect();
        let fewest = group
            .iter()
            .min_by_key(|r| r.lights)
            .expect("r is in its group");
        let most = group
            .iter()
            .max_by_key(|r| r.lights)
            .expect("r is in its group");
        if fewest.lights == most.lights {
            continue;
        }
        if out.is_empty() {
            out += "\ncost per light (slope between the fewest and the most lights)\n";
        }
        let k = f64::from(most.lights - fewest.lights);
        let slope = |n: &str| (pass(most, n) - pass(fewest, n)) / k;
        out += &format!(
            "{:>10} {:>10} {:>10} lights {}..{}: lighting {:.3} ms, shadow {:.3} ms per light\n",
            format!("{}x{}", r.width, r.height),
            r.sss,
            r.transmittance_label(),
            fewest.lights,
            most.lights,
            slope("lighting"),
            slope("shadow"),
        );
    }
    out
}

const PLOT_SIZE: (u32, u32) = (900, 560);

/// Frame time (solid) and SSS time (dashed) against the number of characters, per method.
fn plot(pending: PendingFile, report: &Report) -> Result<()> {
    let img = plot::draw_image(PLOT_SIZE, |root| draw(root, report)).context("--plot")?;
    pending.write_png(&image::DynamicImage::ImageRgb8(img).to_rgba8())
}

fn draw(root: &plot::Area, report: &Report) -> plot::DrawResult {
    let max_n = report
        .runs
        .iter()
        .map(|r| r.characters)
        .max()
        .unwrap_or(1)
        .max(2) as f64;
    let max_ms = report
        .runs
        .iter()
        .map(|r| r.frame_ms)
        .fold(0.0, f64::max)
        .max(1e-3)
        * 1.1;
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("GPU time vs characters — {}", report.adapter),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_n * 1.05, 0.0..max_ms)?;
    chart
        .configure_mesh()
        .x_desc("characters")
        .y_desc("ms (solid: frame, dashed: SSS)")
        .draw()?;
    let mut keys: Vec<(&str, String, u32, u32)> = Vec::new();
    for r in &report.runs {
        let k = (r.sss, r.transmittance_label(), r.width, r.height);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (i, (sss, tm, w, h)) in keys.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let pts: Vec<&Run> = report
            .runs
            .iter()
            .filter(|r| {
                r.sss == *sss && &r.transmittance_label() == tm && r.width == *w && r.height == *h
            })
            .collect();
        let frame = pts.iter().map(|r| (r.characters as f64, r.frame_ms));
        plot::line(&mut chart, frame, colour, format!("{sss} {tm} {w}x{h}"))?;
        let sss = pts.iter().map(|r| (r.characters as f64, sss_ms(&r.passes)));
        plot::dashed(&mut chart, sss, colour, (6, 4))?;
    }
    // plotters' default size for legend text.
    plot::legend(&mut chart, 12)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid keeps the characters' footprint: n copies, each 1/columns the size, inside
    /// the original bounds (plus rounding).
    #[test]
    fn replicated_characters_cover_the_same_area() {
        let scene = Scene::default_scene();
        let (lo, hi) = scene.bounds();
        for n in [1, 2, 4, 9, 16] {
            let grid = replicate(&scene, n);
            assert_eq!(grid.objects.len(), scene.objects.len() * n as usize);
            let (glo, ghi) = grid.bounds();
            let slack = (hi - lo) * 0.05;
            assert!(
                glo.cmpge(lo - slack).all() && ghi.cmple(hi + slack).all(),
                "n={n}: {glo}..{ghi} vs {lo}..{hi}"
            );
            let cols = (n as f32).sqrt().ceil();
            let (clo, chi) = grid.objects[0].world_bounds();
            let (olo, ohi) = scene.objects[0].world_bounds();
            assert!(
                (((chi - clo).length() / (ohi - olo).length()) - 1.0 / cols).abs() < 1e-3,
                "n={n}: copy not scaled by 1/{cols}"
            );
        }
    }
}
