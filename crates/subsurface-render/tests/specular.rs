//! The lighting pass's specular term against the CPU reference of the boundary it models
//! (`subsurface_profile::specular`, the rough dielectric the path tracer renders), head-on and
//! where a back light grazes a rim toward the camera.

use crate::common;

use common::{camera_toml, context, light_toml, options, scene};
use subsurface_profile::specular::boundary_reflection;
use subsurface_render::{Renderer, Scene, SssMethod, TransmittanceMethod};

const ROUGHNESS: f64 = 0.3;
/// skin1's boundary index.
const ETA: f64 = 1.3;
/// Odd, so the centre pixel looks straight down -z.
const SIZE: u32 = 33;

/// A black slab of skin1 (specular 1, so the specular target is the boundary's reflection)
/// turned `yaw_deg` about y, lit by an unshadowed directional light of irradiance 1 arriving
/// from `l`; the camera looks down -z through a 4 degree field of view.
fn slab_scene(yaw_deg: f64, l: [f64; 3]) -> Scene {
    let light = light_toml(
        "directional",
        l.map(|x| x as f32),
        1.0,
        "shadow_map_size = 0",
    );
    scene(&format!(
        r#"
        {camera}
        [render]
        ambient = [0.0, 0.0, 0.0]
        {light}
        [[objects]]
        mesh = {{ shape = "slab", width = 0.2, height = 0.2, thickness = 0.01 }}
        rotation_deg = [0.0, {yaw_deg:?}, 0.0]
        mm_per_unit = 1000.0
        [objects.material]
        medium = "skin1"
        albedo = [0.0, 0.0, 0.0]
        use_gltf_color = false
        roughness = {ROUGHNESS:?}
        specular = 1.0
        "#,
        camera = camera_toml(0.3, 4.0, "near = 0.05\nfar = 2.0"),
    ))
}

/// The specular target's red at the centre pixel.
fn centre_specular(scene: &Scene) -> f32 {
    let ctx = context().unwrap();
    let mut opts = options(scene, SIZE, SIZE);
    opts.settings.sss.method = SssMethod::None;
    opts.settings.transmittance.method = TransmittanceMethod::Off;
    let mut r = Renderer::new(&ctx, scene, opts).unwrap();
    r.render().unwrap();
    let spec = r.read_specular().unwrap();
    let c = (SIZE / 2 * SIZE + SIZE / 2) as usize;
    assert!(
        spec[c][0] == spec[c][1] && spec[c][1] == spec[c][2],
        "{:?}",
        spec[c]
    );
    spec[c][0]
}

fn unit(theta_deg: f64) -> [f64; 3] {
    let t = theta_deg.to_radians();
    [t.sin(), 0.0, t.cos()]
}

/// For each `(yaw_deg, light_deg, what)`: the slab turned `yaw_deg` from the camera and lit
/// from `light_deg` shows the specular the rough boundary reflects (skipped without a GPU).
fn assert_reflects(cases: &[(f64, f64, &str)]) {
    if context().is_none() {
        return;
    }
    for &(yaw_deg, light_deg, what) in cases {
        let (n, l, v) = (unit(yaw_deg), unit(light_deg), [0.0, 0.0, 1.0]);
        let want = boundary_reflection(n, l, v, ROUGHNESS, ETA);
        assert!(want > 0.0, "{what}: the reference reflects nothing");
        let got = centre_specular(&slab_scene(yaw_deg, l)) as f64;
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "{what}: specular {got}, the boundary reflects {want}"
        );
    }
}

#[test]
fn specular_is_the_rough_boundary_reflection_head_on() {
    assert_reflects(&[
        // Facing the camera, the light 30 degrees off the normal: the highlight's flank.
        (0.0, 30.0, "head on"),
        // Turned 20 degrees, the light mirrored about the normal: the highlight itself.
        (20.0, 40.0, "mirror"),
    ]);
}

/// A rim lit from behind at the grazing angle it is seen at: 80 degrees from the camera with
/// light and camera 160 degrees apart, then 86 and 172. Kelemen/Szirmay-Kalos's 1 / |L + V|^2
/// made these 1.3x and 3.1x the boundary's reflection, growing without bound as the two
/// directions close in on opposite ones (44x on the finger-backlit scene's outline); Smith's
/// masking bounds it.
#[test]
fn a_back_light_grazing_a_rim_reflects_what_the_boundary_does() {
    assert_reflects(&[
        (80.0, 160.0, "backlit rim"),
        (86.0, 172.0, "backlit rim, closer to grazing"),
    ]);
}
