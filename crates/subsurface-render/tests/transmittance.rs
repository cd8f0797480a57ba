//! Transmittance through thin parts (Jimenez et al. 2010) measured in rendered images against
//! the analytic T(s) of the skin profile.

use crate::common;

use common::{camera_toml, context, options, white_object_scene};
use subsurface_profile::SumOfGaussians;
use subsurface_profile::oracle::transmitted::SlabTransmission;
use subsurface_profile::specular::{rough_transmittance, schlick};
use subsurface_render::SssMethod;
use subsurface_render::{DEFAULT_MAP_TEXEL_MM, TransmittanceMethod};
use subsurface_render::{DebugView, Renderer, Scene};

const SHRINK: f32 = 0.0001; // 0.1 mm at 1000 mm per unit

/// A scene lit only from behind (-z) by a directional light of irradiance 1, seen from +z.
fn backlit(object: &str, shadow_map_size: u32) -> Scene {
    backlit_material(object, shadow_map_size, "skin")
}

fn backlit_material(object: &str, shadow_map_size: u32, profile: &str) -> Scene {
    // The normal shrink is SHRINK.
    white_object_scene(
        &camera_toml(0.3, 20.0, "near = 0.05\nfar = 2.0"),
        [0.0, 0.0, -1.0],
        shadow_map_size,
        object,
        profile,
    )
}

/// One frame of `scene` without SSS, with transmittance `method`.
fn render(scene: &Scene, w: u32, h: u32, method: TransmittanceMethod) -> Renderer {
    let ctx = context().unwrap();
    let mut opts = options(scene, w, h);
    opts.settings.sss.method = SssMethod::None;
    opts.settings.transmittance.method = method;
    let mut r = Renderer::new(&ctx, scene, opts).unwrap();
    r.render().unwrap();
    r
}

fn render_diffuse(
    scene: &Scene,
    w: u32,
    h: u32,
    method: TransmittanceMethod,
) -> (Vec<[f32; 4]>, Vec<f32>) {
    let r = render(scene, w, h, method);
    (r.read_diffuse().unwrap(), r.read_linear_depth().unwrap())
}

fn skin_t(s_mm: f32) -> [f32; 3] {
    SumOfGaussians::skin()
        .transmittance(s_mm as f64)
        .map(|v| v as f32)
}

/// Each channel of `got` within 0.002 + 3% of `want` (the `model`'s transmitted light).
fn assert_transmits(got: [f32; 4], want: [f32; 3], model: &str) {
    for c in 0..3 {
        assert!(
            (got[c] - want[c]).abs() < 0.002 + 0.03 * want[c],
            "channel {c}: {} vs {model} {}",
            got[c],
            want[c]
        );
    }
}

/// The prism of 000_* (Figure 6b): 0 mm thick at its left edge, 8 mm at its right.
#[test]
fn backlit_wedge_follows_t_of_s() {
    if context().is_none() {
        return;
    }
    let (length, max_t) = (0.08f32, 0.008f32);
    let s = backlit(
        &format!(
            "{{ shape = \"wedge\", length = {length}, height = 0.04, max_thickness = {max_t} }}"
        ),
        2048,
    );
    let (w, h) = (256u32, 160u32);
    let (diffuse, depth) = render_diffuse(&s, w, h, TransmittanceMethod::Paper);
    let focal = 0.5 * h as f32 / (10f32).to_radians().tan();
    // Both faces slope by atan(max_t / 2 / length); E = 0.3 + cos(slope) for light along -z.
    let e = 0.3 + (max_t * 0.5 / length).atan().cos();
    let y = h / 2;
    let mut samples = Vec::new(); // (thickness mm, measured T)
    for x in 0..w {
        let i = (y * w + x) as usize;
        if depth[i] > 1.0 {
            continue; // background
        }
        let world_x = (x as f32 + 0.5 - w as f32 * 0.5) * depth[i] / focal;
        let thickness_mm = (world_x + length * 0.5) / length * max_t * 1000.0;
        // Skip the ends, where the thickness filter straddles the silhouette.
        if !(0.4..=7.6).contains(&thickness_mm) {
            continue;
        }
        let d = diffuse[i];
        samples.push((
            thickness_mm - SHRINK * 1000.0,
            [d[0] / e, d[1] / e, d[2] / e],
        ));
    }
    assert!(
        samples.len() > 80,
        "too few wedge pixels: {}",
        samples.len()
    );
    let mut worst = 0.0f32;
    for (s_mm, t) in &samples {
        let want = skin_t(*s_mm);
        for c in 0..3 {
            // Tolerance: 0.02 absolute plus 10% (f16 targets, LUT, shadow-map texels).
            let err = (t[c] - want[c]).abs();
            assert!(
                err < 0.02 + 0.1 * want[c],
                "s = {s_mm:.2} mm, channel {c}: rendered {} vs T(s) {}",
                t[c],
                want[c]
            );
            worst = worst.max(err);
        }
    }
    eprintln!(
        "wedge: {} samples, worst |T_rendered - T(s)| = {worst:.4}",
        samples.len()
    );
    // Monotone: thicker transmits less (allowing f16 noise), and red/green grows with s.
    for pair in samples.windows(8).step_by(8) {
        let (a, b) = (pair[0], pair[7]);
        assert!(
            b.1[0] <= a.1[0] + 2e-3,
            "red not decreasing: {a:?} -> {b:?}"
        );
    }
    let ratio = |t: [f32; 3]| t[0] / t[1].max(1e-6);
    let thin = samples.iter().find(|(s, _)| *s > 0.5).unwrap();
    let thick = samples.iter().rev().find(|(s, _)| *s < 3.0).unwrap();
    assert!(
        ratio(thick.1) > 2.0 * ratio(thin.1),
        "no yellow-to-red shift: thin {thin:?}, thick {thick:?}"
    );
}

