//! GPU tests of the foundation (shadow maps, lighting, tone map) on whatever adapter wgpu
//! finds: lavapipe in CI. Images are small so the software rasteriser stays fast.

use crate::common;

use common::{
    assert_update_gives, camera_toml, context, dark_scene, light_toml, masked_mean, options, scene,
    update_matches_fresh,
};
use subsurface_render::{Renderer, SssMethod};

fn luminance(c: [f32; 4]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// A sphere of radius 0.5 lit from +x by a directional light of irradiance 2 (`light_more`:
/// its extra `key = value` lines), seen from 3 units down +z.
fn lit_sphere(light_more: &str) -> subsurface_render::Scene {
    dark_scene(
        &camera_toml(3.0, 30.0, ""),
        &light_toml("directional", [5.0, 0.0, 0.0], 2.0, light_more),
        r#"
        [[objects]]
        mesh = { shape = "sphere", radius = 0.5 }
        "#,
    )
}

#[test]
fn lit_sphere_is_brighter_on_the_lit_side() {
    let Some(ctx) = context() else { return };
    let s = lit_sphere("");
    let (w, h) = (96, 96);
    let mut r = Renderer::new(&ctx, &s, options(&s, w, h)).unwrap();
    r.render().unwrap();
    let diffuse: Vec<f32> = r
        .read_diffuse()
        .unwrap()
        .into_iter()
        .map(luminance)
        .collect();
    let depth = r.read_linear_depth().unwrap();
    let on_sphere = |i: usize| depth[i] < 10.0;
    let right = masked_mean(&diffuse, |i| on_sphere(i) && (i as u32 % w) > w / 2 + 4);
    let left = masked_mean(&diffuse, |i| on_sphere(i) && (i as u32 % w) < w / 2 - 4);
    assert!(right > 0.2, "lit side too dark: {right}");
    assert!(left < 0.02 * right, "unlit side {left} vs lit side {right}");
}

/// A receiver slab lit by a light on the camera's side, with and without a sphere between
/// them: the shadowed part of the receiver must be much darker, for every kind of light.
#[test]
fn shadow_caster_darkens_the_receiver() {
    let Some(ctx) = context() else { return };
    for kind in ["spot", "point", "directional"] {
        let render = |with_caster: bool| {
            let caster = if with_caster {
                r#"
                [[objects]]
                mesh = { shape = "sphere", radius = 0.2 }
                translation = [0.25, 0.25, 1.5]
                "#
            } else {
                ""
            };
            let light = light_toml(
                kind,
                [0.5, 0.5, 3.0],
                if kind == "directional" { 1.0 } else { 9.0 },
                "outer_angle_deg = 40.0\ninner_angle_deg = 30.0\nshadow_map_size = 256",
            );
            let objects = format!(
                r#"
                [[objects]]
                mesh = {{ shape = "slab", width = 3.0, height = 3.0, thickness = 0.05 }}
                {caster}
                "#
            );
            let s = dark_scene(&camera_toml(4.0, 40.0, ""), &light, &objects);
            let (w, h) = (64, 64);
            let mut r = Renderer::new(&ctx, &s, options(&s, w, h)).unwrap();
            r.render().unwrap();
            let d = r.read_diffuse().unwrap();
            // The light projects the caster's centre onto the receiver at about (0, 0): the
            // middle of the image, while the caster itself is seen further up and right.
            luminance(d[(h / 2 * w + w / 2) as usize])
        };
        let lit = render(false);
        let shadowed = render(true);
        assert!(lit > 0.1, "{kind}: receiver not lit: {lit}");
        assert!(
            shadowed < 0.15 * lit,
            "{kind}: shadowed {shadowed} vs lit {lit}"
        );
    }
}

/// Percentage-closer filtering across a straight shadow edge: a tent of 3x3 texels over a
/// binary edge is a linear ramp 3 shadow-map texels wide (the box-filtered texels 0, 1/3, 2/3,
/// 1, interpolated). Measured on the receiver against the same scene without the occluder, on
/// one row of pixels: monotone, from shadow to light, and a straight line in between (the
/// comparison gathers' weights in the wrong order or place would zigzag or bend it).
#[test]
fn pcf_penumbra_is_a_linear_ramp() {
    let Some(ctx) = context() else { return };
    let (w, h) = (256u32, 64u32);
    let render = |with_occluder: bool| {
        let occluder = if with_occluder {
            r#"
            [[objects]]
            mesh = { shape = "slab", width = 4.0, height = 1.5, thickness = 0.02 }
            translation = [-2.0, 0.0, 0.5]
            rotation_deg = [0.0, -18.435, 0.0]
            "#
        } else {
            ""
        };
        let light = light_toml(
            "directional",
            [-1.0, 0.0, 3.0],
            1.0,
            "shadow_map_size = 64\nshadow_bias = 0.001",
        );
        let objects = format!(
            r#"
            [[objects]]
            mesh = {{ shape = "slab", width = 8.0, height = 1.0, thickness = 0.05 }}
            rotation_deg = [0.0, -18.435, 0.0]
            material = {{ sss_strength = 0.0 }}
            {occluder}
            "#
        );
        let s = dark_scene(&camera_toml(4.0, 20.0, ""), &light, &objects);
        let mut r = Renderer::new(&ctx, &s, options(&s, w, h)).unwrap();
        r.render().unwrap();
        let depth = r.read_linear_depth().unwrap();
        let d = r.read_diffuse().unwrap();
        let row = (h / 2 * w) as usize;
        (0..w as usize)
            .map(|x| (depth[row + x], luminance(d[row + x])))
            .collect::<Vec<_>>()
    };
    let open = render(false);
    let shadowed = render(true);
    // The receiver's own pixels beside the occluder (the same depth in both images). Both face
    // the light, so the receiver is flat in the shadow map (no self-shadowing texel pattern).
    let ratio: Vec<f32> = open
        .iter()
        .zip(&shadowed)
        .filter(|(o, s)| (o.0 - s.0).abs() < 1e-4 && o.1 > 0.1)
        .map(|(o, s)| s.1 / o.1)
        .collect();
    assert!(ratio.len() > 64, "{} receiver pixels", ratio.len());
    assert!(
        ratio[0] < 0.02 && ratio[ratio.len() - 1] > 0.98,
        "{ratio:?}"
    );
    for pair in ratio.windows(2) {
        assert!(pair[1] >= pair[0] - 2e-3, "not monotone: {ratio:?}");
    }
    let ramp: Vec<(f32, f32)> = ratio
        .iter()
        .enumerate()
        .filter(|(_, r)| (0.05..0.95).contains(*r))
        .map(|(i, r)| (i as f32, *r))
        .collect();
    assert!(ramp.len() >= 12, "penumbra {} px: {ratio:?}", ramp.len());
    let n = ramp.len() as f32;
    let (mx, my) = ramp
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxy: f32 = ramp.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f32 = ramp.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    let slope = sxy / sxx;
    let worst = ramp
        .iter()
        .map(|(x, y)| (y - (my + slope * (x - mx))).abs())
        .fold(0.0, f32::max);
    eprintln!(
        "penumbra: {} px, slope {slope:.4} per px, worst deviation from a line {worst:.4}",
        ramp.len()
    );
    assert!(
        worst < 0.03,
        "penumbra not a straight ramp ({worst}): {ratio:?}"
    );
}

/// Oblique light feeds a diffusion source 1 / sigma_t' along the refracted ray, so a scattering
/// surface's diffuse light is shadowed as the surface tan(theta_t) / sigma_t' back toward the
/// light is: the penumbra of the light before the blur moves away from the light by that much
/// per channel, and not at all without SSS. A skin1 receiver at 1 mm per unit, lit at 45
/// degrees past an occluder's edge: theta_t = asin(sin 45 / 1.3), red's sigma_t' = 0.772 / mm,
/// so red moves 0.84 mm and green and blue the ratios of sigma_t' (0.735, 0.518) of that.
#[test]
fn oblique_light_moves_the_diffusion_source_away_from_the_light() {
    let Some(ctx) = context() else { return };
    let (w, h) = (256u32, 64u32);
    let light = light_toml(
        "directional",
        [-1.0, 0.0, 1.0],
        1.0,
        "shadow_map_size = 128\nshadow_bias = 0.3",
    );
    let objects = r#"
        [[objects]]
        mesh = { shape = "slab", width = 8.0, height = 1.0, thickness = 0.05 }
        mm_per_unit = 1.0
        material = { medium = "skin1" }
        [[objects]]
        mesh = { shape = "slab", width = 4.0, height = 1.5, thickness = 0.02 }
        translation = [-2.0, 0.0, 0.5]
        material = { sss_strength = 0.0 }
        "#;
    let s = dark_scene(&camera_toml(4.0, 20.0, ""), &light, objects);
    // The lit image before the blur, per channel, along the middle row; the receiver's own
    // pixels right of the occluder (front face 3.975 away).
    let row = |method: SssMethod| {
        let mut o = options(&s, w, h);
        o.settings.sss.method = method;
        // Without transmittance: the occluder would pass for the far side of a thin part.
        o.settings.transmittance.method = subsurface_render::TransmittanceMethod::Off;
        o.view = subsurface_render::DebugView::DiffuseBeforeSss;
        let mut r = Renderer::new(&ctx, &s, o).unwrap();
        r.render().unwrap();
        let depth = r.read_linear_depth().unwrap();
        let d = r.read_diffuse().unwrap();
        let start = (h / 2 * w) as usize;
        (0..w as usize)
            .filter(|x| (depth[start + x] - 3.975).abs() < 1e-3)
            .map(|x| (x as f32, d[start + x]))
            .collect::<Vec<_>>()
    };
    // Where channel c first reaches half its lit value, interpolated between pixels.
    let crossing = |px: &[(f32, [f32; 4])], c: usize| {
        let lit = px.iter().map(|p| p.1[c]).fold(0.0, f32::max);
        let i = px
            .iter()
            .position(|p| p.1[c] >= 0.5 * lit)
            .expect("a lit side");
        assert!(
            i > 0 && px[0].1[c] < 0.1 * lit,
            "channel {c}: no shadow before the edge"
        );
        let (a, b) = (px[i - 1], px[i]);
        a.0 + (0.5 * lit - a.1[c]) / (b.1[c] - a.1[c]) * (b.0 - a.0)
    };
    let plain = row(SssMethod::None);
    let scattered = row(SssMethod::Separable);
    // Scene units (mm) per pixel on the receiver's face.
    let mm_per_px = 2.0 * 3.975 * (10f32).to_radians().tan() / h as f32;
    let sin_t = (45f32).to_radians().sin() / 1.3;
    let red_mm = sin_t / (1.0 - sin_t * sin_t).sqrt() / 0.772;
    let shift: Vec<f32> = (0..3)
        .map(|c| (crossing(&scattered, c) - crossing(&plain, c)) * mm_per_px)
        .collect();
    eprintln!("shift of the penumbra, mm: {shift:?} (red predicted {red_mm:.3})");
    assert!((shift[0] / red_mm - 1.0).abs() < 0.05, "{shift:?}");
    for (c, ratio) in [(1, 0.772 / 1.05), (2, 0.772 / 1.49)] {
        let got = shift[c] / shift[0];
        assert!(
            (got - ratio).abs() < 0.03,
            "channel {c}: {got} of red, want {ratio}"
        );
    }
}

#[test]
fn linear_depth_matches_camera_distance() {
    let Some(ctx) = context() else { return };
    // The point light's target and intensity are the defaults: it has no direction.
    let s = scene(&format!(
        r#"
        {camera}
        {light}
        [[objects]]
        mesh = {{ shape = "slab", width = 1.0, height = 1.0, thickness = 0.1 }}
        "#,
        camera = camera_toml(2.0, 40.0, "far = 50.0"),
        light = light_toml("point", [0.0, 0.0, 1.0], 1.0, ""),
    ));
    let (w, h) = (64, 48);
    let mut r = Renderer::new(&ctx, &s, options(&s, w, h)).unwrap();
    r.render().unwrap();
    let depth = r.read_linear_depth().unwrap();
    // Front face at z = 0.05, camera at z = 2 looking down -z: linear (view) depth 1.95
    // everywhere on the face, not only at the centre (it is not the Euclidean distance).
    for (x, y) in [
        (w / 2, h / 2),
        (w / 2 + 8, h / 2 - 6),
        (w / 2 - 10, h / 2 + 5),
    ] {
        let d = depth[(y * w + x) as usize];
        assert!(
            (d - 1.95).abs() < 1e-4,
            "depth at ({x},{y}) = {d}, expected 1.95"
        );
    }
    assert_eq!(depth[0], 50.0, "background should hold the far plane");
    let sss = r.read_sss().unwrap();
    assert_eq!(sss[0][0], 0.0, "background is not skin");
    assert!(
        sss[(h / 2 * w + w / 2) as usize][0] > 0.0,
        "slab has the default skin material"
    );
}

#[test]
fn validation_errors_are_returned_not_logged() {
    let Some(ctx) = context() else { return };
    ctx.check().unwrap();
    // MAP_READ may only be combined with COPY_DST: wgpu reports a validation error.
    let _bad = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("deliberately invalid"),
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::VERTEX,
        mapped_at_creation: false,
    });
    let err = ctx.check().expect_err("validation error was swallowed");
    assert!(err.to_string().contains("validation"), "{err}");
    assert!(
        !err.to_string().contains('\n'),
        "error is not one line: {err}"
    );
    ctx.check().expect("errors are reported once");
}

