//! `subsurface render`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
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
    /// What to write: the final image or an intermediate buffer.
    #[arg(long, value_enum, default_value = "final")]
    pub view: ViewArg,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum ViewArg {
    /// Tone-mapped composite
    Final,
    /// SSS strength mask (white = skin)
    Mask,
    /// Linear depth (black = camera, white = far plane)
    Depth,
    /// Diffuse radiance only
    Diffuse,
    /// Specular radiance only
    Specular,
}

impl From<ViewArg> for DebugView {
    fn from(v: ViewArg) -> Self {
        match v {
            ViewArg::Final => DebugView::Final,
            ViewArg::Mask => DebugView::Mask,
            ViewArg::Depth => DebugView::Depth,
            ViewArg::Diffuse => DebugView::Diffuse,
            ViewArg::Specular => DebugView::Specular,
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
    let scene = load_scene(args.scene.as_ref(), args.model.as_ref())?;
    let mut opts = options(&scene, args.width, args.height, args.exposure)?;
    opts.view = args.view.into();
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
