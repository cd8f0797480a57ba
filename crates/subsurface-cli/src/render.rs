//! `subsurface render`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use subsurface_render::passes::sss::{SssConfig, SssMethod};
use subsurface_render::passes::transmittance::{TransmittanceConfig, TransmittanceMethod};
use subsurface_render::{DebugView, GpuContext, RenderOptions, Renderer, Scene};

use crate::output::PendingFile;

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML, see README). Without it, the embedded default scene: a backlit hand
    /// beside a wedge.
    pub scene: Option<PathBuf>,
    /// Replace the scene's objects by this glTF/GLB model (in metres, skin material); the
    /// camera is re-aimed to frame it.
    #[arg(long, value_name = "FILE.glb")]
    pub model: Option<PathBuf>,
    /// Image width in pixels (default: the scene's, 1280).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels (default: the scene's, 720).
    #[arg(long)]
    pub height: Option<u32>,
    /// Output PNG.
    #[arg(long, short, default_value = "subsurface.png", value_name = "FILE.png")]
    pub out: PathBuf,
    /// Exposure in EV (stops) added to the scene's exposure.
    #[arg(long, value_name = "EV", allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Render this many copies of the scene's objects in a grid covering about the same
    /// screen area (the scalability scenes of `bench --characters`).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub characters: u32,
    /// What to write: the final image or an intermediate buffer.
    #[arg(long, value_enum, default_value = "final")]
    pub view: ViewArg,
    #[command(flatten)]
    pub sss: SssArgs,
    #[command(flatten)]
    pub transmittance: TransmittanceArgs,
}

/// Light through thin parts (ears, nostrils, fingers), shared by `render` and `bench`.
#[derive(Args, Debug, Clone)]
pub struct TransmittanceArgs {
    /// Transmittance method: paper = Jimenez et al. 2010 (T(s) of the material's profile from
    /// standard shadow maps), beer = Green's exp(-sigma_t s), seed-report = the ad-hoc s^-0.6
    /// term of the screen/texture-space report, tsm = translucent shadow maps (d'Eon: back-side
    /// irradiance blurred in texture space, same T(s) as paper), diffusion = T(s) from diffusion
    /// theory for the material's measured coefficients (multipole slab transmittance; thick
    /// parts still pass red light), off = none [default: the scene's render.transmittance,
    /// paper].
    #[arg(long, value_enum)]
    pub transmittance: Option<TransmittanceArg>,
    /// Width in texels (odd, 1..=15) of the shadow-map area averaged for a softer thickness
    /// [default: the scene's render.thickness_filter, 3].
    #[arg(long, value_name = "N")]
    pub thickness_filter: Option<u32>,
    /// Inward shift along the vertex normal before the shadow-map lookup, in scene units
    /// (default: the scene's render.normal_shrink, 0.005 unless set).
    #[arg(long, value_name = "UNITS")]
    pub normal_shrink: Option<f32>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransmittanceArg {
    Paper,
    Beer,
    SeedReport,
    Tsm,
    Diffusion,
    Off,
}

impl From<TransmittanceArg> for TransmittanceMethod {
    fn from(v: TransmittanceArg) -> Self {
        match v {
            TransmittanceArg::Paper => TransmittanceMethod::Paper,
            TransmittanceArg::Beer => TransmittanceMethod::Beer,
            TransmittanceArg::SeedReport => TransmittanceMethod::SeedReport,
            TransmittanceArg::Tsm => TransmittanceMethod::Tsm,
            TransmittanceArg::Diffusion => TransmittanceMethod::Diffusion,
            TransmittanceArg::Off => TransmittanceMethod::Off,
        }
    }
}

impl TransmittanceArgs {
    pub fn config(&self, scene: &Scene) -> Result<TransmittanceConfig> {
        let c = TransmittanceConfig {
            method: self
                .transmittance
                .map_or(scene.desc.render.transmittance, TransmittanceMethod::from),
            normal_shrink: self
                .normal_shrink
                .unwrap_or(scene.desc.render.normal_shrink),
            thickness_filter: self
                .thickness_filter
                .unwrap_or(scene.desc.render.thickness_filter),
        };
        c.validate()
            .map_err(|e| anyhow::anyhow!("--{}", e.to_string().replace('_', "-")))?;
        Ok(c)
    }
}

/// Screen-space subsurface-scattering options, shared by `render` and `bench`.
#[derive(Args, Debug, Clone)]
pub struct SssArgs {
    /// Screen-space SSS method: gaussian6 = Jimenez et al. 2009 / GPU Pro (five Gaussians, H+V
    /// 7-tap blurs each), separable = Jimenez et al. 2015 (one H and one V pass), hable13 =
    /// Hable et al. 2009 (one 2-D pass of 13 taps), texture = d'Eon et al. 2007 texture-space
    /// diffusion (per-object UV irradiance maps), none = no scattering.
    /// [default: the scene's render.sss, separable]
    #[arg(long, value_enum)]
    pub sss: Option<SssArg>,
    /// Separable: number of kernel taps (odd, 3..=63) [default: the scene's render.samples, 17].
    #[arg(long, value_name = "N")]
    pub samples: Option<u32>,
    /// Scene units per profile millimetre for every skin object, overriding what each object's
    /// mm_per_unit and sss_width give (e.g. 0.001 for a model in metres at physical size).
    #[arg(long, value_name = "UNITS")]
    pub sss_width: Option<f32>,
    /// Separable: per-channel kernel strength R,G,B in 0..=1 (default: the first skin
    /// material's kernel_strength, 0.48,0.41,0.28).
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb)]
    pub strength: Option<[f32; 3]>,
    /// Separable: per-channel falloff R,G,B (default: the first skin material's, 1,0.37,0.3).
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb)]
    pub falloff: Option<[f32; 3]>,
    /// Let the blur cross depth edges (turns off the depth-difference correction)
    /// [default: the scene's render.follow_surface, true].
    #[arg(long)]
    pub no_follow_surface: bool,
    /// Six-Gaussian: which of the five blurred Gaussians to accumulate, as five 0/1 values
    /// (e.g. 1,1,0,1,1) [default: the scene's render.gaussians, all].
    #[arg(long, value_name = "G1,..,G5", value_parser = parse_gaussians)]
    pub gaussians: Option<[bool; 5]>,
    /// Texture-space SSS: size of each object's irradiance map in texels.
    #[arg(long, default_value_t = 1024, value_name = "N")]
    pub texture_size: u32,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SssArg {
    None,
    Gaussian6,
    Separable,
    Hable13,
    Texture,
}