#[test]
fn sizes_outside_the_device_limit_are_errors() {
    let Some(ctx) = context() else { return };
    let s = subsurface_render::Scene::default_scene();
    let max = ctx.max_texture_size();
    for (w, h) in [(0, 64), (64, 0), (max + 1, 64)] {
        let err = Renderer::new(&ctx, &s, options(&s, w, h))
            .err()
            .expect("accepted a bad size");
        let msg = err.to_string();
        assert!(msg.contains("width") || msg.contains("height"), "{msg}");
    }
}

#[test]
fn timestamps_report_each_pass() {
    let Some(ctx) = context() else { return };
    if !ctx.has_timestamps() {
        eprintln!("adapter has no timestamp queries");
        return;
    }
    let s = subsurface_render::Scene::default_scene();
    let mut r = Renderer::new(&ctx, &s, options(&s, 64, 64)).unwrap();
    let frame = r.render().unwrap();
    for name in ["shadow", "lighting", "tonemap"] {
        let t = frame
            .timings
            .iter()
            .find(|t| t.name == name)
            .unwrap_or_else(|| panic!("no {name} timing"));
        assert!(t.ms >= 0.0 && t.ms.is_finite(), "{name}: {}", t.ms);
    }
}

/// `Renderer::update` (the viewer's path for every edit) gives the same image as a renderer
/// created from scratch with the edited scene and options.
#[test]
fn update_matches_a_fresh_renderer() {
    let Some(ctx) = context() else { return };
    let scene = subsurface_render::Scene::default_scene();
    let mut edited = scene.clone();
    edited.desc.camera.position = [0.1, 0.05, 0.45];
    edited.desc.lights[0].intensity *= 0.5;
    edited.desc.lights[1].position[0] -= 0.1;
    let mut opts = options(&scene, 96, 64);
    let mut r = Renderer::new(&ctx, &scene, opts.clone()).unwrap();
    r.render().unwrap();
    opts.settings.sss.method = SssMethod::Gaussian6;
    opts.settings.exposure_ev = 0.5;
    update_matches_fresh(&ctx, &mut r, &edited, &opts, "camera, lights and settings");
}