#[test]
fn backlit_slab_transmits_the_analytic_colour() {
    if context().is_none() {
        return;
    }
    let thickness = 0.003; // 3 mm
    let s = backlit(
        &format!("{{ shape = \"slab\", width = 0.05, height = 0.05, thickness = {thickness} }}"),
        1024,
    );
    let (w, h) = (64u32, 64u32);
    let (diffuse, _) = render_diffuse(&s, w, h, TransmittanceMethod::Paper);
    let got = diffuse[(h / 2 * w + w / 2) as usize];
    let want = skin_t(thickness * 1000.0 - SHRINK * 1000.0).map(|t| t * 1.3);
    assert_transmits(got, want, "analytic");
    // Beer-Lambert with skin1's extinction: exp(-sigma_t s) x E, s measured from the shaded
    // point itself (only `paper` keeps 000_*'s thickness from the shrunk point).
    let (diffuse, _) = render_diffuse(&s, w, h, TransmittanceMethod::Beer);
    let got = diffuse[(h / 2 * w + w / 2) as usize];
    let sigma_t = [0.772f32, 1.05, 1.49];
    let want = sigma_t.map(|s| (-s * thickness * 1000.0).exp() * 1.3);
    assert_transmits(got, want, "Beer-Lambert");
}

#[test]
fn lights_without_shadow_maps_add_no_transmittance() {
    if context().is_none() {
        return;
    }
    let s = backlit(
        "{ shape = \"slab\", width = 0.05, height = 0.05, thickness = 0.001 }",
        0,
    );
    let (diffuse, depth) = render_diffuse(&s, 64, 64, TransmittanceMethod::Paper);
    for (d, z) in diffuse.iter().zip(&depth) {
        if *z < 1.0 {
            assert_eq!(
                &d[..3],
                &[0.0, 0.0, 0.0],
                "light without shadow map transmitted {d:?}"
            );
        }
    }
}

#[test]
fn transmittance_reddens_thin_parts_and_stays_finite() {
    let Some(ctx) = context() else { return };
    let scene = Scene::default_scene();
    let render = |method| {
        let mut opts = options(&scene, 192, 108);
        opts.settings.transmittance.method = method;
        let mut r = Renderer::new(&ctx, &scene, opts).unwrap();
        r.render().unwrap();
        (
            r.read_diffuse().unwrap(),
            r.read_specular().unwrap(),
            r.read_sss().unwrap(),
        )
    };
    let (on, spec, mask) = render(TransmittanceMethod::Paper);
    let (off, _, _) = render(TransmittanceMethod::Off);
    for v in on.iter().chain(spec.iter()) {
        assert!(
            v.iter().all(|c| c.is_finite() && *c >= 0.0),
            "NaN, Inf or negative radiance: {v:?}"
        );
    }
    let mean = |img: &[[f32; 4]], c: usize| {
        let px: Vec<f32> = img
            .iter()
            .zip(&mask)
            .filter(|(_, m)| m[0] > 0.0)
            .map(|(p, _)| p[c])
            .collect();
        px.iter().sum::<f32>() / px.len() as f32
    };
    let (r_on, g_on, r_off, g_off) = (mean(&on, 0), mean(&on, 1), mean(&off, 0), mean(&off, 1));
    eprintln!(
        "skin mean red {r_off:.4} -> {r_on:.4}, red/green {:.3} -> {:.3}",
        r_off / g_off,
        r_on / g_on
    );
    assert!(
        r_on > 1.2 * r_off,
        "transmittance adds little red: {r_off} -> {r_on}"
    );
    assert!(
        r_on / g_on > 1.1 * (r_off / g_off),
        "transmitted light is not redder"
    );
}

/// T(s) comes from the material's own profile: a marble slab (Jensen et al. 2001's measured
/// coefficients, fitted with Gaussians) transmits nearly white light where skin turns red.
#[test]
fn transmitted_colour_follows_the_material_profile() {
    if context().is_none() {
        return;
    }
    let slab = "{ shape = \"slab\", width = 0.05, height = 0.05, thickness = 0.004 }";
    let centre = |profile: &str| {
        let (d, _) = render_diffuse(
            &backlit_material(slab, 1024, profile),
            32,
            32,
            TransmittanceMethod::Paper,
        );
        d[16 * 32 + 16]
    };
    let skin = centre("skin");
    let marble = centre("marble");
    let rg = |c: [f32; 4]| c[0] / c[1].max(1e-6);
    eprintln!(
        "4 mm slab: skin {skin:?} (r/g {:.2}), marble {marble:?} (r/g {:.2})",
        rg(skin),
        rg(marble)
    );
    assert!(
        marble[1] > 0.01,
        "marble transmits almost nothing: {marble:?}"
    );
    assert!(
        rg(skin) > 3.0 * rg(marble),
        "marble is as red as skin: skin {skin:?}, marble {marble:?}"
    );
    assert!(
        rg(marble) < 2.0,
        "marble should transmit nearly white light: {marble:?}"
    );
}

