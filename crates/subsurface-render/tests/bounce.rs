//! The bounce (passes::bounce) against the radiative transfer between two planes, integrated
//! here in closed form per point: a lit floor and a wall standing on it, the wall's face
//! taking in what the floor reflects.

use crate::common;

use common::{context, options, scene};
use subsurface_profile::oracle::bounce::{self as oracle, FluxCell, FluxLevel, Gather};
use subsurface_render::{GpuContext, Renderer, Scene, gpu_scene, readback};

const SIZE: u32 = 128;
const TAN_HALF_FOV: f32 = 0.363_970_23; // tan(20 degrees)
const CAMERA: [f32; 3] = [0.25, 0.05, 0.0];
/// The wall's face toward the camera (a 1 mm wall centred on x = 0).
const FACE_X: f32 = 0.0005;
const FLOOR_HALF: f32 = 0.15;

/// A 300 mm square floor (top face at y = 0) lit straight from above by a directional light of
/// irradiance 1, a 1 mm thick, 100 mm high wall standing on it across x = 0, both of one
/// material without specular, no SSS, transmittance or ambient light; the camera looks at the
/// wall's +x face from 250 mm.
fn floor_and_wall(ring: u32) -> Scene {
    scene(&format!(
        r#"
        [camera]
        position = {CAMERA:?}
        target = [0.0, 0.05, 0.0]
        fov_y_deg = 40.0
        near = 0.01
        far = 2.0
        [render]
        ambient = [0.0, 0.0, 0.0]
        # Lambertian: the oracle's wall reflects its albedo, not what a 1 mm sheet of the
        # default skin medium keeps of it (sss.thin_parts).
        sss = {{ method = "none", thin_parts = false }}
        transmittance = {{ method = "off" }}
        bounce = {{ ring = {ring} }}
        [[lights]]
        kind = "directional"
        position = [0.0, 0.5, 0.0]
        target = [0.0, 0.0, 0.0]
        intensity = 1.0
        shadow_map_size = 1024
        shadow_bias = 0.0002
        [[objects]]
        mesh = {{ shape = "slab", width = 0.3, height = 0.3, thickness = 0.004 }}
        mm_per_unit = 1000.0
        translation = [0.0, -0.002, 0.0]
        rotation_deg = [-90.0, 0.0, 0.0]
        [objects.material]
        albedo = [0.8, 0.8, 0.8]
        specular = 0.0
        [[objects]]
        mesh = {{ shape = "slab", width = 0.2, height = 0.1, thickness = 0.001 }}
        mm_per_unit = 1000.0
        translation = [0.0, 0.05, 0.0]
        rotation_deg = [0.0, 90.0, 0.0]
        [objects.material]
        albedo = [0.8, 0.8, 0.8]
        specular = 0.0
        "#
    ))
}

fn rendered(ring: u32) -> Renderer {
    let ctx = context().unwrap();
    let s = floor_and_wall(ring);
    let mut r = Renderer::new(&ctx, &s, options(&s, SIZE, SIZE)).unwrap();
    r.render().unwrap();
    r
}

fn diffuse(ring: u32) -> Vec<[f32; 4]> {
    rendered(ring).read_diffuse().unwrap()
}

/// Level `level` of the first shadow layer's pyramid, read back.
fn read_level(ctx: &GpuContext, r: &Renderer, level: u32) -> FluxLevel {
    let p = r.flux_pyramid().expect("the bounce is on");
    let read = |t: &wgpu::Texture| {
        let bytes = readback::read_texture_level(ctx, t, 0, level).unwrap();
        readback::decode_float(t.format(), &bytes).0
    };
    let (pos, nrm, spread) = (read(&p.position), read(&p.normal), read(&p.spread));
    let size = (p.position.width() >> level).max(1) as usize;
    let cells = (0..size * size)
        .map(|k| FluxCell {
            position_sum: [0, 1, 2].map(|c| pos[4 * k + c] as f64),
            flux: pos[4 * k + 3] as f64,
            normal_sum: [0, 1, 2].map(|c| nrm[4 * k + c] as f64),
            reflected: nrm[4 * k + 3] as f64,
            spread: spread[k] as f64,
        })
        .collect();
    FluxLevel { size, cells }
}

/// Where pixel row `j` meets the wall's face (its height, at the image's centre column).
fn wall_height(j: u32) -> f32 {
    let ndc_y = 1.0 - (j as f32 + 0.5) / SIZE as f32 * 2.0;
    CAMERA[1] + (CAMERA[0] - FACE_X) * ndc_y * TAN_HALF_FOV
}