/// Each transmittance method has its own lighting pipeline (the compiler drops the other
/// methods' code): `update` to another method must build that method's pipeline, giving the
/// image a fresh renderer gives, and back again the first image. Without the rebuild, the
/// `paper` pipeline read `diffusion`'s uniform and drew `paper`'s image.
#[test]
fn update_builds_the_pipeline_of_a_new_transmittance_method() {
    use subsurface_render::TransmittanceMethod;
    let Some(ctx) = context() else { return };
    let scene = subsurface_render::Scene::default_scene();
    let mut opts = options(&scene, 96, 64);
    opts.settings.transmittance.method = TransmittanceMethod::Paper;
    let mut r = Renderer::new(&ctx, &scene, opts.clone()).unwrap();
    let paper = r.render().unwrap().image;
    let mut diffusion_opts = opts.clone();
    diffusion_opts.settings.transmittance.method = TransmittanceMethod::Diffusion;
    let fresh = update_matches_fresh(&ctx, &mut r, &scene, &diffusion_opts, "to `diffusion`");
    assert_ne!(
        paper.as_raw(),
        fresh.as_raw(),
        "the backlit hand must look different with `diffusion`"
    );
    assert_update_gives(
        &mut r,
        &scene,
        &opts,
        &paper,
        "update() back to `paper` differs from the first frame",
    );
}

