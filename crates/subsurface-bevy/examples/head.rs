//! The Lee Perry-Smith head (`scenes/head.toml`, its model and maps read from
//! `../shared/assets/LeePerrySmith/`, or from `$SUBSURFACE_ASSETS/LeePerrySmith/`) drawn by
//! Bevy with `SubsurfacePlugin`, in a window; or another glTF model given on the command line
//! in its place.
//!
//! ```text
//! cargo run --release -p subsurface-bevy --example head
//! cargo run --release -p subsurface-bevy --example head -- --model my_head.glb
//! cargo run --release -p subsurface-bevy --example head -- --frames 30 --screenshot head.png
//! ```
//! Keys as in the `hand` example.

#[path = "common/mod.rs"]
mod common;

use std::path::PathBuf;

use clap::Parser;
use subsurface_render::Scene;

#[derive(Parser, Debug)]
struct HeadArgs {
    /// Replace the head by this glTF/GLB model (the camera is re-aimed to frame it).
    #[arg(long, value_name = "FILE.glb")]
    model: Option<PathBuf>,
    #[command(flatten)]
    common: common::Args,
}

fn main() -> bevy::app::AppExit {
    let args = HeadArgs::parse();
    let scene_file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/head.toml");
    let scene = match &args.model {
        // Another model takes the head's place under its lights, or, without the head's
        // files, the default scene's.
        Some(model) => {
            let mut scene =
                Scene::load_file(&scene_file).unwrap_or_else(|_| Scene::default_scene());
            scene.replace_model(model).map(|()| scene)
        }
        None => Scene::load_file(&scene_file),
    };
    match scene {
        Ok(scene) => common::run("subsurface-bevy: head", scene, args.common),
        Err(e) if args.model.is_some() => {
            eprintln!("error: {e}");
            bevy::app::AppExit::error()
        }
        Err(e) => {
            // The head is not in the repository (README, Assets).
            eprintln!(
                "error: {e} (put LeePerrySmith.glb and its maps in ../shared/assets/LeePerrySmith/ \
                 or set SUBSURFACE_ASSETS)"
            );
            bevy::app::AppExit::error()
        }
    }
}