/// The thickness debug view writes, per pixel, the thickness the transmittance uses; on the
/// wedge it is the wedge's own thickness at that x (minus the normal shrink), and where no
/// light has a shadow map it is "unknown" (< 0), shown grey.
#[test]
fn thickness_view_shows_the_wedge_thickness() {
    let Some(ctx) = context() else { return };
    let (length, max_t) = (0.08f32, 0.008f32);
    let wedge = format!(
        "{{ shape = \"wedge\", length = {length}, height = 0.04, max_thickness = {max_t} }}"
    );
    let (w, h) = (256u32, 160u32);
    let render = |scene: &Scene, view: DebugView| {
        let mut opts = options(scene, w, h);
        opts.view = view;
        let mut r = Renderer::new(&ctx, scene, opts).unwrap();
        let frame = r.render().unwrap();
        (
            r.read_diffuse().unwrap(),
            r.read_linear_depth().unwrap(),
            frame.image,
        )
    };
    let (thick, depth, image) = render(&backlit(&wedge, 2048), DebugView::Thickness);
    let focal = 0.5 * h as f32 / (10f32).to_radians().tan();
    let y = h / 2;
    let mut n = 0;
    let mut worst = 0.0f32;
    let mut last = -1.0f32;
    for x in 0..w {
        let i = (y * w + x) as usize;
        if depth[i] > 1.0 {
            continue;
        }
        let world_x = (x as f32 + 0.5 - w as f32 * 0.5) * depth[i] / focal;
        let want = (world_x + length * 0.5) / length * max_t * 1000.0 - SHRINK * 1000.0;
        if !(0.4..=7.6).contains(&want) {
            continue;
        }
        let got = thick[i][0];
        // Shadow-map texels (2048 over the light's frustum) and the 3x3 thickness filter.
        assert!(
            (got - want).abs() < 0.1 + 0.03 * want,
            "x = {x}: thickness view {got} mm, wedge {want} mm"
        );
        assert!(
            got >= last - 0.05,
            "not increasing at x = {x}: {last} -> {got}"
        );
        last = got;
        worst = worst.max((got - want).abs());
        n += 1;
    }
    assert!(n > 80, "too few wedge pixels: {n}");
    eprintln!("thickness view on the wedge: {n} pixels, worst error {worst:.3} mm");
    // The ramp: thin is brighter than thick in the image.
    let lum = |x: u32| {
        let p = image.get_pixel(x, y).0;
        p[0] as u32 + p[1] as u32 + p[2] as u32
    };
    let xs: Vec<u32> = (0..w)
        .filter(|&x| depth[(y * w + x) as usize] < 1.0)
        .collect();
    let (first, last_x) = (xs[xs.len() / 8], xs[xs.len() * 7 / 8]);
    assert!(
        lum(first) > lum(last_x) + 60,
        "thin end {:?} not brighter than thick end {:?}",
        image.get_pixel(first, y),
        image.get_pixel(last_x, y)
    );
    // Without shadow maps there is no thickness: every object pixel is "unknown".
    let (thick, depth, _) = render(&backlit(&wedge, 0), DebugView::Thickness);
    for (t, z) in thick.iter().zip(&depth) {
        if *z < 1.0 {
            assert!(t[0] < 0.0, "thickness {t:?} without a shadow map");
        }
    }
}

/// Jimenez et al. 2010 add transmitted light only where the surface turns away from the
/// light: lit from the camera's side, a thin slab looks the same with and without it.
#[test]
fn no_transmittance_where_the_surface_faces_the_light() {
    if context().is_none() {
        return;
    }
    let slab = "{ shape = \"slab\", width = 0.05, height = 0.05, thickness = 0.001 }";
    let front = |s: Scene| {
        let mut desc = s.desc.clone();
        desc.lights[0].position = [0.0, 0.0, 1.0];
        Scene::from_desc(desc, std::path::Path::new("."), "front").unwrap()
    };
    let lit = front(backlit(slab, 1024));
    let (with, depth) = render_diffuse(&lit, 64, 64, TransmittanceMethod::Paper);
    let (without, _) = render_diffuse(&lit, 64, 64, TransmittanceMethod::Off);
    let mut n = 0;
    for ((a, b), z) in with.iter().zip(&without).zip(&depth) {
        if *z < 1.0 {
            assert!(b[0] > 0.5, "front face not lit: {b:?}");
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-3,
                    "transmittance added {a:?} vs {b:?}"
                );
            }
            n += 1;
        }
    }
    assert!(n > 500, "slab covers {n} pixels");
    // The same slab lit from behind does transmit (1 mm of skin passes most red light).
    let (back, _) = render_diffuse(&backlit(slab, 1024), 64, 64, TransmittanceMethod::Paper);
    let centre = back[32 * 64 + 32];
    assert!(centre[0] > 0.3, "backlit: {centre:?}");
}

/// `diffusion`: a 6 mm slab of skin lit from behind passes what exact transport says a 6 mm
/// slab of skin1 transmits by multiple scattering (T_ms / albedo, times the entry face's
/// irradiance E = 1), seen along the normal (the slab's exit shape toward the normal, times the
/// boundary's 1 - F0), far more red than the Gaussian T(s). The thickness is measured from the
/// shaded point itself (the normal shrink only finds the entry texel), so it is the slab's own
/// 6 mm.
#[test]
fn backlit_slab_transmits_the_exact_slab_transmittance() {
    if context().is_none() {
        return;
    }
    let thickness = 0.006;
    let s = backlit(
        &format!("{{ shape = \"slab\", width = 0.05, height = 0.05, thickness = {thickness} }}"),
        1024,
    );
    let (diffusion, _) = render_diffuse(&s, 64, 64, TransmittanceMethod::Diffusion);
    let (paper, _) = render_diffuse(&s, 64, 64, TransmittanceMethod::Paper);
    let centre = (32 * 64 + 32) as usize;
    let want = skin1_transport_t(thickness * 1000.0, 1.0, 1.0);
    let got = diffusion[centre];
    assert_transmits(got, want, "exact transport");
    assert!(want[0] > 0.3, "6 mm of skin1 should pass red: {want:?}");
    assert!(
        got[0] > 100.0 * paper[centre][0],
        "diffusion {got:?} vs paper {:?}",
        paper[centre]
    );
}