impl From<SssArg> for SssMethod {
    fn from(v: SssArg) -> Self {
        match v {
            SssArg::None => SssMethod::None,
            SssArg::Gaussian6 => SssMethod::Gaussian6,
            SssArg::Separable => SssMethod::Separable,
            SssArg::Hable13 => SssMethod::Hable13,
            SssArg::Texture => SssMethod::Texture,
        }
    }
}

/// Parses five comma-separated 0/1 values (the six-Gaussian switches).
pub fn parse_gaussians(s: &str) -> Result<[bool; 5], String> {
    let v: Vec<bool> = s
        .split(',')
        .map(|p| match p.trim() {
            "1" => Ok(true),
            "0" => Ok(false),
            o => Err(format!("{o:?} is not 0 or 1")),
        })
        .collect::<Result<_, _>>()?;
    v.try_into()
        .map_err(|v: Vec<bool>| format!("expected five 0/1 values (got {})", v.len()))
}

/// Parses "r,g,b" into three finite floats.
pub fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [r, g, b] if v.iter().all(|x| x.is_finite()) => Ok([*r, *g, *b]),
        [_, _, _] => Err("values must be finite".into()),
        _ => Err(format!(
            "expected three comma-separated numbers R,G,B (got {s:?})"
        )),
    }
}

