//! `subsurface bench`: GPU time per pass (timestamp queries), medians over many frames, for
//! each image size, number of characters, SSS method and transmittance method.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use subsurface_profile::Medium;
use subsurface_render::settings::Quality;
use subsurface_render::{
    BounceSettings, GpuContext, MapEvaluation, PassTiming, RenderOptions, RenderSettings, Renderer,
    Scene, SssFetch, SssMethod, TransmittanceMethod,
};

use crate::output::{PendingFile, print_summary};
use crate::settings_args::{load_scene, replicate};
use axes::{Axis, combinations, flag_axis};
use memory::{flip_means, traffic_of};
use report::{
    FlipVsFixed, Report, Run, SkinCost, frame_sum, median, plot, sss_ms, summarise, table,
};

mod axes;
mod memory;
mod report;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file (default: the embedded default scene, the hand and the wedge).
    scene: Option<PathBuf>,
    /// Replace the scene's objects by this glTF/GLB model.
    #[arg(long, value_name = "FILE.glb")]
    model: Option<PathBuf>,
    #[command(flatten)]
    size: SizeArgs,
    /// Numbers of characters (copies of the scene's objects, in a grid covering about the
    /// same screen area at every count), comma-separated.
    #[arg(long, default_value = "1", value_delimiter = ',')]
    characters: Vec<u32>,
    /// Quality presets to measure, comma-separated (low, medium, high): each its bundle of
    /// settings with the scene's own keys and --set over it [default: the scene's].
    #[arg(long, value_delimiter = ',', value_name = "PRESET,..")]
    quality: Vec<Quality>,
    /// SSS methods to measure, comma-separated (none, gaussian6, separable, hable13,
    /// texture); short for --vary render.sss.method=.. [default: the scene's].
    #[arg(long, value_delimiter = ',', value_name = "METHOD,..")]
    sss: Vec<SssMethod>,
    /// Transmittance methods to measure, comma-separated (e.g. paper,off for the cost of
    /// transmittance side by side); short for --vary render.transmittance.method=..
    /// [default: the scene's].
    #[arg(long, value_delimiter = ',', value_name = "METHOD,..")]
    transmittance: Vec<TransmittanceMethod>,
    /// Diffusion runs: numbers of lateral shadow-map taps (0..=32), comma-separated, e.g. 0,12
    /// for what gathering the light around the chord costs against the chord's slab alone
    /// [default: the scene's render.transmittance.lateral_taps].
    #[arg(long, value_delimiter = ',', value_name = "N,..")]
    lateral_taps: Vec<u32>,
    /// Diffusion runs: the transmitted map's texel sizes in profile millimetres (0..=50),
    /// comma-separated, e.g. 0,2 for `diffusion` at every pixel inside the lighting pass against
    /// the transmitted map [default: the scene's render.transmitted_map.texel_mm].
    /// The table names each run by the reduction it gave (`diffusion/12:4`: 12 taps, one
    /// texel per 4x4 pixels).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "MM,..",
        alias = "lateral-texel-mm"
    )]
    map_texel_mm: Vec<f32>,
    /// Diffusion runs: how the transmitted map is evaluated, compute, fragment and/or auto
    /// (compute on GPUs, fragment on CPU adapters), comma-separated; the same map, so
    /// `compute,fragment` compares their cost [default: the scene's
    /// render.transmitted_map.pass]. The table marks fragment runs (`diffusion/12:8 frag`).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "PASS,..",
        alias = "lateral-pass"
    )]
    map_pass: Vec<MapEvaluation>,
    /// The bounce's ring (0..=8; 0 = off), comma-separated, e.g. 0,2 for what gathering the
    /// light between parts costs [default: the scene's render.bounce.ring]. The table names
    /// each run's ring after its transmittance (`paper b2`).
    #[arg(long, value_delimiter = ',', value_name = "N,..")]
    bounce_ring: Vec<u32>,
    /// Numbers of distinct diffusion profiles on screen, comma-separated: the objects (with
    /// --characters, the copies) take the material presets in turn, so the cost of a profile
    /// per material shows beside one profile for all.
    #[arg(long, default_value = "1", value_delimiter = ',', value_name = "N,..")]
    profiles: Vec<u32>,
    /// How the screen-space passes fetch a tap's texels, comma-separated: packed (one
    /// Rgba32Uint texel per texel, after a pack step), workgroup (separable's passes as
    /// compute shaders reading workgroup memory, the first packing as it loads) and/or direct
    /// (colour, depth and SSS textures per texel); the same image, so `packed,workgroup,direct`
    /// compares their cost.
    /// Short for --vary render.sss.fetch=.. [default: the scene's].
    #[arg(long, value_delimiter = ',', value_name = "FETCH,..")]
    fetch: Vec<SssFetch>,
    /// Numbers of the scene's lights to keep (its first N), comma-separated, e.g. 1,5 on the
    /// head: the table then gives the lighting and shadow passes' cost per light (the slope
    /// between the smallest and the largest N) [default: all of the scene's lights].
    #[arg(long, value_delimiter = ',', value_name = "N,..")]
    lights: Vec<u32>,
    /// Separable kernel taps [default: the scene's render.sss.samples].
    #[arg(long, value_name = "N")]
    samples: Option<u32>,
    /// Separable: jitter the taps per pixel (the few-sample mode, e.g. --samples 7 --jitter).
    #[arg(long)]
    jitter: bool,
    /// Separable runs: also render the frame with N fixed taps and report the FLIP mean (LDR)
    /// of the measured settings against it, over the whole frame and over the skin pixels, e.g.
    /// --samples 7 --jitter --flip-vs 33 for the quality the few-sample mode gives up.
    #[arg(long, value_name = "N")]
    flip_vs: Option<u32>,
    /// Memory bandwidth of the adapter in GB/s (10^9 bytes/s): prints each modelled pass's
    /// time against the time its compulsory bytes take at that rate (1 = at the memory limit).
    #[arg(long, value_name = "GBPS")]
    bandwidth: Option<f64>,
    /// Any setting of the scene's `[render]` table, for every run: --set KEY=VALUE as `render`
    /// takes it (after the flags above; `subsurface settings` lists the keys).
    #[arg(long = "set", value_name = "KEY=VALUE", value_parser = crate::settings_args::parse_key_value)]
    set: Vec<(String, String)>,
    /// Any setting as an axis: --vary KEY=V1,V2 measures each value (e.g. --vary
    /// render.sss.samples=7,17 --vary render.bounce.ring=0,2 measures four configurations);
    /// after the method flags, the last varying fastest. A value of a key that does not matter
    /// to a configuration (the separable taps of hable13) is measured once.
    #[arg(long = "vary", value_name = "KEY=V1,V2,..", value_parser = axes::parse_axis)]
    vary: Vec<Axis>,
    /// Frames rendered and thrown away before timing (shader compilation, caches).
    #[arg(long, default_value_t = 5)]
    warmup: u32,
    /// Timed frames; the median of each pass is reported.
    #[arg(long, default_value_t = 30)]
    frames: u32,
    /// Measure every configuration this many times in turn (A, B, A, B, ...), each round with
    /// its own warm-up and frames, and report the median over all rounds' frames: a machine
    /// whose speed drifts over minutes (a CPU driver, a laptop's clocks) then shifts every
    /// configuration alike instead of whichever ran last. JSON gives each round's frame time.
    #[arg(long, default_value_t = 1, value_name = "N")]
    rounds: u32,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Draw GPU time against the number of characters, one line per method; `-` writes the
    /// PNG to standard output and the table to standard error.
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
}