/// What `diffusion` sends toward the camera through `s_mm` of skin1 (the Gaussian skin
/// preset's medium) at cosine `c` to the flow and exit cosine `mu_o`, by the CPU oracle
/// (roughness 0.3, the material's default; eta 1.3).
fn skin1_transport_t(s_mm: f32, c: f32, mu_o: f32) -> [f32; 3] {
    skin1_slab().toward(s_mm, c, mu_o)
}

/// The rough boundary's transmittance at cosine `mu` (roughness 0.3, eta 1.3).
fn boundary_t(mu: f32) -> f32 {
    rough_transmittance(mu as f64, 0.3, SKIN1_ETA as f64) as f32
}

/// Exact transport through slabs of skin1 (the Gaussian skin preset's medium), as the renderer
/// tabulates it, behind skin1's rough boundary.
fn skin1_slab() -> SlabTransmission {
    let skin1 =
        subsurface_profile::Dipole::new([0.032, 0.17, 0.48], [0.74, 0.88, 1.01], 1.3).unwrap();
    SlabTransmission::new(&skin1, 32.0, 0.3, SKIN1_ETA.into()).unwrap()
}

/// `diffusion` lights the back by the entry face's own irradiance, E cos(theta), from the normal
/// the shadow map stores, times what the rough boundary lets in at that angle over what it
/// lets in head-on (the slab's T(s) is solved for light at normal incidence): a 3 mm slab
/// turned 60 degrees to the light receives E / 2 x 0.95 and is crossed along a 6 mm chord
/// (000_*'s wrapped front normal would give 0.3 + 0.5). The camera sees the face at the same
/// angle, and the light leaves through the rough boundary too.
#[test]
fn diffusion_lights_the_back_by_the_entry_face_irradiance() {
    if context().is_none() {
        return;
    }
    tilted_slab_transmits(60.0, 3.0);
}

/// Toward grazing, the rough boundary lets light in and out where a smooth one would not: a
/// 1 mm slab turned 80 degrees, seen at 80 degrees, leaves 0.81 of the transmitted light where
/// a smooth boundary's 1 - F (Schlick) would leave 0.61, and lets in 0.83 of normal
/// incidence's light (a smooth boundary 0.62).
#[test]
fn diffusion_passes_the_rough_boundary_at_grazing_angles() {
    if context().is_none() {
        return;
    }
    assert!(
        boundary_t(80f32.to_radians().cos())
            > 1.25 * (1.0 - schlick(80f64.to_radians().cos(), 1.3) as f32)
    );
    tilted_slab_transmits(80.0, 1.0);
}

/// A slab `thickness_mm` thick, turned `yaw_deg` about the vertical axis, lit from straight
/// behind and seen from straight in front: its centre pixel against the CPU's chord slab.
fn tilted_slab_transmits(yaw_deg: f32, thickness_mm: f32) {
    let mut s = backlit(
        &format!(
            "{{ shape = \"slab\", width = 0.05, height = 0.05, thickness = {} }}\nrotation_deg = [0.0, {yaw_deg}, 0.0]",
            thickness_mm / 1000.0
        ),
        2048,
    );
    // The chord's term alone: the lateral taps see the tilted plane `thickness_mm` away across
    // the slab and give more (docs/lab/fidelity.md, finding 6).
    s.desc.render.transmittance.lateral_taps = 0;
    let (diffuse, _) = render_diffuse(&s, 64, 64, TransmittanceMethod::Diffusion);
    // The entry texel is found along the ray through the point shrunk 0.1 mm along the normal:
    // on a slope of angle a that entry is 0.1 sin a tan a nearer. The light flows along the
    // light's direction inside, bent toward the face's normal by 0.4 of it (`exit_flow`).
    let a = yaw_deg.to_radians();
    let n = glam::Vec3::new(a.sin(), 0.0, a.cos());
    let (v, l) = (glam::Vec3::Z, -glam::Vec3::Z);
    let flow = (0.4 * n - l).normalize();
    let inside = -(-v).refract(n, 1.0 / SKIN1_ETA);
    let chord = thickness_mm / a.cos() - SHRINK * 1000.0 * a.sin() * a.tan();
    let entry = a.cos() * boundary_t(a.cos()) / boundary_t(1.0);
    let want = skin1_transport_t(chord, inside.dot(flow), n.dot(v)).map(|t| t * entry);
    assert_transmits(
        diffuse[32 * 64 + 32],
        want,
        &format!("E cos {yaw_deg} x T({chord:.2} mm) toward the camera"),
    );
}

/// skin1's boundary (the Gaussian skin preset's measured medium): eta, Schlick's F0 and
/// sigma_t per channel, 1/mm.
const SKIN1_ETA: f32 = 1.3;
const SKIN1_SIGMA_T: [f32; 3] = [0.772, 1.05, 1.49];