/// The viewer's bounce slider: `update` from no bounce to the bounce builds the flux pyramid
/// and binds it (a new lighting pass and a map layer more), giving a fresh renderer's image;
/// a light moved with the bounce on rewrites the pyramid's light cameras; back to no bounce
/// gives the first image again. At 96x64 the skin is too small on screen for a transmitted map,
/// so the pixels gather the bounce themselves; at 256x256 it is read from the map.
#[test]
fn update_turns_the_bounce_on_and_off() {
    let Some(ctx) = context() else { return };
    let scene = subsurface_render::Scene::default_scene();
    for (w, h) in [(96, 64), (256, 256)] {
        let mut off = options(&scene, w, h);
        off.settings.bounce.ring = 0;
        let mut r = Renderer::new(&ctx, &scene, off.clone()).unwrap();
        let first = r.render().unwrap().image;
        let mut on = off.clone();
        on.settings.bounce.ring = 2;
        let fresh = update_matches_fresh(&ctx, &mut r, &scene, &on, &format!("{w}x{h}: bounce"));
        assert_ne!(
            first.as_raw(),
            fresh.as_raw(),
            "{w}x{h}: the bounce changed nothing"
        );
        let mut moved = scene.clone();
        moved.desc.lights[0].position[0] += 0.05;
        update_matches_fresh(
            &ctx,
            &mut r,
            &moved,
            &on,
            &format!("{w}x{h}: a light moved"),
        );
        assert_update_gives(
            &mut r,
            &scene,
            &off,
            &first,
            &format!("{w}x{h}: update() back to no bounce"),
        );
    }
}