/// What the lit floor in front of the face (x > FACE_X) sends the face's point at height `y`
/// (z = 0) per unit of the floor's radiosity: (1 / pi) times the integral of
/// cos(floor) cos(face) / d^2 over the floor, cos(floor) = y / d and cos(face) = (x - FACE_X) / d.
/// The integral over z is closed form: int dz / (a^2 + z^2)^2 over [-h, h] with a^2 = dx^2 + y^2.
fn floor_to_face(y: f32) -> f64 {
    let (y, h) = (y as f64, FLOOR_HALF as f64);
    let steps = 20_000;
    let dx = (h - FACE_X as f64) / steps as f64;
    (0..steps)
        .map(|i| {
            let x = (i as f64 + 0.5) * dx;
            let a2 = x * x + y * y;
            let a = a2.sqrt();
            let z = h / (a2 * (a2 + h * h)) + (h / a).atan() / (a2 * a);
            y * x * z * dx
        })
        .sum::<f64>()
        / std::f64::consts::PI
}

/// The face takes in what the floor reflects: per row, the bounce on the wall (the image with
/// it less the image without) against the floor's radiosity (its albedo, measured on the floor
/// pixels, times the irradiance of 1) times the form factor, times the face's albedo again.
/// Measured: 0.90 (5 mm up) to 1.08 (95 mm) of the exact transfer; the rows within 3 mm of the
/// floor, whose pixels and map texels straddle the corner, are left out.
#[test]
fn a_wall_takes_in_what_the_lit_floor_reflects() {
    if context().is_none() {
        return;
    }
    let (on, off) = (diffuse(2), diffuse(0));
    let at = |img: &[[f32; 4]], i: u32, j: u32| img[(j * SIZE + i) as usize][1];
    // The floor in front of the wall fills the bottom rows: its albedo under irradiance 1.
    let centre = SIZE / 2 - 4..SIZE / 2 + 4;
    let albedo = centre.clone().map(|i| at(&off, i, SIZE - 2)).sum::<f32>() / 8.0;
    assert!(
        (0.2..=1.0).contains(&albedo),
        "the floor's diffuse {albedo}"
    );
    let mut checked = 0;
    for j in 0..SIZE {
        let y = wall_height(j);
        if !(0.005..=0.095).contains(&y) {
            continue;
        }
        let bounce = centre
            .clone()
            .map(|i| at(&on, i, j) - at(&off, i, j))
            .sum::<f32>()
            / 8.0;
        let want = (albedo * albedo) as f64 * floor_to_face(y);
        let ratio = bounce as f64 / want;
        eprintln!(
            "y {:5.1} mm: bounce {bounce:.4}, exact {want:.4}, ratio {ratio:.3}",
            y * 1e3
        );
        assert!(
            (0.85..=1.15).contains(&ratio),
            "at {:.1} mm up the wall the bounce is {bounce:.4}, the exact transfer {want:.4}",
            y * 1e3
        );
        checked += 1;
    }
    assert!(checked > 20, "only {checked} rows on the wall");
}

/// A lone convex object sends nothing to itself: its lit cells face away from every point
/// they could reach through the air.
#[test]
fn a_convex_object_gets_no_bounce_from_itself() {
    if context().is_none() {
        return;
    }
    let sphere = |ring: u32| {
        let s = common::white_object_scene(
            &common::camera_toml(0.3, 20.0, "near = 0.05\nfar = 2.0"),
            [0.3, 0.2, -1.0],
            512,
            "{ shape = \"sphere\", radius = 0.02, segments = 64 }",
            "skin1",
        );
        let mut s = s;
        s.desc.render.bounce.ring = ring;
        let ctx = context().unwrap();
        let mut r = Renderer::new(&ctx, &s, options(&s, 96, 96)).unwrap();
        r.render().unwrap();
        r.read_diffuse().unwrap()
    };
    let (on, off) = (sphere(4), sphere(0));
    let most = on
        .iter()
        .zip(&off)
        .map(|(a, b)| (a[0] - b[0]).abs())
        .fold(0.0f32, f32::max);
    let lit = off.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    assert!(lit > 0.05, "the sphere is lit ({lit})");
    assert!(most < 1e-3 * lit, "the sphere bounced {most} onto itself");
}

