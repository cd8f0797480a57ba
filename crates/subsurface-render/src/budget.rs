//! What a frame will allocate on the GPU, estimated from the settings before anything is
//! created, so that a size the device cannot hold is a one-line error naming the setting
//! rather than an out-of-memory abort halfway through.

use crate::error::RenderError;
use crate::scene::Scene;
use crate::settings::{RenderSettings, SssMethod, TransmittanceMethod};

/// Default limit on the estimate, in bytes; `SUBSURFACE_GPU_MEMORY_LIMIT_GB` overrides it.
pub const DEFAULT_LIMIT_BYTES: u64 = 8 << 30;

/// Bytes per pixel of the frame's targets: diffuse and specular (Rgba16Float), linear depth
/// (R32Float), SSS (Rgba16Float), z-buffer (Depth32Float), output (Rgba8), and up to four
/// Rgba16Float intermediates of the six-Gaussian blur.
const FRAME_BYTES_PER_PIXEL: u64 = 8 + 8 + 4 + 8 + 4 + 4 + 4 * 8;
/// Bytes per texel of one object's texture-space maps: irradiance (Rgba16Float), stretch
/// (Rg32Float), and the blur's temporary, ping, pong, accumulation, result and widest
/// Gaussian (Rgba16Float each).
const TEXTURE_SPACE_BYTES_PER_TEXEL: u64 = 8 + 8 + 6 * 8;
/// Bytes per texel of a shadow-map layer: distance and entry normal (Rg32Float), the depth
/// buffer it is drawn with (Depth32Float), translucent shadow maps' (u, v) (Rg32Float).
const SHADOW_BYTES_PER_TEXEL: u64 = 8 + 4 + 8;

/// The environment variable that overrides [`DEFAULT_LIMIT_BYTES`].
pub const LIMIT_VAR: &str = "SUBSURFACE_GPU_MEMORY_LIMIT_GB";

/// The limit in force: [`DEFAULT_LIMIT_BYTES`], or [`LIMIT_VAR`] in GiB when it is set. A
/// value that is not a finite number > 0 (`abc`, `-1`, `nan`, `0`, empty) is an error naming
/// the variable: it used to fall back to 8 GiB without a word.
pub fn limit_bytes() -> Result<u64, RenderError> {
    match std::env::var_os(LIMIT_VAR) {
        None => Ok(DEFAULT_LIMIT_BYTES),
        Some(v) => parse_limit(&v.to_string_lossy()),
    }
}

fn parse_limit(v: &str) -> Result<u64, RenderError> {
    let bad = || {
        RenderError::invalid(
            LIMIT_VAR,
            format!("must be a number of GiB, finite and > 0 (got {v:?})"),
        )
    };
    let gb = v.trim().parse::<f64>().map_err(|_| bad())?;
    if !(gb.is_finite() && gb > 0.0) {
        return Err(bad());
    }
    // At least one byte, at most what u64 holds (a float past it saturates in the cast).
    Ok(((gb * (1u64 << 30) as f64) as u64).max(1))
}