/// Moving the camera nearer makes the skin larger on screen, so the transmitted map's reduction
/// (texels of about 4 profile mm) grows: `update` must give the new map the frame a fresh
/// renderer gives, without new frame-sized targets.
#[test]
fn update_follows_the_transmitted_map_reduction() {
    let Some(ctx) = context() else { return };
    let scene = subsurface_render::Scene::default_scene();
    let opts = options(&scene, 128, 128);
    let mut r = Renderer::new(&ctx, &scene, opts.clone()).unwrap();
    r.render().unwrap();
    let before = r.targets.map_downsample();
    let mut nearer = scene.clone();
    nearer.desc.camera.position = [0.01, 0.0, 0.25];
    r.update(&nearer, &opts).unwrap();
    let after = r.targets.map_downsample();
    assert!(
        after > before,
        "reduction {before} before, {after} with the camera twice as near"
    );
    let updated = r.render().unwrap().image;
    let mut fresh = Renderer::new(&ctx, &nearer, opts).unwrap();
    assert_eq!(fresh.targets.map_downsample(), after);
    let fresh = fresh.render().unwrap().image;
    assert_eq!(
        updated.as_raw(),
        fresh.as_raw(),
        "update() and a new Renderer differ"
    );
}

/// The transmitted map's pass sums every light's transmitted light into two layers (diffuse; unscattered
/// and singly scattered) in one pass. The default scene's two lights copied (four shadowed
/// lights, each twice) must give twice what the two give, texel for texel, on the same
/// surfaces, and each copy must reach the texels its original reaches (layer 1's `a`); the
/// bounce pass fills the layer after them, on those surfaces too.
#[test]
fn the_lateral_pass_sums_every_lights_transmitted_light() {
    let Some(ctx) = context() else { return };
    let layers = |scene: &subsurface_render::Scene| {
        let mut r = Renderer::new(&ctx, scene, options(scene, 256, 256)).unwrap();
        r.render().unwrap();
        let map = &r.targets.map.as_ref().expect("no transmitted map").map;
        assert_eq!(
            map.depth_or_array_layers(),
            3,
            "the transmitted light's two layers and the bounce's"
        );
        (0..3)
            .map(|l| {
                let bytes = subsurface_render::readback::read_texture_layer(&ctx, map, l).unwrap();
                subsurface_render::readback::decode_float(map.format(), &bytes).0
            })
            .collect::<Vec<_>>()
    };
    let scene = subsurface_render::Scene::default_scene();
    let mut doubled = scene.clone();
    let lights = doubled.desc.lights.clone();
    let n = lights.len();
    doubled.desc.lights.extend(lights);
    let (once, twice) = (layers(&scene), layers(&doubled));
    let mut reached = 0;
    for layer in 0..2 {
        let mut lit = 0;
        for (a, b) in once[layer]
            .chunks_exact(4)
            .zip(twice[layer].chunks_exact(4))
        {
            if layer == 0 {
                assert!(a[3] == b[3], "layer {layer}: a texel's depth differs");
            } else {
                // Layer 1's `a`: the lights that reach the texel directly, a bit each; the
                // copies are lights n..2n.
                let (code, doubled_code) = (a[3] as u32, b[3] as u32);
                assert_eq!(
                    doubled_code,
                    code | (code << n),
                    "the lights that reach a texel, with the lights twice"
                );
                reached += usize::from(code != 0);
            }
            for c in 0..3 {
                let want = 2.0 * a[c];
                assert!(
                    (b[c] - want).abs() <= 1e-4 * want.abs() + 1e-12,
                    "layer {layer}: {} with the lights twice, {} once",
                    b[c],
                    a[c]
                );
            }
            if a[0] > 0.0 {
                lit += 1;
            }
        }
        assert!(lit > 50, "layer {layer}: only {lit} texels transmit light");
    }
    assert!(reached > 50, "only {reached} texels are reached by a light");
    // Every texel the map's pass drew holds the bounce and that depth.
    let mut bounced = 0;
    for (t, b) in once[0].chunks_exact(4).zip(once[2].chunks_exact(4)) {
        assert!(t[3] == b[3], "a texel's depth differs between the passes");
        if b[3] > 0.0 && b[0] > 0.0 {
            bounced += 1;
        }
    }
    assert!(bounced > 100, "only {bounced} texels received a bounce");
}