/// The GPU pyramid against the CPU oracle (`subsurface_profile::oracle::bounce`): its finest
/// level holds the light's whole flux across the beam (irradiance 1 on the 300 mm floor and
/// the wall's top: 0.09 m^2), every level above is the sum of the one below, and the bounce on
/// the wall is the oracle's gather over the GPU's own cells (measured within 1.5 %; the
/// oracle caught the GPU's annulus reading the inner cells twice where the hole began past
/// the map's edge: 1.7x on the wall).
#[test]
fn the_pyramid_and_the_gather_match_the_cpu_oracle() {
    if context().is_none() {
        return;
    }
    let (r, off) = (rendered(2), diffuse(0));
    let on = r.read_diffuse().unwrap();
    let levels: Vec<FluxLevel> = (0..r.flux_pyramid().unwrap().position.mip_level_count())
        .map(|k| read_level(r.context(), &r, k))
        .collect();
    let total: f64 = levels[0].cells.iter().map(|c| c.flux).sum();
    assert!(
        (total / 0.09 - 1.0).abs() < 0.02,
        "the finest level holds {total} m^2 of flux, the beam 0.09"
    );
    for k in 1..levels.len() {
        let want = oracle::downsample(&levels[k - 1]);
        assert_eq!(want.size, levels[k].size);
        for (a, b) in levels[k].cells.iter().zip(&want.cells) {
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-5 * (x.abs() + y.abs()) + 1e-12;
            assert!(
                close(a.flux, b.flux)
                    && close(a.reflected, b.reflected)
                    && close(a.spread, b.spread)
                    && (0..3).all(|c| close(a.position_sum[c], b.position_sum[c])),
                "level {k}: {a:?} against the sum of its children {b:?}"
            );
        }
    }
    // The oracle's gather at the wall's face, where the light's map puts it.
    let scene = floor_and_wall(2);
    let setup = gpu_scene::light_setup(&scene, &scene.desc.render).unwrap();
    let (view_proj, origin) = (setup.layers[0].view_proj, setup.layers[0].origin);
    let size = scene.desc.lights[0].shadow_map_size;
    let cells = levels[0].size as f64 * size as f64 / setup.atlas_size as f64;
    let at_light = |p: glam::Vec3| {
        let c = view_proj * p.extend(1.0);
        let uv = glam::Vec2::new(c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5);
        [uv.x as f64 * cells, uv.y as f64 * cells]
    };
    // The finest cell's width: the map's width across the beam over its cells.
    let across = |x: f32| {
        let c = view_proj.inverse() * glam::Vec4::new(x, 0.0, 0.5, 1.0);
        c.truncate() / c.w
    };
    let cell = (across(1.0) - across(-1.0)).length() as f64 / cells;
    let first = ((2.0 / (cell * 1e3)).log2().round().max(0.0)) as usize;
    let at = |img: &[[f32; 4]], i: u32, j: u32| img[(j * SIZE + i) as usize][1];
    let albedo = (SIZE / 2 - 4..SIZE / 2 + 4)
        .map(|i| at(&off, i, SIZE - 2))
        .sum::<f32>() as f64
        / 8.0;
    let down = [0.0, 1.0, 0.0];
    let mut checked = 0;
    for j in 0..SIZE {
        let y = wall_height(j);
        // Within 8 mm of the floor the pixel's own height spans a tenth of it.
        if !(0.008..=0.095).contains(&y) {
            continue;
        }
        // The oracle at each of the 8 columns' points on the face (the camera's right is -z).
        let e = (SIZE / 2 - 4..SIZE / 2 + 4)
            .map(|i| {
                let ndc_x = (i as f32 + 0.5) / SIZE as f32 * 2.0 - 1.0;
                let z = -(CAMERA[0] - FACE_X) * ndc_x * TAN_HALF_FOV;
                let p = glam::Vec3::new(FACE_X, y, z);
                oracle::gather(
                    &levels,
                    &Gather {
                        at: at_light(p),
                        cells,
                        first,
                        ring: 2.0,
                        cell_area: cell * cell,
                        point: p.to_array().map(f64::from),
                        normal: [1.0, 0.0, 0.0],
                        light_origin: origin.to_array().map(f64::from),
                        to_light: &|_| down,
                        albedo: [albedo; 3],
                        reflection: &|_, _, _| 0.0,
                    },
                )[1]
            })
            .sum::<f64>()
            / 8.0;
        let bounce = (SIZE / 2 - 4..SIZE / 2 + 4)
            .map(|i| at(&on, i, j) - at(&off, i, j))
            .sum::<f32>() as f64
            / 8.0;
        let want = albedo * e;
        eprintln!("y {:5.1} mm: GPU {bounce:.4}, oracle {want:.4}", y * 1e3);
        assert!(
            (bounce / want - 1.0).abs() < 0.03,
            "at {:.1} mm up the wall the GPU's bounce is {bounce:.4}, the oracle's {want:.4}",
            y * 1e3
        );
        checked += 1;
    }
    assert!(checked > 20);
}
