//! The skin passes in another renderer (examples/skin_in_your_renderer.rs): the example's own
//! forward renderer plus the library's shadow entry, transmitted light and SSS passes must
//! give the image `Renderer` gives of the same scene, and the skin passes must be what changes
//! the skin.

use crate::common;

#[path = "../examples/skin_in_your_renderer.rs"]
#[allow(dead_code)]
mod example;

use subsurface_render::{RenderOptions, Renderer, Scene};

/// The default frame (the medium preset: no bounce).
#[test]
fn skin_in_your_renderer_matches_the_renderer() {
    let Some(ctx) = common::context() else { return };
    let scene = Scene::default_scene();
    let settings = example::example_settings(&scene, 320, 180);
    check_against_renderer(&ctx, &scene, &settings, "medium");
}

/// The high preset: the bounce between the fingers and all of transmittance's terms.
#[test]
fn skin_in_your_renderer_matches_the_renderer_with_the_bounce() {
    let Some(ctx) = common::context() else { return };
    let mut scene = Scene::default_scene();
    scene
        .desc
        .set_quality(subsurface_render::settings::Quality::High)
        .unwrap();
    let settings = example::example_settings(&scene, 320, 180);
    assert!(settings.bounce.ring > 0);
    check_against_renderer(&ctx, &scene, &settings, "high");
}

fn check_against_renderer(
    ctx: &subsurface_render::GpuContext,
    scene: &Scene,
    settings: &subsurface_render::RenderSettings,
    name: &str,
) {
    let theirs = example::render(ctx, scene, settings, true).unwrap().0;
    let without = example::render(ctx, scene, settings, false).unwrap().0;
    let options = RenderOptions {
        settings: settings.clone(),
        ..Default::default()
    };
    let mut renderer = Renderer::new(ctx, scene, options).unwrap();
    let ours = renderer.render().unwrap().image;
    let strength = renderer.read_sss().unwrap();
    let out = common::output_dir();
    let tag = name;
    for (which, image) in [("ours", &ours), ("theirs", &theirs), ("without", &without)] {
        image
            .save(out.join(format!("skin_in_your_renderer.{tag}.{which}.png")))
            .unwrap();
    }
    let (mean, p95, heat) = common::flip(&ours, &theirs);
    heat.save(out.join("skin_in_your_renderer.flip.png"))
        .unwrap();
    let is_skin = |i: usize| strength[i][0] > 0.0;
    let skin_flip = common::masked_mean(&common::flip_errors(&ours, &theirs), is_skin);
    let skin_flip_without = common::masked_mean(&common::flip_errors(&ours, &without), is_skin);
    eprintln!(
        "{tag}: FLIP against Renderer: mean {mean:.4}, p95 {p95:.4}, on skin {skin_flip:.4}; \
         without the skin passes on skin {skin_flip_without:.4}"
    );
    // Skin pixels: the skin passes change them; nothing else changes.
    let (mut skin_change, mut skin_pixels) = (0.0f64, 0usize);
    for (i, (a, b)) in theirs.pixels().zip(without.pixels()).enumerate() {
        let change: f64 = (0..3)
            .map(|c| (f64::from(a[c]) - f64::from(b[c])).abs())
            .sum();
        if is_skin(i) {
            skin_change += change / 3.0;
            skin_pixels += 1;
        } else {
            assert_eq!(a, b, "pixel {i} is not skin but the skin passes changed it");
        }
    }
    let skin_change = skin_change / skin_pixels.max(1) as f64;
    eprintln!("skin pixels {skin_pixels}, mean |change| {skin_change:.2} of 255");
    assert!(skin_pixels > 1000, "only {skin_pixels} skin pixels");
    assert!(
        skin_change > 2.0,
        "the skin passes changed the skin by only {skin_change:.2} of 255"
    );
    assert!(
        mean < 0.01 && skin_flip < 0.04,
        "{tag}: FLIP against Renderer: mean {mean:.4}, on skin {skin_flip:.4}"
    );
    assert!(
        skin_flip_without > 4.0 * skin_flip,
        "on skin, FLIP without the skin passes is {skin_flip_without:.4}, with them {skin_flip:.4}"
    );
}
