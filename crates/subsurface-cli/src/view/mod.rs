//! `subsurface view`: the interactive viewer. A winit window shows the renderer's image at
//! the window's physical size with an egui panel over its left side (the window opens wider
//! than the scene by the panel's width, so the panel covers none of the scene at first);
//! every setting is live (`Renderer::update`, no restart), cameras orbit or fly, lights move,
//! and a split screen compares two settings.
//!
//! Layout: `camera` (orbit/fly math, unit-tested), `state` (all settings <-> scene file and
//! `RenderOptions`, round-trip tested), `model` (edits, no GPU), `setting` (one `[render]`
//! key as the panel edits it, checked by the render crate), `panel` (egui), `gfx` (what
//! lives on the device: surface, egui and scene renderers), `app` (window and frame loop).

mod app;
mod camera;
mod fonts;
mod gfx;
mod model;
mod panel;
mod setting;
mod soak;
mod state;

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use subsurface_render::scene::DEFAULT_SCENE_TOML;
use subsurface_render::{Scene, SssMethod};

use crate::output::PendingFile;
use crate::render::ViewArg;
use crate::settings_args::SettingsArgs;
use state::ViewerState;

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// Scene file (TOML; the viewer's saved scenes too). Without it, the embedded default scene.
    scene: Option<PathBuf>,
    /// Replace the scene's objects by this glTF/GLB model; the camera is re-aimed to frame it.
    #[arg(long, value_name = "FILE.glb")]
    model: Option<PathBuf>,
    /// Debug view to start with.
    #[arg(long, value_enum)]
    view: Option<ViewArg>,
    /// The scene's settings, overridden as `subsurface render` does; --width/--height give the
    /// window's inner size in physical pixels (default: the scene's size in logical pixels,
    /// widened by the panel's width so that the panel covers none of the scene at first).
    #[command(flatten)]
    settings: SettingsArgs,
    /// Start in split screen: the settings above on the left, this SSS method on the right.
    #[arg(long, value_name = "METHOD")]
    compare: Option<SssMethod>,
    /// Present without waiting for vertical sync (frame times then show the GPU's pace).
    #[arg(long)]
    no_vsync: bool,
    /// Scripted mode: render N frames in the window, then write --screenshot/--save-scene and
    /// exit (non-zero on any error).
    #[arg(long, value_name = "N")]
    frames: Option<u32>,
    /// With --frames: PNG of the 3D view (the renderer's image, no panel) after the last
    /// frame.
    #[arg(long, value_name = "FILE.png")]
    screenshot: Option<PathBuf>,
    /// With --frames: save the settings as a scene file after the last frame.
    #[arg(long, value_name = "FILE.toml")]
    save_scene: Option<PathBuf>,
    /// With --frames: destroy the GPU device after this frame, to test recovery.
    #[arg(long, value_name = "FRAME", hide = true)]
    lose_device_at: Option<u32>,
    /// With --frames: change the methods, lights and window size every frame and fail if
    /// memory, GPU memory or wgpu objects grow (the viewer soak test).
    #[arg(long, hide = true)]
    soak: bool,
}

/// Loads the scene and applies the command line on top of it.
fn initial_state(args: &ViewArgs) -> Result<(ViewerState, Scene)> {
    let (mut state, mut scene) = match &args.scene {
        Some(p) => ViewerState::load_with_scene(p)?,
        None => (
            ViewerState::from_toml_str(DEFAULT_SCENE_TOML, PathBuf::from("."), "<default scene>")?,
            Scene::default_scene(),
        ),
    };
    if let Some(m) = &args.model {
        scene.replace_model(m)?;
        state.desc = scene.desc.clone();
    }
    // One overlay for render, bench and view: the flags go into the scene, and the viewer's
    // main side starts from its settings.
    let window = state.desc.render.clone();
    args.settings.apply(&mut scene)?;
    state.desc = scene.desc.clone();
    (state.desc.render.width, state.desc.render.height) = (window.width, window.height);
    state.a = state::Side::of(&scene.desc.render);
    if let Some(v) = args.view {
        state.a.view = v.into();
    }
    if let Some(c) = args.compare {
        state.compare_with(c);
    }
    Ok((state, scene))
}

pub fn run(args: &ViewArgs) -> Result<()> {
    if args.frames.is_none() {
        for (flag, given) in [
            ("--screenshot", args.screenshot.is_some()),
            ("--save-scene", args.save_scene.is_some()),
            ("--lose-device-at", args.lose_device_at.is_some()),
            ("--soak", args.soak),
        ] {
            anyhow::ensure!(!given, "{flag}: needs --frames N (scripted mode)");
        }
    }
    if let Some(n) = args.frames {
        anyhow::ensure!(n >= 1, "--frames: must be at least 1 (got {n})");
    }
    // Unwritable outputs fail now, not after the window has rendered.
    let screenshot = args
        .screenshot
        .as_deref()
        .map(PendingFile::create)
        .transpose()?;
    if let Some(p) = &args.save_scene {
        drop(PendingFile::create(p)?);
    }
    let (state, scene) = initial_state(args)?;
    let script = args.frames.map(|frames| app::Script {
        frames,
        screenshot,
        save_scene: args.save_scene.clone(),
        lose_device_at: args.lose_device_at,
        soak: args.soak.then(|| soak::Soak::new(frames)),
    });
    let size: winit::dpi::Size = match (args.settings.width, args.settings.height) {
        // The scene's size beside the panel: the panel covers none of the scene at first.
        (None, None) => winit::dpi::LogicalSize::new(
            f64::from(state.desc.render.width) + f64::from(panel::PANEL_WIDTH),
            f64::from(state.desc.render.height),
        )
        .into(),
        (w, h) => winit::dpi::PhysicalSize::new(
            w.unwrap_or(state.desc.render.width),
            h.unwrap_or(state.desc.render.height),
        )
        .into(),
    };
    let model = model::Model::new(state, scene, args.scene.as_deref());
    let event_loop = winit::event_loop::EventLoop::new().map_err(|e| {
        // winit prefixes OS errors with its own source location; users need only the reason.
        let msg = e.to_string();
        let reason = msg
            .rsplit_once(".rs:")
            .and_then(|(_, r)| r.split_once(": "))
            .map_or(msg.as_str(), |(_, r)| r);
        anyhow::anyhow!(
            "cannot open a window: {reason} (for scripted runs without a display, use xvfb-run)"
        )
    })?;
    let mut app = app::App::new(model, &event_loop, size, !args.no_vsync, script);
    event_loop
        .run_app(&mut app)
        .context("the window's event loop failed")?;
    app.finish()
}