impl SssArgs {
    /// Applies the flags to the scene (width override) and returns the pass configuration.
    pub fn apply(&self, scene: &mut Scene) -> Result<SssConfig> {
        if let Some(w) = self.sss_width {
            anyhow::ensure!(
                w.is_finite() && w > 0.0,
                "--sss-width: must be finite and > 0 (got {w})"
            );
            for o in &mut scene.objects {
                let scale = o.transform.determinant().abs().cbrt();
                o.material.sss_width = w * o.mm_per_unit / scale;
            }
        }
        let mut config = SssConfig::for_scene(scene);
        if let Some(m) = self.sss {
            config.method = m.into();
        }
        if let Some(n) = self.samples {
            config.samples = n;
        }
        config.texture_size = self.texture_size;
        if let Some(s) = self.strength {
            config.strength = s;
        }
        if let Some(f) = self.falloff {
            config.falloff = f;
        }
        if self.no_follow_surface {
            config.follow_surface = false;
        }
        if let Some(g) = self.gaussians {
            config.gaussians_enabled = g;
        }
        config.validate().map_err(|e| anyhow::anyhow!("--{e}"))?;
        Ok(config)
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum ViewArg {
    /// Tone-mapped composite
    Final,
    /// SSS strength mask (white = skin)
    Mask,
    /// Linear depth (black = camera, white = far plane)
    Depth,
    /// Diffuse radiance after subsurface scattering
    Diffuse,
    /// Diffuse radiance before subsurface scattering
    DiffuseBefore,
    /// Specular radiance only
    Specular,
    /// Thickness the transmittance sees, in profile mm (white 0, yellow, red, black 8 mm and
    /// beyond; grey where no shadowed light reaches)
    Thickness,
    /// The irradiance that is blurred: the first skin object's UV-space map with --sss
    /// texture, else the lit image before the screen-space blur
    Irradiance,
}

impl From<ViewArg> for DebugView {
    fn from(v: ViewArg) -> Self {
        match v {
            ViewArg::Final => DebugView::Final,
            ViewArg::Mask => DebugView::Mask,
            ViewArg::Depth => DebugView::Depth,
            ViewArg::Diffuse => DebugView::Diffuse,
            ViewArg::DiffuseBefore => DebugView::DiffuseBeforeSss,
            ViewArg::Specular => DebugView::Specular,
            ViewArg::Thickness => DebugView::Thickness,
            ViewArg::Irradiance => DebugView::Irradiance,
        }
    }
}

/// Loads the scene named on the command line (or the default) and applies `--model`.
pub fn load_scene(scene: Option<&PathBuf>, model: Option<&PathBuf>) -> Result<Scene> {
    let mut scene = match scene {
        Some(p) => Scene::load_file(p)?,
        None => Scene::default_scene(),
    };
    if let Some(m) = model {
        scene.replace_model(m)?;
    }
    Ok(scene)
}

pub fn options(
    scene: &Scene,
    width: Option<u32>,
    height: Option<u32>,
    exposure: Option<f32>,
) -> Result<RenderOptions> {
    let mut o = RenderOptions::from_scene(scene);
    if let Some(w) = width {
        o.width = w;
    }
    if let Some(h) = height {
        o.height = h;
    }
    if let Some(e) = exposure {
        anyhow::ensure!(e.is_finite(), "--exposure: must be finite (got {e})");
        o.exposure_ev += e;
    }
    for (name, v) in [("--width", o.width), ("--height", o.height)] {
        anyhow::ensure!(v > 0, "{name}: must be at least 1 (got {v})");
    }
    Ok(o)
}

pub fn run(args: &RenderArgs, verbose: u8) -> Result<()> {
    let start = Instant::now();
    let pending = PendingFile::create(&args.out)?;
    anyhow::ensure!(
        (1..=256).contains(&args.characters),
        "--characters: must be in 1..=256 (got {})",
        args.characters
    );
    let mut scene = crate::bench::replicate(
        &load_scene(args.scene.as_ref(), args.model.as_ref())?,
        args.characters,
    );
    let mut opts = options(&scene, args.width, args.height, args.exposure)?;
    opts.view = args.view.into();
    opts.sss = args.sss.apply(&mut scene)?;
    opts.transmittance = args.transmittance.config(&scene)?;
    let ctx = GpuContext::new_headless()?;
    if verbose > 0 {
        eprintln!("adapter: {}", ctx.adapter_name());
    }
    ctx.check_size("--", opts.width, opts.height)?;
    let mut renderer = Renderer::new(&ctx, &scene, opts.clone())?;
    let frame = renderer.render().context("rendering failed")?;
    pending.write_png(&frame.image)?;
    let passes = if frame.timings.is_empty() {
        "no GPU timestamps".to_string()
    } else {
        let mut s: Vec<String> = frame
            .timings
            .iter()
            .map(|t| format!("{} {:.3} ms", t.name, t.ms))
            .collect();
        s.push(format!("GPU {:.3} ms", frame.gpu_total_ms()));
        s.join(", ")
    };
    println!(
        "{} {}x{} on {}: {}; total {:.0} ms",
        args.out.display(),
        opts.width,
        opts.height,
        ctx.adapter_name(),
        passes,
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