fn skin1_f0() -> f32 {
    schlick(1.0, SKIN1_ETA as f64) as f32
}

/// A 1 mm slab of skin lit from straight behind (1024-texel shadow map), turned `yaw_deg`
/// about the vertical axis.
fn thin_slab(yaw_deg: f32) -> Scene {
    backlit(
        &format!(
            "{{ shape = \"slab\", width = 0.05, height = 0.05, thickness = 0.001 }}\n\
             rotation_deg = [0.0, {yaw_deg}, 0.0]"
        ),
        1024,
    )
}

fn specular(scene: &Scene, method: TransmittanceMethod) -> Vec<[f32; 4]> {
    render(scene, 64, 64, method).read_specular().unwrap()
}

/// `diffusion`'s unscattered part: a 1 mm slab lit from straight behind passes
/// exp(-sigma_t s) of the light on, through two Fresnel transmissions, spread by the rough
/// boundary into a Gaussian lobe of sigma = alpha (eta - 1) around the light's direction
/// (0.09 rad for roughness 0.3 and eta 1.3). It lands in the specular target (the material's
/// specular is 0 here), and `paper` has none of it.
#[test]
fn thin_slab_passes_unscattered_light_in_a_lobe_of_the_boundary_roughness() {
    if context().is_none() {
        return;
    }
    let s = thin_slab(0.0);
    let spec = specular(&s, TransmittanceMethod::Diffusion);
    let alpha = 0.3f32;
    let sigma = alpha * (SKIN1_ETA - 1.0);
    let f0 = skin1_f0();
    let peak = SKIN1_SIGMA_T.map(|st| (1.0 - f0).powi(2) * (-st).exp() / (2.0 * sigma * sigma));
    // Pixel (32, 32) looks 0.003 rad off the axis: the lobe there is the peak.
    assert_transmits(spec[32 * 64 + 32], peak, "unscattered peak");
    // Column 44 looks theta = atan(0.39 tan 10 deg) off the axis.
    let tan = ((44.5f32 / 64.0) * 2.0 - 1.0) * 10f32.to_radians().tan();
    let falloff = (-(tan.atan().powi(2)) / (2.0 * sigma * sigma)).exp();
    assert!((0.6..0.9).contains(&falloff));
    assert_transmits(
        spec[32 * 64 + 44],
        peak.map(|p| p * falloff),
        "lobe at 0.069 rad",
    );
    let paper = specular(&s, TransmittanceMethod::Paper);
    let centre = paper[32 * 64 + 32];
    assert!(centre[0].abs() < 1e-6, "{centre:?}");
}

/// The unscattered lobe widens toward grazing incidence: a facet tilt d turns the refracted ray
/// by (1 - cos i / (eta cos t)) d at the entry, and the exit magnifies the inside spread by
/// m = eta cos t / cos o and adds (m - 1) d. For a 1 mm slab turned 40 degrees to the light
/// (parallel faces: the light leaves along its own direction) that is sigma = 0.143 rad
/// against 0.09 at normal incidence, with the peak lowered as 1 / sigma^2 and exp(-sigma_t s)
/// taken along the light's refracted way through the slab, 1 / cos t = 1.125 mm (Snell's law;
/// the straight chord along the light, 1.31 mm, which the lobe took before it found its entry
/// along the camera's refracted ray, left the blue peak 14 % low).
#[test]
fn unscattered_lobe_widens_at_oblique_incidence() {
    if context().is_none() {
        return;
    }
    let spec = specular(&thin_slab(40.0), TransmittanceMethod::Diffusion);
    let (alpha, eta) = (0.3f32, SKIN1_ETA);
    let i = 40f32.to_radians();
    let t = (i.sin() / eta).asin();
    let turn_in = 1.0 - i.cos() / (eta * t.cos());
    let m = eta * t.cos() / i.cos();
    let sigma = alpha / 2f32.sqrt() * (m * turn_in).hypot(m - 1.0);
    assert!((0.14..0.146).contains(&sigma), "{sigma}");
    let f0 = skin1_f0();
    let fresnel = f0 + (1.0 - f0) * (1.0 - i.cos()).powi(5);
    // The refracted path; the tilted entry face changes its light distance by 0.08 mm across
    // one shadow texel, so the peak is held between those of the path +-0.05 mm.
    let chord = 1.0 / t.cos();
    let peak = |chord: f32| {
        SKIN1_SIGMA_T
            .map(|st| (1.0 - fresnel).powi(2) * (-st * chord).exp() / (2.0 * sigma * sigma))
    };
    let (lo, hi) = (peak(chord + 0.05), peak(chord - 0.05));
    let centre = spec[32 * 64 + 32];
    for c in 0..3 {
        assert!(
            (0.97 * lo[c]..1.03 * hi[c]).contains(&centre[c]),
            "channel {c}: peak {} outside {}..{}",
            centre[c],
            lo[c],
            hi[c]
        );
    }
    // The lobe's shape does not depend on the chord: 12 pixels off the axis (up: across, the
    // turned slab is too narrow), exp(-theta^2 / 2 sigma^2) of the peak (0.89 here; 0.75 at
    // normal incidence).
    let tan = ((44.5f32 / 64.0) * 2.0 - 1.0) * 10f32.to_radians().tan();
    let falloff = (-(tan.atan().powi(2)) / (2.0 * sigma * sigma)).exp();
    for c in 0..3 {
        let ratio = spec[44 * 64 + 32][c] / centre[c];
        assert!(
            (ratio - falloff).abs() < 0.02,
            "channel {c}: {ratio} vs {falloff}"
        );
    }
}

