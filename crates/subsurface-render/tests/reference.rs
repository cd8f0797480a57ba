//! Reference images compared with FLIP. References are lavapipe renders at 256x256 blessed
//! with SUBSURFACE_BLESS=1; on failure the actual and FLIP heat-map images land in
//! target/test-output/.

mod common;

use common::{assets_dir, context, flip_against_reference, repo_root};
use subsurface_render::{DebugView, RenderOptions, Renderer, Scene};

fn render(scene: &Scene) -> Option<image::RgbaImage> {
    let ctx = context()?;
    let opts = RenderOptions {
        width: 256,
        height: 256,
        exposure_ev: scene.desc.render.exposure_ev,
        view: DebugView::Final,
    };
    let mut r = Renderer::new(&ctx, scene, opts).unwrap();
    Some(r.render().unwrap().image)
}

#[test]
fn default_scene_matches_reference() {
    let Some(img) = render(&Scene::default_scene()) else {
        return;
    };
    flip_against_reference("default", &img, 0.02, 0.1);
}

#[test]
fn head_matches_reference() {
    let Some(assets) = assets_dir() else { return };
    // scenes/head.toml points at ../../shared/assets; tests honour SUBSURFACE_ASSETS instead.
    let path = repo_root().join("scenes/head.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("../../shared/assets", &assets.to_string_lossy());
    let desc =
        subsurface_render::scene::SceneDesc::from_toml_str(&text, "scenes/head.toml").unwrap();
    let scene = Scene::from_desc(desc, &repo_root().join("scenes"), "scenes/head.toml").unwrap();
    let Some(img) = render(&scene) else { return };
    flip_against_reference("head", &img, 0.02, 0.1);
}