/// A size in bytes for messages, with enough precision at every scale: a limit of 1e-6 GiB
/// printed as "0.0 GiB" said nothing.
fn gib(bytes: u64) -> String {
    const UNITS: [(&str, u64); 3] = [("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)];
    match UNITS.iter().find(|(_, size)| bytes >= *size) {
        Some((unit, size)) => {
            let v = bytes as f64 / *size as f64;
            if v >= 10.0 {
                format!("{v:.1} {unit}")
            } else {
                format!("{v:.3} {unit}")
            }
        }
        None => format!("{bytes} bytes"),
    }
}

/// The largest allocations of a frame, each checked against the limit, with the setting that
/// drives it named in the error.
pub fn check(scene: &Scene, s: &RenderSettings) -> Result<(), RenderError> {
    let limit = limit_bytes()?;
    let pixels = s.width as u64 * s.height as u64;
    let frame = pixels * FRAME_BYTES_PER_PIXEL;
    let over = |field: &str, what: String, bytes: u64| {
        RenderError::invalid(
            field,
            format!(
                "{what} needs about {} of GPU memory, over the limit of {} (set SUBSURFACE_GPU_MEMORY_LIMIT_GB to raise it)",
                gib(bytes),
                gib(limit)
            ),
        )
    };
    if frame > limit {
        return Err(over(
            "width",
            format!("a {}x{} frame", s.width, s.height),
            frame,
        ));
    }
    let texture_space =
        s.sss.method == SssMethod::Texture || s.transmittance.method == TransmittanceMethod::Tsm;
    if texture_space {
        let skin = scene
            .objects
            .iter()
            .filter(|o| o.material.sss_strength > 0.0 && !o.mesh.indices.is_empty())
            .count() as u64;
        let side = s.sss.texture_size as u64;
        let maps = skin * side * side * TEXTURE_SPACE_BYTES_PER_TEXEL;
        if frame + maps > limit {
            return Err(over(
                "sss.texture_size",
                format!("texture-space maps of {side}x{side} for {skin} skin objects"),
                frame + maps,
            ));
        }
    }
    let shadow: u64 = scene
        .desc
        .lights
        .iter()
        .map(|l| {
            let layers = if l.kind == crate::scene::LightKind::Point {
                6
            } else {
                1
            };
            l.shadow_map_size as u64 * l.shadow_map_size as u64 * layers * SHADOW_BYTES_PER_TEXEL
        })
        .sum();
    if frame + shadow > limit {
        return Err(over(
            "lights",
            "the shadow maps".to_string(),
            frame + shadow,
        ));
    }
    check_work(scene, s)
}

/// Most pixels the triangles of one geometry pass may cover, counted with overdraw: 2^32, a
/// 16384 x 16384 frame drawn 16 times over, or 4,600 full 1280 x 720 layers. Past it a frame
/// takes minutes on a software rasteriser (99,000 instances of one quad across a 1280 x 720
/// view ran past 120 s on lavapipe, 4.3 ms each) for no picture anyone needs.
pub const MAX_COVERED_PIXELS: f64 = 4_294_967_296.0;

/// The pixels the triangles of `scene` cover in a `width` x `height` view of its camera,
/// overdraw included, per object: each triangle's projected area, at most its screen bounding
/// box clipped to the view; a triangle reaching behind the camera counts as the whole view.
pub fn covered_pixels(scene: &Scene, width: u32, height: u32) -> Vec<f64> {
    let c = &scene.desc.camera;
    let (w, h) = (f64::from(width), f64::from(height));
    let view = glam::DMat4::look_at_rh(
        glam::Vec3::from(c.position).as_dvec3(),
        glam::Vec3::from(c.target).as_dvec3(),
        glam::Vec3::from(c.up).as_dvec3(),
    );
    let proj = glam::DMat4::perspective_rh(
        f64::from(c.fov_y_deg).to_radians(),
        w / h,
        f64::from(c.near),
        f64::from(c.far),
    );
    scene
        .objects
        .iter()
        .map(|o| {
            let m = proj * view * o.transform.as_dmat4();
            let clip: Vec<glam::DVec4> = o
                .mesh
                .vertices
                .iter()
                .map(|v| m * glam::Vec3::from(v.position).as_dvec3().extend(1.0))
                .collect();
            o.mesh
                .indices
                .chunks_exact(3)
                .map(|t| {
                    let p = [t[0], t[1], t[2]].map(|i| clip[i as usize]);
                    // Wholly outside one side of the frustum: culled.
                    let outside = |f: fn(&glam::DVec4) -> bool| p.iter().all(f);
                    if outside(|q| q.x > q.w)
                        || outside(|q| q.x < -q.w)
                        || outside(|q| q.y > q.w)
                        || outside(|q| q.y < -q.w)
                        || outside(|q| q.z > q.w)
                        || outside(|q| q.z < 0.0)
                    {
                        return 0.0;
                    }
                    if p.iter().any(|q| q.w <= 0.0) {
                        return w * h;
                    }
                    let s = p.map(|q| glam::DVec2::new(q.x / q.w * 0.5 * w, q.y / q.w * 0.5 * h));
                    let area = 0.5 * (s[1] - s[0]).perp_dot(s[2] - s[0]).abs();
                    let lo = s[0]
                        .min(s[1])
                        .min(s[2])
                        .max(glam::DVec2::new(-0.5 * w, -0.5 * h));
                    let hi = s[0]
                        .max(s[1])
                        .max(s[2])
                        .min(glam::DVec2::new(0.5 * w, 0.5 * h));
                    let bbox = (hi - lo).max(glam::DVec2::ZERO);
                    area.min(bbox.x * bbox.y)
                })
                .sum()
        })
        .collect()
}

/// The work budget: the pixels the scene's triangles cover in one pass at most
/// [`MAX_COVERED_PIXELS`], checked when the scene is loaded rather than minutes into a frame.
fn check_work(scene: &Scene, s: &RenderSettings) -> Result<(), RenderError> {
    let per_object = covered_pixels(scene, s.width, s.height);
    let total: f64 = per_object.iter().sum();
    if total <= MAX_COVERED_PIXELS {
        return Ok(());
    }
    let (i, most) = per_object
        .iter()
        .enumerate()
        .fold((0, 0.0), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
    let o = &scene.objects[i];
    Err(RenderError::invalid(
        format!("objects[{i}]"),
        format!(
            "{} ({} triangles) covers about {most:.2e} pixels of the {}x{} view, {:.0} times \
             over (the scene {total:.2e}), past the work budget of {MAX_COVERED_PIXELS:.2e} \
             covered pixels per pass: use fewer instances or a smaller image",
            o.name,
            o.mesh.triangle_count(),
            s.width,
            s.height,
            most / (f64::from(s.width) * f64::from(s.height)),
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_past_the_limit_are_errors_naming_the_setting() {
        let scene = Scene::default_scene();
        let mut o = scene.desc.render.clone();
        assert!(check(&scene, &o).is_ok());
        (o.width, o.height) = (16384, 16384);
        let e = check(&scene, &o).unwrap_err().to_string();
        assert!(
            e.starts_with("width: a 16384x16384 frame needs about"),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let mut o = scene.desc.render.clone();
        o.sss.method = SssMethod::Texture;
        o.sss.texture_size = 16384;
        let e = check(&scene, &o).unwrap_err().to_string();
        assert!(e.starts_with("sss.texture_size: texture-space maps"), "{e}");
        o.sss.texture_size = 1024;
        assert!(check(&scene, &o).is_ok());
    }

    #[test]
    fn memory_limit_values_are_checked_and_printed_with_precision() {
        for bad in ["abc", "-1", "nan", "0", "", "inf", " "] {
            let e = parse_limit(bad).unwrap_err().to_string();
            assert!(
                e.starts_with("SUBSURFACE_GPU_MEMORY_LIMIT_GB: must be"),
                "{e}"
            );
            assert!(e.contains(&format!("{bad:?}")), "{e}");
        }
        assert_eq!(parse_limit("2").unwrap(), 2 << 30);
        assert_eq!(parse_limit(" 0.5 ").unwrap(), 1 << 29);
        assert_eq!(parse_limit("1e-30").unwrap(), 1);
        assert_eq!(gib(8 << 30), "8.000 GiB");
        assert_eq!(gib(1074), "1.049 KiB");
        assert_eq!(gib(3 << 20), "3.000 MiB");
        assert_eq!(gib(12), "12 bytes");
        assert_eq!(gib(100 << 30), "100.0 GiB");
    }

    /// A quad in front of the camera, instanced `n` times in one place: the covered pixels
    /// grow with the instances, and past the work budget the scene is refused naming the
    /// object, before any GPU work.
    #[test]
    fn absurd_overdraw_is_refused_by_the_work_budget() {
        use crate::mesh::{Mesh, Vertex};
        let mut scene = Scene::default_scene();
        scene.desc.camera.position = [0.0, 0.0, 1.0];
        scene.desc.camera.target = [0.0, 0.0, 0.0];
        scene.desc.camera.up = [0.0, 1.0, 0.0];
        let quad = |n: usize| {
            let v = |x: f32, y: f32| Vertex {
                position: [x, y, 0.0],
                ..Default::default()
            };
            let mut m = Mesh::default();
            for _ in 0..n {
                m.append(&Mesh {
                    vertices: vec![v(-1.0, -1.0), v(1.0, -1.0), v(1.0, 1.0), v(-1.0, 1.0)],
                    indices: vec![0, 1, 2, 0, 2, 3],
                    missing_uvs: None,
                });
            }
            m
        };
        scene.objects.truncate(1);
        scene.desc.objects.truncate(1);
        scene.objects[0].transform = glam::Mat4::IDENTITY;
        let mut s = scene.desc.render.clone();
        (s.width, s.height) = (1280, 720);
        scene.objects[0].mesh = quad(1);
        let one = covered_pixels(&scene, s.width, s.height)[0];
        // The quad fills the view (30 degrees of fov at distance 1 see +-0.27 vertically); each
        // of its triangles counts as its bounding box, the whole view: an upper bound.
        let view = 1280.0 * 720.0;
        assert!((2.0 * view - one).abs() < 1.0, "{one}");
        assert!(check_work(&scene, &s).is_ok());
        scene.objects[0].mesh = quad(99_000);
        let e = check_work(&scene, &s).unwrap_err().to_string();
        assert!(e.starts_with("objects[0]: "), "{e}");
        assert!(
            e.contains("198000 triangles") && e.contains("work budget"),
            "{e}"
        );
        // Behind the camera it costs nothing.
        scene.objects[0].transform = glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.0, 5.0));
        assert!(check_work(&scene, &s).is_ok());
        // The default scene is far inside the budget.
        let d = Scene::default_scene();
        let px: f64 = covered_pixels(&d, 1280, 720).iter().sum();
        assert!(px > 1e4 && px < 1e8, "{px}");
    }
}