/// `diffusion`'s single scattering: on a 1 mm slab lit from straight behind, every point of
/// the camera ray refracted into it has crossed t + s_i = s of skin since the light entered,
/// so the radiance is sigma_s' s exp(-sigma_t s) / 4 through two Fresnel transmissions (the
/// isotropic phase 1 / (4 pi), times pi for this renderer's albedo x E radiance). With a
/// nearly smooth boundary the unscattered lobe is 5 mrad wide, so 0.047 rad off the axis
/// (column 40, 14 mm from the slab's centre) the specular target holds the single
/// scattering alone.
#[test]
fn thin_slab_scatters_light_once_toward_the_camera() {
    if context().is_none() {
        return;
    }
    let mut s = thin_slab(0.0);
    s.edit_materials(|m| m.roughness = 0.01);
    let spec = specular(&s, TransmittanceMethod::Diffusion);
    let f0 = skin1_f0();
    // skin1's sigma_s' (the Gaussian skin preset's measured medium), 1/mm.
    let sigma_s = [0.74f32, 0.88, 1.01];
    let want: [f32; 3] = std::array::from_fn(|c| {
        sigma_s[c] * 1.0 * (-SKIN1_SIGMA_T[c]).exp() / 4.0 * (1.0 - f0).powi(2)
    });
    assert_transmits(spec[32 * 64 + 40], want, "sigma_s' s exp(-sigma_t s) / 4");
    // `paper` has no single scattering.
    let paper = specular(&s, TransmittanceMethod::Paper);
    assert!(paper[32 * 64 + 40][0].abs() < 1e-6);
}

/// Single scattering reaches as far as the medium's unscattered light: its bound is an optical
/// depth (the slowest channel keeps exp(-sigma_t s) of at least 0.2 %), not a length. Behind
/// 12 mm of chicken1, a weak scatterer (sigma_t 0.165 per mm in red), the light scattered once
/// is sigma_s' s exp(-sigma_t s) / 4, as on the 1 mm slab of skin above (a bound of 8 mm for
/// every medium gave nothing here); behind 12 mm of skin1 (red keeps 0.01 %) it is skipped.
#[test]
fn single_scattering_reaches_as_far_as_the_medium_lets_light_through() {
    if context().is_none() {
        return;
    }
    let slab = |medium: &str| {
        let mut s = backlit_material(
            "{ shape = \"slab\", width = 0.05, height = 0.05, thickness = 0.012 }",
            1024,
            medium,
        );
        s.edit_materials(|m| m.roughness = 0.01);
        s
    };
    let f0 = skin1_f0();
    // Jensen et al. 2001's chicken1, 1/mm (eta 1.3, as skin1).
    let sigma_s = [0.15f32, 0.21, 0.38];
    let sigma_a = [0.015f32, 0.077, 0.19];
    let want: [f32; 3] = std::array::from_fn(|c| {
        let sigma_t = sigma_s[c] + sigma_a[c];
        sigma_s[c] * 12.0 * (-sigma_t * 12.0).exp() / 4.0 * (1.0 - f0).powi(2)
    });
    let chicken = specular(&slab("chicken1"), TransmittanceMethod::Diffusion);
    assert_transmits(
        chicken[32 * 64 + 40],
        want,
        "sigma_s' s exp(-sigma_t s) / 4",
    );
    let skin = specular(&slab("skin1"), TransmittanceMethod::Diffusion);
    let beyond = skin[32 * 64 + 40];
    assert!(beyond[0].abs() < 1e-4, "{beyond:?}");
}

/// A block of skin two thicknesses deep, lit from straight behind: 16 mm for x < 0 and 6 mm
/// beyond (two slabs side by side, front faces at z = 0), seen head-on, 64 x 64 pixels over
/// 106 mm. Light that crossed the thin part spreads under the thick part beside the step, as
/// through a palm beside the finger roots; `diffusion`'s lateral taps gather it.
fn stepped_block(lateral_taps: u32) -> Vec<[f32; 4]> {
    stepped_block_with(lateral_taps, 0.0, false)
}

/// [`stepped_block`] with the lateral taps read from a map of texels `texel_mm` apart (0: the
/// taps at every pixel; at 1.66 mm a pixel, 7 mm gives one texel per 4x4 pixels),
/// and with `occluder` a 2 mm sheet of the same skin 30 mm in front of the thick part, covering
/// it up to 12 mm from the step (a depth edge between two skin surfaces, on the camera's
/// side: the light, behind the block, reaches the sheet only through it).
fn stepped_block_with(lateral_taps: u32, texel_mm: f32, occluder: bool) -> Vec<[f32; 4]> {
    let sheet = if occluder {
        skin_slab(-0.031, 0.0, 0.038, 0.038, 0.002, 0.03)
    } else {
        String::new()
    };
    stepped_block_seen(lateral_taps, texel_mm, 0.3, &sheet)
}

/// A `[[objects]]` slab of skin centred on (`x`, `y`), `width` x `height`, its front face at z
/// = `front`, `thickness` deep (metres, 1000 mm a unit).
fn skin_slab(x: f32, y: f32, width: f32, height: f32, thickness: f32, front: f32) -> String {
    format!(
        "[[objects]]\nmesh = {{ shape = \"slab\", width = {width:?}, height = {height:?}, thickness = {thickness:?} }}\ntranslation = [{x:?}, {y:?}, {:?}]\nmm_per_unit = 1000.0\n[objects.material]\nalbedo = [1.0, 1.0, 1.0]\nspecular = 0.0\nmedium = \"skin\"\n",
        front - thickness / 2.0
    )
}

