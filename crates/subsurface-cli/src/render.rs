//! `subsurface render`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use subsurface_render::{DebugView, GpuContext, RenderOptions, Renderer};

use crate::output::{PendingFile, print_summary};
use crate::settings_args::{SettingsArgs, load_scene, replicate};

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML, see docs/guide.md). Without it, the embedded default scene: a backlit hand
    /// beside a wedge.
    scene: Option<PathBuf>,
    /// Replace the scene's objects by this glTF/GLB model (in metres, skin material); the
    /// camera is re-aimed to frame it.
    #[arg(long, value_name = "FILE.glb")]
    model: Option<PathBuf>,
    /// Output PNG.
    #[arg(long, short, default_value = "subsurface.png", value_name = "FILE.png")]
    out: PathBuf,
    /// Render this many copies of the scene's objects in a grid covering about the same
    /// screen area (the scalability scenes of `bench --characters`).
    #[arg(long, default_value_t = 1, value_name = "N")]
    characters: u32,
    /// What to write: the final image or an intermediate buffer.
    #[arg(long, value_enum, default_value = "final")]
    view: ViewArg,
    #[command(flatten)]
    settings: SettingsArgs,
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

pub fn run(args: &RenderArgs, verbose: u8) -> Result<()> {
    let start = Instant::now();
    let pending = PendingFile::create(&args.out)?;
    anyhow::ensure!(
        (1..=256).contains(&args.characters),
        "--characters: must be in 1..=256 (got {})",
        args.characters
    );
    let mut scene = replicate(
        &load_scene(args.scene.as_ref(), args.model.as_ref())?,
        args.characters,
    );
    args.settings.apply(&mut scene)?;
    let opts = RenderOptions {
        view: args.view.into(),
        ..RenderOptions::from_scene(&scene)
    };
    let ctx = GpuContext::new_headless()?;
    if verbose > 0 {
        eprintln!("adapter: {}", ctx.adapter_name());
    }
    ctx.check_size("--", opts.width(), opts.height())?;
    let mut renderer = Renderer::new(&ctx, &scene, opts.clone())?;
    let frame = renderer.render().context("rendering failed")?;
    // The summary must not end up inside a PNG written to stdout (`--out -`).
    let stdout_taken = pending.writes_to_stdout();
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
    let summary = format!(
        "{} {}x{} on {}: {}; total {:.0} ms\n",
        args.out.display(),
        opts.width(),
        opts.height(),
        ctx.adapter_name(),
        passes,
        start.elapsed().as_secs_f64() * 1e3
    );
    print_summary(stdout_taken, &summary);
    // After the image: a run that fails says one thing, its error.
    for line in subsurface_render::lights::coarse_shadow_maps(&scene) {
        log::warn!("{line}");
    }
    Ok(())
}
