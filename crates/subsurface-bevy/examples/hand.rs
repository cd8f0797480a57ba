//! The embedded scene of `subsurface render` (a backlit hand and a skin wedge) drawn by Bevy
//! with `SubsurfacePlugin`, in a window.
//!
//! ```text
//! cargo run --release -p subsurface-bevy --example hand
//! cargo run --release -p subsurface-bevy --example hand -- --frames 30 --screenshot hand.png
//! cargo run --release -p subsurface-bevy --example hand -- --bench
//! ```
//! Drag with the left button to orbit, scroll to zoom, S switches scattering, T
//! transmittance, Q cycles the quality preset, Esc quits. The line at the top shows the
//! plugin's GPU time.

#[path = "common/mod.rs"]
mod common;

use clap::Parser;
use subsurface_render::Scene;

fn main() -> bevy::app::AppExit {
    let args = common::Args::parse();
    common::run("subsurface-bevy: hand", Scene::default_scene(), args)
}