/// The stepped block seen from `camera_z` metres in front of it, with `more` objects.
fn stepped_block_seen(
    lateral_taps: u32,
    texel_mm: f32,
    camera_z: f32,
    more: &str,
) -> Vec<[f32; 4]> {
    let slab = |x: f32, thickness: f32| skin_slab(x, 0.0, 0.05, 0.05, thickness, 0.0);
    let toml = format!(
        "{}\n[render]\nambient = [0.0, 0.0, 0.0]\ntransmittance = {{ normal_shrink = 0.0001 }}\n{}\n{}\n{}\n{more}",
        camera_toml(camera_z, 20.0, "near = 0.05\nfar = 2.0"),
        common::light_toml(
            "directional",
            [0.0, 0.0, -1.0],
            1.0,
            "shadow_map_size = 2048\nshadow_bias = 0.00005"
        ),
        slab(-0.025, 0.016),
        slab(0.025, 0.006),
    );
    let s = common::scene(&toml);
    let ctx = context().unwrap();
    let mut opts = options(&s, 64, 64);
    opts.settings.sss.method = SssMethod::None;
    opts.settings.transmittance.method = TransmittanceMethod::Diffusion;
    opts.settings.transmittance.lateral_taps = lateral_taps;
    opts.settings.transmitted_map.texel_mm = texel_mm;
    let mut r = Renderer::new(&ctx, &s, opts).unwrap();
    r.render().unwrap();
    r.read_diffuse().unwrap()
}

/// The lateral taps against their CPU reference (`subsurface_profile::lateral`): beside the
/// step the thick part shows the light of the lit surface around it, several times its own
/// chord's slab; far from the step, the slab; without taps, the slab everywhere.
#[test]
fn light_crossing_a_thin_neighbour_spreads_under_a_thick_part() {
    if context().is_none() {
        return;
    }
    use subsurface_profile::lateral::{DEFAULT_LATERAL_TAPS, lateral_transmittance};
    let slab = skin1_slab();
    let table = slab.table();
    let sigma = table.lateral_decay_per_mm();
    let with = stepped_block(DEFAULT_LATERAL_TAPS);
    let without = stepped_block(0);
    // The pixel's point on the front face (mm): 20 degrees over 64 pixels at 300 mm.
    let half = 300.0 * 10f64.to_radians().tan();
    let x_of = |i: usize| ((i as f64 + 0.5) / 32.0 - 1.0) * half;
    let row = 32usize;
    // Rows run down the image, y up the scene.
    let y = -x_of(row);
    let chord = 16.0;
    let slab = skin1_transport_t(chord as f32, 1.0, 1.0);
    for (i, near) in [(28usize, true), (10, false)] {
        let x = x_of(i);
        // The shader's frame across the light (0, 0, -1): t1 = +x, t2 = -y.
        let lateral =
            lateral_transmittance(table, chord, sigma, DEFAULT_LATERAL_TAPS, |rho, phi| {
                let (ex, ey) = (x + rho * phi.cos(), y - rho * phi.sin());
                if ex.abs() >= 50.0 || ey.abs() >= 25.0 {
                    return None;
                }
                let depth = if ex < 0.0 { 16.0 } else { 6.0 };
                let r = ((ex - x).powi(2) + (ey - y).powi(2) + depth * depth).sqrt();
                Some((r, (2.0 * depth / r).min(1.0)))
            })
            .unwrap();
        let flux = table.multiple_at(chord);
        let want: [f32; 3] =
            std::array::from_fn(|c| slab[c] * (lateral[c] / flux[c]).max(1.0) as f32);
        let got = with[row * 64 + i];
        let plain = without[row * 64 + i];
        assert!(
            (got[0] / want[0] - 1.0).abs() < 0.05,
            "pixel {i} ({x:.1} mm): red {} vs the CPU's {} (slab {})",
            got[0],
            want[0],
            slab[0]
        );
        assert!(
            (plain[0] / slab[0] - 1.0).abs() < 0.03,
            "pixel {i}, no taps: red {} vs the slab's {}",
            plain[0],
            slab[0]
        );
        if near {
            assert!(
                got[0] > 2.0 * slab[0],
                "beside the step: {} vs slab {}",
                got[0],
                slab[0]
            );
        } else {
            assert!(
                got[0] < 1.1 * slab[0],
                "far from the step: {} vs slab {}",
                got[0],
                slab[0]
            );
        }
    }
}

/// Red of the pixels of row 32 of a stepped block where the per-pixel taps give light.
fn row_red(img: &[[f32; 4]]) -> Vec<(usize, f32)> {
    (0..64)
        .map(|i| (i, img[32 * 64 + i][0]))
        .filter(|&(_, r)| r > 1e-5)
        .collect()
}

