//! The frame plan's decisions, checked on the default scene and variations of it.

use super::*;

fn downsample(scene: &Scene, settings: &RenderSettings, w: u32, h: u32) -> u32 {
    map_downsample(scene, settings, w, h)
}

/// Each object's box on screen holds every vertex of it (the transmitted map's compute
/// dispatch covers only the box), is far smaller than the frame for the default scene's
/// hand and wedge, and is the whole frame for an object reaching behind the camera.
#[test]
fn screen_rects_hold_every_vertex() {
    let mut scene = Scene::default_scene();
    let (w, h) = (256, 192);
    let camera = camera_uniform(&scene, w, h);
    let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
    let rects = screen_rects(&scene, w, h);
    assert_eq!(rects.len(), scene.objects.len());
    for (o, rect) in scene.objects.iter().zip(&rects) {
        let [x0, y0, x1, y1] = rect.expect("the default scene's objects are in view");
        assert!(
            ((x1 - x0) * (y1 - y0)) < w * h / 2,
            "{:?}: box {x0},{y0}..{x1},{y1} of a {w}x{h} frame",
            o.name
        );
        for v in &o.mesh.vertices {
            let c = view_proj
                * o.transform
                    .transform_point3(Vec3::from(v.position))
                    .extend(1.0);
            let px = (c.x / c.w * 0.5 + 0.5) * w as f32;
            let py = (0.5 - c.y / c.w * 0.5) * h as f32;
            assert!(
                px >= x0 as f32 && px <= x1 as f32 && py >= y0 as f32 && py <= y1 as f32,
                "{:?}: vertex at ({px}, {py}) outside {x0},{y0}..{x1},{y1}",
                o.name
            );
        }
    }
    // The camera inside the hand's bounds, looking down the fingers to the wrist (the
    // bounds reach past the near plane in front and behind the eye).
    let (lo, hi) = scene.objects[0].world_bounds();
    let centre = (lo + hi) * 0.5;
    scene.desc.camera.position = centre.to_array();
    scene.desc.camera.target = (centre - Vec3::Y).to_array();
    scene.desc.camera.up = [0.0, 0.0, 1.0];
    assert_eq!(screen_rects(&scene, w, h)[0], Some([0, 0, w, h]));
}

/// The map's texels stay about `transmitted_map.texel_mm` on the skin: twice the pixels, twice
/// the reduction (up to 8), 2 for skin small on screen and none where it is smaller still.
#[test]
fn transmitted_map_reduction_follows_the_skin_on_screen() {
    let scene = Scene::default_scene();
    let s = high(&scene);
    let (r256, r512) = (
        downsample(&scene, &s, 256, 256),
        downsample(&scene, &s, 512, 512),
    );
    assert_eq!((r256, r512), (3, 6));
    assert_eq!(downsample(&scene, &s, 1280, 720), 8);
    // Small on screen: two pixels a texel while that stays within MAX_TEXEL_FACTOR.
    assert_eq!(downsample(&scene, &s, 64, 64), 2);
    assert_eq!(downsample(&scene, &s, 32, 32), 1);
    let mut per_pixel = s.clone();
    per_pixel.transmitted_map.texel_mm = 0.0;
    assert_eq!(downsample(&scene, &per_pixel, 512, 512), 1);
}

/// Skin whose texels would span more than `MAX_TEXEL_FACTOR` times `transmitted_map.texel_mm`
/// gathers the taps itself: none of the default scene's objects, and every object but the
/// nearest once moved back to six times its distance along the view (the map stays sized
/// for the nearest).
#[test]
fn skin_too_far_for_the_map_gathers_its_own_taps() {
    let scene = Scene::default_scene();
    let s = high(&scene);
    let n = downsample(&scene, &s, 1280, 720);
    let flags = lateral_taps_objects(&scene, &s, 1280, 720, n);
    assert_eq!(flags.len(), scene.objects.len());
    assert!(flags.iter().all(|&t| !t), "{flags:?}");
    let pixel_mm = skin_pixel_mm(&scene, 1280, 720);
    let nearest = (0..pixel_mm.len())
        .filter(|&i| pixel_mm[i].is_some())
        .min_by(|&a, &b| pixel_mm[a].partial_cmp(&pixel_mm[b]).unwrap())
        .unwrap();
    let camera = camera_uniform(&scene, 1280, 720);
    let (eye, forward) = (Vec3::from(camera.position), Vec3::from(camera.forward));
    let mut far = scene.clone();
    for (i, o) in far.objects.iter_mut().enumerate() {
        if i != nearest {
            let (lo, hi) = o.world_bounds();
            let depth = ((lo + hi) * 0.5 - eye).dot(forward);
            o.transform = Mat4::from_translation(forward * 5.0 * depth) * o.transform;
        }
    }
    assert_eq!(downsample(&far, &s, 1280, 720), n);
    let flags = lateral_taps_objects(&far, &s, 1280, 720, n);
    for (i, flag) in flags.iter().enumerate() {
        let skin = pixel_mm[i].is_some();
        assert_eq!(*flag, skin && i != nearest, "object {i}: {flags:?}");
    }
    // Without a map nothing is marked.
    assert!(
        lateral_taps_objects(&far, &s, 1280, 720, 1)
            .iter()
            .all(|&t| !t)
    );
}

