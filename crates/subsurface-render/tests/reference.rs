//! Reference images compared with FLIP, for every SSS method on the hand (default scene) and
//! the head. References are lavapipe renders at 256x256 blessed with SUBSURFACE_BLESS=1; on
//! failure the actual and FLIP heat-map images land in target/test-output/.

mod common;

use common::{assets_dir, context, flip_against_reference, repo_root};
use subsurface_render::SssMethod;
use subsurface_render::TransmittanceMethod;
use subsurface_render::{RenderOptions, Renderer, Scene};

/// FLIP mean and 95th-percentile limits: lavapipe against its own references differs only by
/// nondeterminism-free arithmetic, so these leave room for other drivers' rounding only.
const MEAN_MAX: f32 = 0.02;
const P95_MAX: f32 = 0.1;

const METHODS: [SssMethod; 4] = [
    SssMethod::None,
    SssMethod::Separable,
    SssMethod::Gaussian6,
    SssMethod::Hable13,
];

fn check(name: &str, scene: &Scene) {
    let Some(ctx) = context() else { return };
    for method in METHODS {
        let mut opts = RenderOptions::from_scene(scene);
        opts.settings.width = 256;
        opts.settings.height = 256;
        opts.settings.sss.method = method;
        let mut r = Renderer::new(&ctx, scene, opts).unwrap();
        let img = r.render().unwrap().image;
        flip_against_reference(
            &format!("{name}-{}", method.name()),
            &img,
            MEAN_MAX,
            P95_MAX,
        );
    }
    // Transmittance off, for the record of what it adds.
    let mut opts = RenderOptions::from_scene(scene);
    opts.settings.width = 256;
    opts.settings.height = 256;
    opts.settings.transmittance.method = TransmittanceMethod::Off;
    let img = Renderer::new(&ctx, scene, opts)
        .unwrap()
        .render()
        .unwrap()
        .image;
    flip_against_reference(
        &format!("{name}-separable-no-transmittance"),
        &img,
        MEAN_MAX,
        P95_MAX,
    );
}

#[test]
fn hand_matches_references() {
    check("hand", &Scene::default_scene());
}

/// scenes/head.toml, reading the head from SUBSURFACE_ASSETS.
pub fn head_scene() -> Option<Scene> {
    let assets = assets_dir()?;
    // scenes/head.toml points at ../../shared/assets; tests honour SUBSURFACE_ASSETS instead.
    let path = repo_root().join("scenes/head.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("../../shared/assets", &assets.to_string_lossy());
    let desc =
        subsurface_render::scene::SceneDesc::from_toml_str(&text, "scenes/head.toml").unwrap();
    Some(Scene::from_desc(desc, &repo_root().join("scenes"), "scenes/head.toml").unwrap())
}

#[test]
fn head_matches_references() {
    let Some(scene) = head_scene() else { return };
    check("head", &scene);
}
