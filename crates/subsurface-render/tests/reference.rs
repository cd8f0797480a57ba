//! Reference images compared with FLIP, for every SSS method on the hand (default scene) and
//! the head. References are lavapipe renders at 256x256 blessed with SUBSURFACE_BLESS=1; on
//! failure the actual and FLIP heat-map images land in target/test-output/.

use crate::common;

use common::{context, flip_against_reference, head_scene, options};
use subsurface_render::SssMethod;
use subsurface_render::TransmittanceMethod;
use subsurface_render::{Renderer, Scene};

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
        let mut opts = options(scene, 256, 256);
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
    let mut opts = options(scene, 256, 256);
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

#[test]
fn head_matches_references() {
    let Some(scene) = head_scene() else { return };
    check("head", &scene);
}

/// Mean colour of the loaded colour map at the UVs of the head's front-most vertices near the
/// centre line, `below_nose` head units (48 mm each) under the tip of the nose. The map is
/// sampled as the renderer samples it (v down the image).
fn colour_below_nose(scene: &Scene, below_nose: f32) -> [f32; 3] {
    let head = &scene.objects[0];
    let map = head
        .albedo_texture
        .as_ref()
        .expect("the head has a colour map");
    let verts = &head.mesh.vertices;
    let nose = verts
        .iter()
        .max_by(|a, b| a.position[2].total_cmp(&b.position[2]))
        .unwrap();
    let y = nose.position[1] - below_nose;
    let mut near: Vec<_> = verts
        .iter()
        .filter(|v| (v.position[1] - y).abs() < 0.06 && v.position[0].abs() < 0.3)
        .collect();
    near.sort_by(|a, b| b.position[2].total_cmp(&a.position[2]));
    let front = &near[..near.len().min(8)];
    assert!(!front.is_empty(), "no vertices {below_nose} below the nose");
    let (w, h) = map.dimensions();
    let mut sum = [0.0f32; 3];
    for v in front {
        let x = ((v.uv[0].rem_euclid(1.0) * w as f32) as u32).min(w - 1);
        let y = ((v.uv[1].rem_euclid(1.0) * h as f32) as u32).min(h - 1);
        let p = map.get_pixel(x, y);
        for c in 0..3 {
            sum[c] += p[c] as f32 / front.len() as f32;
        }
    }
    sum
}

/// Texture registration, checked against the texture's content rather than against our own
/// renders: the lips (about 29 mm below the tip of the nose) are much redder than the chin
/// (about 67 mm below). With the head's maps the wrong way up, the lips' red lands on the
/// chin and this fails.
#[test]
fn head_colour_map_puts_the_lips_above_the_chin() {
    let Some(scene) = head_scene() else { return };
    let redness = |c: [f32; 3]| c[0] / c[1].max(1.0);
    let lips = redness(colour_below_nose(&scene, 0.6));
    let chin = redness(colour_below_nose(&scene, 1.4));
    eprintln!("red/green: lips {lips:.2}, chin {chin:.2}");
    assert!(lips > chin + 0.3, "lips {lips:.2} vs chin {chin:.2}");
    // The same maps without the scene's flip put the red on the chin.
    let mut unflipped = scene.clone();
    let map = unflipped.objects[0].albedo_texture.as_mut().unwrap();
    image::imageops::flip_vertical_in_place(map);
    let lips = redness(colour_below_nose(&unflipped, 0.6));
    let chin = redness(colour_below_nose(&unflipped, 1.4));
    assert!(chin > lips, "unflipped: lips {lips:.2} vs chin {chin:.2}");
}