/// No map where nothing reads it: other transmittance methods without the bounce, no
/// taps, texture-space diffusion (its transmitted light comes from UV space), no
/// translucent object in view.
#[test]
fn no_transmitted_map_where_nothing_reads_it() {
    let scene = Scene::default_scene();
    let mut s = high(&scene);
    let mut paper = s.clone();
    paper.transmittance.method = TransmittanceMethod::Paper;
    // The bounce alone is gathered on the map.
    assert_eq!(downsample(&scene, &paper, 512, 512), 6);
    s.bounce = crate::settings::BounceSettings::OFF;
    paper.bounce = crate::settings::BounceSettings::OFF;
    let mut no_taps = s.clone();
    no_taps.transmittance.lateral_taps = 0;
    // `diffusion` without lateral taps still evaluates its chords on the map.
    assert_eq!(downsample(&scene, &no_taps, 512, 512), 6);
    let mut texture = s.clone();
    texture.sss.method = SssMethod::Texture;
    for settings in [paper, texture] {
        assert_eq!(downsample(&scene, &settings, 512, 512), 1);
    }
    let mut away = scene.clone();
    let c = &mut away.desc.camera;
    c.target = [c.position[0], c.position[1], c.position[2] + 1.0];
    assert_eq!(downsample(&away, &s, 512, 512), 1);
}

/// `scene`'s settings at `Quality::High`: the transmitted map and the bounce both run.
fn high(scene: &Scene) -> RenderSettings {
    let mut desc = scene.desc.clone();
    desc.set_quality(crate::settings::Quality::High).unwrap();
    desc.render
}

fn plan(scene: &Scene, settings: &RenderSettings) -> FramePlan {
    FramePlan::new(scene, settings, AdapterFeatures::ALL)
}

/// The frame's pipeline gathers the taps itself only without a map (objects too far for
/// the map get that variant through `taps_objects`).
#[test]
fn the_lateral_light_comes_from_the_map_wherever_there_is_one() {
    let scene = Scene::default_scene();
    let mut s = high(&scene);
    assert!(plan(&scene, &s).map_downsample > 1);
    assert_eq!(plan(&scene, &s).lighting.lateral, 1);
    s.transmitted_map.texel_mm = 0.0;
    assert_eq!(plan(&scene, &s).lighting.lateral, 2);
    s.transmittance.lateral_taps = 0;
    assert_eq!(plan(&scene, &s).lighting.lateral, 0);
    s.transmittance.lateral_taps = 12;
    s.transmittance.method = TransmittanceMethod::Paper;
    assert_eq!(plan(&scene, &s).lighting.lateral, 0);
}