/// The image sizes to measure.
#[derive(Args, Debug)]
struct SizeArgs {
    /// Image width; with --height, a single size instead of --sizes.
    #[arg(long, requires = "height")]
    width: Option<u32>,
    /// Image height; with --width, a single size instead of --sizes.
    #[arg(long, requires = "width")]
    height: Option<u32>,
    /// Image sizes to measure, WxH, comma-separated.
    #[arg(long, default_value = "1280x720,1920x1080", value_delimiter = ',', value_parser = parse_size)]
    sizes: Vec<(u32, u32)>,
}

impl SizeArgs {
    /// `--width` x `--height` where both are given, else `--sizes`.
    fn sizes(&self) -> Result<Vec<(u32, u32)>> {
        Ok(match (self.width, self.height) {
            (Some(w), Some(h)) => vec![
                parse_size(&format!("{w}x{h}"))
                    .map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?,
            ],
            _ => self.sizes.clone(),
        })
    }
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
    for &p in &args.profiles {
        anyhow::ensure!(
            (1..=256).contains(&p),
            "--profiles: each must be in 1..=256 (got {p})"
        );
    }
    let sizes = args.size.sizes()?;
    let base = load_scene(args.scene.as_ref(), args.model.as_ref())?;
    let settings = base_settings(&base.desc.render, args)?;
    let keep: Vec<(String, String)> = base
        .desc
        .render_keys
        .0
        .iter()
        .chain(&args.set)
        .cloned()
        .collect();
    let configurations = combinations(&settings, &axes_of(args), &keep)?;
    let all_lights = base.desc.lights.len() as u32;
    let light_counts = if args.lights.is_empty() {
        vec![all_lights]
    } else {
        args.lights.clone()
    };
    if let Some(n) = light_counts.iter().find(|n| **n > all_lights) {
        anyhow::bail!("--lights: {n} is more than the scene's {all_lights} lights");
    }
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
    // Every configuration first, so that `--rounds` can measure them in turn. Each scene and
    // size also renders once without any skin effect: the skin's cost is the difference.
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
            let plan = |settings: &RenderSettings, values, bare| {
                let mut opts = RenderOptions::from_scene(&scene);
                opts.settings = settings.clone();
                (opts.settings.width, opts.settings.height) = (w, h);
                opts.baseline_copy = true;
                Plan {
                    scene: scenes.len(),
                    characters: n,
                    lights,
                    values,
                    bare,
                    opts,
                }
            };
            let bare = plans.len();
            plans.push(plan(&without_skin(&settings), Vec::new(), None));
            for c in &configurations {
                plans.push(plan(&c.settings, c.values.clone(), Some(bare)));
            }
        }
        scenes.push(scene);
    }
    // Every configuration within the memory budget before any is measured, so that a list
    // of sizes fails at once rather than after the small ones.
    for plan in &plans {
        subsurface_render::budget::check(&scenes[plan.scene], &plan.opts.settings)?;
    }
    let bar = indicatif::ProgressBar::new(
        plans.len() as u64 * (args.warmup + args.frames) as u64 * args.rounds as u64,
    )
    .with_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames {msg}")
            .expect("static template"),
    );
    let mut samples: Vec<Vec<Vec<PassTiming>>> = plans.iter().map(|_| Vec::new()).collect();
    let mut round_frame_ms: Vec<Vec<f64>> = plans.iter().map(|_| Vec::new()).collect();
    // Each plan's run, in plan order (the bare frames' too, left out of the report).
    let mut runs: Vec<Option<Run>> = plans.iter().map(|_| None).collect();
    for round in 0..args.rounds {
        for (i, plan) in plans.iter().enumerate() {
            let s = &plan.opts.settings;
            bar.set_message(format!(
                "{} x {}x{} {} {}",
                plan.characters, s.width, s.height, s.sss.method, s.transmittance.method
            ));
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
            if round + 1 == args.rounds {
                let mut run = summarise(std::mem::take(&mut samples[i]), plan.characters, s);
                run.round_frame_ms = std::mem::take(&mut round_frame_ms[i]);
                describe(&mut run, plan, &mut renderer, args, &ctx, scene)?;
                runs[i] = Some(run);
            }
        }
    }
    bar.finish_and_clear();
    // The skin's cost against the same scene and size's frame without it.
    let bare_ms: Vec<Option<f64>> = runs
        .iter()
        .map(|r| r.as_ref().map(|r| r.frame_ms))
        .collect();
    let mut report_runs = Vec::new();
    for (plan, run) in plans.iter().zip(runs) {
        let (Some(bare), Some(mut run)) = (plan.bare, run) else {
            continue;
        };
        if let Some(base) = bare_ms[bare].filter(|b| *b > 0.0) {
            run.skin = Some(SkinCost {
                skin_ms: run.frame_ms - base,
                skin_share: (run.frame_ms - base) / base,
            });
        }
        report_runs.push(run);
    }
    let report = Report {
        adapter: ctx.adapter_name(),
        warmup: args.warmup,
        frames: args.frames,
        rounds: args.rounds,
        bandwidth_gbps: args.bandwidth,
        flip_vs: args.flip_vs,
        runs: report_runs,
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

/// The scene's settings with `--samples`, `--jitter` and `--set` applied: what every run
/// starts from.
fn base_settings(scene: &RenderSettings, args: &BenchArgs) -> Result<RenderSettings> {
    let mut s = scene.clone();
    if let Some(n) = args.samples {
        s.set("sss.samples", &n.to_string())
            .map_err(|e| anyhow::anyhow!("--samples: {}", e.message))?;
    }
    s.sss.jitter |= args.jitter;
    for (key, value) in &args.set {
        s.set(key, value)
            .map_err(|e| anyhow::anyhow!("--set {e}"))?;
    }
    Ok(s)
}

/// The axes the flags ask for: the method flags' first (in the order of the frame), then
/// `--vary`'s.
fn axes_of(args: &BenchArgs) -> Vec<Axis> {
    [
        flag_axis("--quality", "quality", &args.quality),
        flag_axis("--sss", "sss.method", &args.sss),
        flag_axis("--fetch", "sss.fetch", &args.fetch),
        flag_axis(
            "--transmittance",
            "transmittance.method",
            &args.transmittance,
        ),
        flag_axis(
            "--lateral-taps",
            "transmittance.lateral_taps",
            &args.lateral_taps,
        ),
        flag_axis(
            "--map-texel-mm",
            "transmitted_map.texel_mm",
            &args.map_texel_mm,
        ),
        flag_axis("--map-pass", "transmitted_map.pass", &args.map_pass),
        flag_axis("--bounce-ring", "bounce.ring", &args.bounce_ring),
    ]
    .into_iter()
    .flatten()
    .chain(args.vary.iter().cloned())
    .collect()
}

/// `s` without any skin effect: no scattering, no transmittance, no bounce, and no thin parts'
/// reflectance, which `--sss none` keeps (it changes how much a thin part reflects, not where)
/// and which costs the back faces' pass and its term in the lighting pass.
fn without_skin(s: &RenderSettings) -> RenderSettings {
    let mut bare = s.clone();
    bare.sss.method = SssMethod::None;
    bare.sss.thin_parts = false;
    bare.transmittance.method = TransmittanceMethod::Off;
    bare.bounce = BounceSettings::OFF;
    bare
}

/// Fills in what a run reports beyond its times: the transmitted map it got, the profiles, the
/// varied keys, the byte model and, with `--flip-vs`, the quality against fixed taps.
fn describe(
    run: &mut Run,
    plan: &Plan,
    renderer: &mut Renderer,
    args: &BenchArgs,
    ctx: &GpuContext,
    scene: &Scene,
) -> Result<()> {
    let s = &plan.opts.settings;
    if s.transmittance.method == TransmittanceMethod::Diffusion {
        run.lateral_taps = Some(s.transmittance.lateral_taps);
        run.map_texel_mm = Some(s.transmitted_map.texel_mm);
        run.map_downsample = Some(renderer.targets.map_downsample());
        run.map_pass = renderer.targets.map_computed().map(|computed| {
            if computed {
                MapEvaluation::Compute.name()
            } else {
                MapEvaluation::Fragment.name()
            }
        });
    }
    run.profiles = renderer.profile_table().kernels.len() as u32;
    run.lights = plan.lights;
    run.varied = plan.values.iter().cloned().collect::<BTreeMap<_, _>>();
    let times = [sss_ms(&run.passes), run.copy_ms];
    let sss = (&s.sss, renderer.sss_pass().pack_on_load());
    run.traffic = traffic_of((run.width, run.height), sss, times, args.bandwidth);
    if let (Some(fixed), SssMethod::Separable) = (args.flip_vs, s.sss.method) {
        let ours = renderer.render()?.image;
        let skin: Vec<bool> = renderer.read_sss()?.iter().map(|m| m[0] > 0.0).collect();
        let mut o = plan.opts.clone();
        (o.settings.sss.samples, o.settings.sss.jitter) = (fixed, false);
        let reference = Renderer::new(ctx, scene, o)
            .context("--flip-vs")?
            .render()?
            .image;
        let (flip_vs_fixed, flip_vs_fixed_skin) = flip_means(&reference, &ours, &skin);
        run.flip = Some(FlipVsFixed {
            flip_vs_fixed,
            flip_vs_fixed_skin,
        });
    }
    Ok(())
}

/// One configuration `run` measures: the scene (an index into its replicated scenes), the
/// options it renders with, the varied keys' values and the plan of its frame without skin
/// effects (`None`: this is that frame).
struct Plan {
    scene: usize,
    characters: u32,
    lights: u32,
    values: Vec<(String, String)>,
    bare: Option<usize>,
    opts: RenderOptions,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bare frame runs none of the skin's passes or terms at any preset: no blur, no
    /// transmitted map, no bounce, no thin parts (whose back faces' pass `--sss none` alone
    /// keeps), so `skin_ms` holds all of them.
    #[test]
    fn the_bare_frame_has_no_skin_pass_or_term() {
        use subsurface_render::frame_plan::{AdapterFeatures, FramePlan};
        use subsurface_render::passes::overrides::Terms;
        let scene = Scene::default_scene();
        for quality in Quality::ALL {
            let bare = without_skin(&RenderSettings::preset(quality));
            let plan = FramePlan::new(&scene, &bare, AdapterFeatures::ALL);
            assert_eq!(bare.sss.method, SssMethod::None, "{quality:?}");
            assert!(
                !plan.thin_parts(),
                "{quality:?}: thin parts in the bare frame"
            );
            assert_eq!(plan.map.layers, 0, "{quality:?}: a transmitted map");
            assert_eq!(plan.bounce_ring, 0, "{quality:?}: the bounce");
            assert_eq!(
                plan.lighting.method,
                TransmittanceMethod::Off.code(),
                "{quality:?}: transmittance"
            );
            let skin_terms = Terms::THIN_PARTS | Terms::SOURCE_SHIFT;
            assert_eq!(
                plan.lighting.terms.0 & skin_terms,
                0,
                "{quality:?}: {:?}",
                plan.lighting.terms
            );
        }
    }

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
