//! The outline pass (`transmitted_map.outlines = "pass"`): each light's chord at the pixels the
//! transmitted map misses, run in a pass of its own, gives the lighting pass's targets the
//! lighting pass's own chords inline (`"lighting"`) give, on the default scene and on a backlit
//! finger whose outline the chords light, in a first frame and after the camera moves.

use crate::common;

use common::{context, options, repo_root};
use subsurface_render::{OutlineChords, Renderer, Scene};

/// The diffuse and specular targets of two frames (the second after the camera moves) of
/// `scene` with the chords where `outlines` puts them, and each pixel's outline mark (the SSS
/// target's `a`).
fn frames(
    ctx: &subsurface_render::GpuContext,
    scene: &Scene,
    outlines: OutlineChords,
) -> Vec<[Vec<[f32; 4]>; 3]> {
    let mut opts = options(scene, 256, 256);
    opts.settings.transmitted_map.outlines = outlines;
    let mut r = Renderer::new(ctx, scene, opts.clone()).unwrap();
    let mut moved = scene.clone();
    moved.desc.camera.position[0] += 0.01;
    let mut out = Vec::new();
    for next in [scene, &moved] {
        r.update(next, &opts).unwrap();
        r.render().unwrap();
        let t = &r.targets;
        out.push([&t.diffuse, &t.specular, &t.sss].map(|t| common::read4(ctx, t)));
    }
    out
}

#[test]
fn the_outline_pass_gives_the_lighting_pass_chords() {
    let Some(ctx) = context() else { return };
    let finger =
        Scene::load_file(&repo_root().join("scenes/canonical/finger-backlit.toml")).unwrap();
    for (name, scene) in [("default", Scene::default_scene()), ("finger", finger)] {
        let inline = frames(&ctx, &scene, OutlineChords::Lighting);
        let pass = frames(&ctx, &scene, OutlineChords::Pass);
        for (frame, (inline, pass)) in inline.iter().zip(&pass).enumerate() {
            let at = format!("{name}, frame {frame}");
            let marked: Vec<bool> = pass[2].iter().map(|s| s[3] > 0.5).collect();
            let count = marked.iter().filter(|&&m| m).count();
            // The chords run on the outline band of the skin: a few hundred pixels here.
            assert!(
                count > 100,
                "{at}: {count} pixels marked for the outline pass"
            );
            assert!(
                inline[2].iter().all(|s| s[3] == 0.0),
                "{at}: the inline frame marked pixels"
            );
            for (target, (a, b)) in ["diffuse", "specular"]
                .iter()
                .zip(inline.iter().zip(pass.iter()))
            {
                for (i, (a, b)) in a.iter().zip(b).enumerate() {
                    for c in 0..3 {
                        // Half floats: the sum of two parts rounds once more than the whole.
                        assert!(
                            (a[c] - b[c]).abs() <= 2e-3 * a[c].abs() + 1e-6,
                            "{at}, {target} at pixel {i} (marked: {}): {} inline, {} with the pass",
                            marked[i],
                            a[c],
                            b[c]
                        );
                    }
                }
            }
        }
    }
}