/// The map pass evaluates the transmitted light only for `diffusion` with taps, a map
/// and a shadowed light, into two layers before the bounce's; the bounce alone takes a
/// map of one layer, and an adapter without compute storage has no bounce.
#[test]
fn the_transmitted_light_takes_two_layers_before_the_bounce() {
    let scene = Scene::default_scene();
    let mut s = high(&scene);
    s.bounce = crate::settings::BounceSettings::OFF;
    let p = plan(&scene, &s);
    assert!(p.map_holds_transmitted);
    assert_eq!((p.map.layers, p.bounce_layer), (TRANSMITTED_LAYERS, None));
    let mut unshadowed = scene.clone();
    for l in &mut unshadowed.desc.lights {
        l.shadow_map_size = 0;
    }
    let p = plan(&unshadowed, &s);
    assert!(!p.map_holds_transmitted, "no light has a shadow map");
    assert_eq!(p.map, TransmittedMapShape::NONE);
    let with_bounce = high(&scene);
    assert!(with_bounce.bounce.enabled());
    let p = plan(&scene, &with_bounce);
    assert_eq!(p.bounce_layer, Some(TRANSMITTED_LAYERS));
    assert_eq!(p.map.layers, TRANSMITTED_LAYERS + 1);
    assert_eq!(p.lighting.bounce, 1);
    let mut paper = with_bounce.clone();
    paper.transmittance.method = TransmittanceMethod::Paper;
    let p = plan(&scene, &paper);
    assert!(!p.map_holds_transmitted);
    assert_eq!((p.bounce_layer, p.map.layers), (Some(0), 1));
    let none = AdapterFeatures {
        compute_storage: false,
        masked_branches: false,
    };
    let p = FramePlan::new(&scene, &with_bounce, none);
    assert_eq!(
        (p.bounce_ring, p.bounce_layer, p.lighting.bounce),
        (0, None, 0)
    );
    assert!(!p.map.compute);
    // Without lateral taps the map still holds the chords' light.
    let mut no_taps = with_bounce.clone();
    no_taps.transmittance.lateral_taps = 0;
    let p = plan(&scene, &no_taps);
    assert!(p.map_holds_transmitted);
    assert_eq!(p.lighting.lateral, lateral::MAP);
    assert_eq!(p.taps_objects_lateral, lateral::NONE);
    for off in [
        |s: &mut RenderSettings| s.transmitted_map.texel_mm = 0.0,
        |s: &mut RenderSettings| s.transmittance.method = TransmittanceMethod::Paper,
    ] {
        let mut other = with_bounce.clone();
        off(&mut other);
        assert!(!plan(&scene, &other).map_holds_transmitted);
    }
}

/// The lights' chords at the pixels the map misses move to the outline pass where asked, and
/// by default only on an adapter that masks its branches; only translucent objects that read
/// the map are drawn there, and a frame without a map has no outline pass.
#[test]
fn the_outline_pass_runs_where_the_map_is_read_and_asked_for() {
    let mut scene = Scene::default_scene();
    let mut s = high(&scene);
    let cpu = AdapterFeatures {
        masked_branches: true,
        ..AdapterFeatures::ALL
    };
    assert_eq!(s.transmitted_map.outlines, OutlineChords::Auto);
    assert!(!plan(&scene, &s).lighting.outline_pass);
    let p = FramePlan::new(&scene, &s, cpu);
    assert!(p.lighting.outline_pass);
    assert_eq!(p.outline_objects, vec![true; scene.objects.len()]);
    s.transmitted_map.outlines = OutlineChords::Lighting;
    assert!(!FramePlan::new(&scene, &s, cpu).lighting.outline_pass);
    s.transmitted_map.outlines = OutlineChords::Pass;
    assert!(plan(&scene, &s).lighting.outline_pass);
    scene.objects[1].material.translucency = 0.0;
    let p = plan(&scene, &s);
    assert_eq!(p.outline_objects, vec![true, false]);
    s.transmitted_map.texel_mm = 0.0;
    let p = plan(&scene, &s);
    assert!(!p.lighting.outline_pass);
    assert_eq!(p.outline_objects, vec![false; 2]);
}

/// By default the map is evaluated by compute shaders on a GPU and by the map's fragment shader
/// on an adapter that masks its branches; an explicit choice holds on either, and an adapter
/// without compute storage evaluates in the fragment shader whatever is asked.
#[test]
fn the_map_is_evaluated_in_compute_on_gpus_and_in_fragments_on_cpus() {
    let scene = Scene::default_scene();
    let mut s = high(&scene);
    let cpu = AdapterFeatures {
        masked_branches: true,
        ..AdapterFeatures::ALL
    };
    let bare = AdapterFeatures {
        compute_storage: false,
        masked_branches: false,
    };
    assert_eq!(s.transmitted_map.pass, MapEvaluation::Auto);
    let computed = |s: &RenderSettings, f: AdapterFeatures| {
        let p = FramePlan::new(&scene, s, f);
        assert!(p.map.layers > 0);
        p.map.compute
    };
    assert!(computed(&s, AdapterFeatures::ALL));
    assert!(!computed(&s, cpu));
    s.transmitted_map.pass = MapEvaluation::Compute;
    assert!(computed(&s, cpu));
    assert!(!computed(&s, bare));
    s.transmitted_map.pass = MapEvaluation::Fragment;
    assert!(!computed(&s, AdapterFeatures::ALL));
}