/// The transmitted map against the taps at every pixel where the lateral light changes fastest:
/// across the stepped block's step, where it falls several-fold within a few millimetres
/// (1.7 mm a pixel here). Twelve taps are a quadrature with its own error there (up to 30 %
/// at a pixel against 32 taps), so both are measured against the 32 taps at every pixel, the
/// converged sum: the map, read once per 4x4 pixels (6.8 mm, 1.8 of the medium's decay
/// lengths) and interpolated, must add no error of its own beyond a point on the mean, and
/// stay within the taps' own worst. The map must be read (the images differ).
#[test]
fn transmitted_map_keeps_the_taps_accuracy_across_a_step() {
    if context().is_none() {
        return;
    }
    let taps = subsurface_profile::lateral::DEFAULT_LATERAL_TAPS;
    let truth = stepped_block_with(subsurface_profile::lateral::MAX_LATERAL_TAPS, 0.0, false);
    // The step and 10 mm either side of it and of the block's middle: within 10 mm of the
    // block's outer edges (x beyond +-40 mm, 1.65 mm a pixel) the side walls' falloff
    // (`transmittance.side_walls`) is sharper than the map's 6.8 mm texels, and the map reads
    // up to 19 % under the taps at the last pixels of the thin half (tests/side_walls.rs
    // checks the walls themselves).
    let row: Vec<(usize, f32)> = row_red(&truth)
        .into_iter()
        .filter(|&(i, _)| (8..56).contains(&i))
        .collect();
    assert!(row.len() > 40, "only {} lit pixels", row.len());
    let errors = |img: &[[f32; 4]]| -> (f32, f32) {
        let e: Vec<f32> = row
            .iter()
            .map(|&(i, want)| (img[32 * 64 + i][0] / want - 1.0).abs())
            .collect();
        let mean = e.iter().sum::<f32>() / e.len() as f32;
        (mean, e.iter().fold(0.0f32, |m, x| m.max(*x)))
    };
    let per_pixel = stepped_block_with(taps, 0.0, false);
    let mapped = stepped_block_with(taps, 7.0, false);
    assert_ne!(mapped, per_pixel, "the transmitted map was not read");
    let (pp_mean, pp_max) = errors(&per_pixel);
    let (map_mean, map_max) = errors(&mapped);
    assert!(
        map_mean <= pp_mean + 0.01,
        "map: mean error {map_mean} against the per-pixel taps' {pp_mean}"
    );
    assert!(
        map_max <= pp_max.max(0.05) + 0.02,
        "map: worst pixel {map_max} against the per-pixel taps' {pp_max}"
    );
}

/// A depth edge between two skin surfaces: a sheet 30 mm in front of the stepped block's thick
/// part, whose lateral light is nothing (its entry, the block's back, is 46 mm away), beside
/// the block's, which is at its strongest there. The map's texels straddling the edge hold
/// both; a pixel must take only texels of its own surface. Without
/// the depth test the sheet's two pixels beside the edge read 0.005 and 0.015 of the block's
/// light and the block's first two 13 % less.
#[test]
fn transmitted_map_does_not_cross_depth_edges() {
    if context().is_none() {
        return;
    }
    let taps = subsurface_profile::lateral::MAX_LATERAL_TAPS;
    let exact = stepped_block_with(taps, 0.0, true);
    let mapped = stepped_block_with(taps, 7.0, true);
    assert_ne!(mapped, exact, "the transmitted map was not read");
    let sheet: Vec<usize> = (0..32).filter(|&i| exact[32 * 64 + i][0] == 0.0).collect();
    assert!(sheet.len() > 10, "the sheet covers {} pixels", sheet.len());
    for i in sheet {
        assert!(
            mapped[32 * 64 + i][0] == 0.0,
            "pixel {i} of the sheet took {} of the block's light",
            mapped[32 * 64 + i][0]
        );
    }
    let edge = (0..32).find(|&i| exact[32 * 64 + i][0] > 0.0).unwrap();
    for i in edge..edge + 2 {
        let (got, want) = (mapped[32 * 64 + i][0], exact[32 * 64 + i][0]);
        assert!(
            got > 0.95 * want,
            "pixel {i} of the block beside the sheet: {got} against {want}"
        );
    }
}

/// The stepped block 600 mm away (3.3 mm a pixel) beside a small sheet of skin 100 mm from
/// the camera (0.55 mm a pixel), as a character far behind a near one. The map is sized for the
/// near sheet's 4 mm texels (a 7x reduction), which makes the block's 23 mm: more than
/// `MAX_TEXEL_FACTOR` times 4, so the block is drawn with the pipeline that gathers the taps
/// at each pixel, and keeps their accuracy. Read from the map, its row's mean error against
/// the converged taps was 0.032, against the twelve taps' own 0.007.
#[test]
fn far_skin_gathers_its_own_taps() {
    if context().is_none() {
        return;
    }
    let near = skin_slab(0.012, 0.012, 0.01, 0.01, 0.002, 0.5);
    let taps = subsurface_profile::lateral::DEFAULT_LATERAL_TAPS;
    let truth = stepped_block_seen(
        subsurface_profile::lateral::MAX_LATERAL_TAPS,
        0.0,
        0.6,
        &near,
    );
    let per_pixel = stepped_block_seen(taps, 0.0, 0.6, &near);
    let mapped = stepped_block_seen(taps, DEFAULT_MAP_TEXEL_MM, 0.6, &near);
    let row = row_red(&truth);
    let mean_error = |img: &[[f32; 4]]| {
        row.iter()
            .map(|&(i, want)| (img[32 * 64 + i][0] / want - 1.0).abs())
            .sum::<f32>()
            / row.len() as f32
    };
    let (pp, map) = (mean_error(&per_pixel), mean_error(&mapped));
    assert!(
        map <= pp + 0.002,
        "far block: mean error {map} against the per-pixel taps' {pp}"
    );
}