/// The transmitted map from its compute evaluation (`fs_surface`, then `cs_clear`, and
/// `cs_transmitted` and `cs_bounce` once per object over its box) against its fragment shaders
/// (`fs_transmitted`, `fs_bounce`): the same function at the same points, so the same numbers,
/// for `diffusion` (the transmitted light's two layers and the bounce's) and for `paper` (the
/// bounce's alone).
/// - The wedge is made half as translucent as the hand, so a dispatch that evaluated another
///   object's texels with its own uniform (the index test) would change them; a box too small
///   would leave texels empty.
/// - Each renderer draws a second frame from another camera, so texels the first frame's boxes
///   wrote and the second's do not cover must have been cleared.
/// - With all eight lights, each light has one invocation of a texel's eight
///   (`cs_transmitted`'s lanes), where with the scene's two it has four, which share its taps.
#[test]
fn the_transmitted_map_is_the_same_from_compute_and_fragment_shaders() {
    use subsurface_render::{MapEvaluation, TransmittanceMethod};
    let Some(ctx) = context() else { return };
    let mut scene = subsurface_render::Scene::default_scene();
    assert_eq!(scene.objects.len(), 2, "the hand and the wedge");
    scene.objects[1].material.translucency *= 0.5;
    let mut eight = scene.clone();
    let lights = eight.desc.lights.clone();
    eight.desc.lights = (0..subsurface_render::uniforms::MAX_LIGHTS)
        .map(|k| {
            let mut light = lights[k % 2].clone();
            // Apart, so that each light's map and taps differ: light k is its scene light moved
            // a little sideways, each at its own brightness.
            light.position[0] += 0.01 * k as f32;
            light.intensity *= 1.0 + 0.25 * k as f32;
            light.shadow_map_size = 256;
            light
        })
        .collect();
    for (scene, method, layer_count) in [
        (&scene, TransmittanceMethod::Diffusion, 3),
        (&scene, TransmittanceMethod::Paper, 1),
        (&eight, TransmittanceMethod::Diffusion, 3),
    ] {
        let lights = scene.desc.lights.len();
        let mut moved = scene.clone();
        moved.desc.camera.position[0] += 0.15;
        let frames = |pass: MapEvaluation| {
            let mut opts = options(scene, 256, 256);
            opts.settings.transmittance.method = method;
            opts.settings.transmitted_map.pass = pass;
            let mut r = Renderer::new(&ctx, scene, opts.clone()).unwrap();
            let read = |r: &mut Renderer| {
                r.render().unwrap();
                if method == TransmittanceMethod::Diffusion {
                    assert_eq!(
                        r.targets.map_computed(),
                        Some(pass == MapEvaluation::Compute),
                        "{pass}: evaluated elsewhere"
                    );
                }
                let map = &r.targets.map.as_ref().expect("no transmitted map").map;
                assert_eq!(map.depth_or_array_layers(), layer_count, "{method}");
                (0..layer_count)
                    .map(|l| {
                        let bytes =
                            subsurface_render::readback::read_texture_layer(&ctx, map, l).unwrap();
                        subsurface_render::readback::decode_float(map.format(), &bytes).0
                    })
                    .collect::<Vec<_>>()
            };
            let first = read(&mut r);
            r.update(&moved, &opts).unwrap();
            [first, read(&mut r)]
        };
        let (compute, fragment) = (
            frames(MapEvaluation::Compute),
            frames(MapEvaluation::Fragment),
        );
        for (frame, (compute, fragment)) in compute.iter().zip(&fragment).enumerate() {
            for (layer, (computed, fragment)) in compute.iter().zip(fragment).enumerate() {
                let at = format!("{method}, {lights} lights, frame {frame}, layer {layer}");
                let (mut lit, mut drawn) = (0, 0);
                for (a, b) in computed.chunks_exact(4).zip(fragment.chunks_exact(4)) {
                    assert!(a[3] == b[3], "{at}: a texel's depth differs");
                    for c in 0..3 {
                        assert!(
                            (a[c] - b[c]).abs() <= 1e-4 * b[c].abs() + 1e-9,
                            "{at}: {} computed, {} from the fragment shader",
                            a[c],
                            b[c]
                        );
                    }
                    drawn += usize::from(b[3] > 0.0);
                    lit += usize::from(b[0] > 0.0);
                }
                assert!(
                    drawn > 500 && lit > 50,
                    "{at}: {drawn} texels drawn, {lit} lit"
                );
            }
        }
    }
}

/// Contexts made, used and dropped on several threads at once, as `cargo test` does. NVIDIA's
/// Linux driver crashed the whole test process (SIGSEGV) here before `GpuContext` serialised
/// instance and device creation and teardown; lavapipe passes either way, so this guards the
/// GPU machines rather than CI.
#[test]
fn contexts_made_and_dropped_on_many_threads_all_render() {
    if context().is_none() {
        return;
    }
    let s = lit_sphere("shadow_map_size = 64");
    let lit: Vec<usize> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..4)
            .map(|_| {
                scope.spawn(|| {
                    (0..3)
                        .map(|_| {
                            let ctx = context().unwrap();
                            let mut r = Renderer::new(&ctx, &s, options(&s, 16, 16)).unwrap();
                            r.render().unwrap();
                            let diffuse = r.read_diffuse().unwrap();
                            diffuse.iter().filter(|c| luminance(**c) > 0.05).count()
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap())
            .collect()
    });
    assert_eq!(lit.len(), 12);
    assert!(
        lit.iter().all(|&n| n > 10 && n == lit[0]),
        "lit pixels per render: {lit:?}"
    );
}
