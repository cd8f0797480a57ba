//! `subsurface export-mitsuba`: the same scene as a Mitsuba 3 scene, to path-trace a reference.
//!
//! What is exported, and how our conventions map onto Mitsuba's (docs/lab/fidelity.md):
//!
//! - Camera: `perspective` with `fov_axis="y"` and a `lookat` transform; near/far are not needed.
//! - Lights: our lighting pass writes diffuse radiance = albedo x irradiance (no 1/pi), while a
//!   physical Lambertian (and a diffusing medium) reflects albedo x irradiance / pi. Every
//!   emitter is therefore exported pi times stronger, so that a surface of albedo `a` has the
//!   same radiance in both renderers. Point and spot: `intensity` (radiant intensity, 1/d^2 in
//!   scene units), spot cone `beam_width` = inner and `cutoff_angle` = outer half-angle
//!   (Mitsuba falls off linearly in angle, we smoothstep in cosine). Directional: `irradiance`.
//!   Shadows are always on in a path tracer (`shadow_map_size = 0` cannot be expressed).
//! - Ambient: a `constant` environment of radiance `render.ambient` (seen directly it is also
//!   the background; ours uses `render.background`, so canonical scenes set both equal).
//! - Meshes: one binary PLY per object in world space (object transform applied), with vertex
//!   normals. Textures are not exported (a homogeneous medium has one albedo): the exporter
//!   says so on stderr.
//! - Skin (`sss_strength > 0`): a `homogeneous` medium inside a `roughdielectric` (Beckmann,
//!   alpha = roughness) boundary of relative index 1.3 with Jensen et al. 2001's measured
//!   sigma_a and sigma_s' of the material's `profile`. "skin" (d'Eon's Gaussians, which have no
//!   coefficients) is exported as Jensen's "skin1". sigma_s' is used as sigma_s with an
//!   isotropic phase function (the similarity relation). A rough, not smooth, dielectric:
//!   a smooth one can never connect to a point or spot light (a delta light behind a delta
//!   BSDF), and renders black.
//! - Other objects: a `diffuse` BSDF with the object's albedo.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use glam::Vec3;
use subsurface_profile::{Dipole, Medium};
use subsurface_render::Scene;
use subsurface_render::scene::{LightKind, Object};

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// Scene file (TOML). Without it, the embedded default scene.
    scene: Option<PathBuf>,
    /// Output directory: scene.xml and meshes/*.ply are written there (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Image width in pixels (default: the scene's). Overridable at load time (`width`).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (default: the scene's). Overridable at load time (`height`).
    #[arg(long)]
    height: Option<u32>,
    /// Default samples per pixel written into the scene (`spp` parameter).
    #[arg(long, default_value_t = 128)]
    spp: u32,
    /// Default maximum path depth (`max_depth` parameter). Skin's single-scattering albedo is
    /// up to 0.96, so light needs a hundred or more scattering events to cross a finger.
    #[arg(long, default_value_t = 256)]
    max_depth: u32,
}

/// The homogeneous medium a material's `medium` stands for, and whether it was substituted:
/// a measured preset or coefficients are exported exactly; d'Eon's "skin" Gaussians are a fit
/// to three layers, not one medium, so Jensen's first skin sample stands in for them.
pub fn exported_medium(medium: &Medium) -> Result<(Dipole, bool)> {
    Ok(match medium.dipole()? {
        Some(d) => (d, false),
        None => (
            Medium::Preset("skin1".into())
                .dipole()?
                .context("skin1 is a measured preset")?,
            true,
        ),
    })
}

/// Medium coefficients in 1/scene-unit. Our objects are `mm_per_unit` mm per mesh unit, scaled
/// by the transform's `s` into the world, and `sss_width` widens the profile: one scene unit
/// is `mm_per_unit / (s * sss_width)` "profile millimetres" (the inverse of the renderer's
/// `world_per_mm`).
pub fn medium_per_unit(m: &Dipole, object: &Object) -> ([f64; 3], [f64; 3]) {
    // In f64: an f32 determinant of a 1e-30 or 1e30 scale underflows or overflows (NaN
    // coefficients reached the XML).
    let s = object.transform.as_dmat4().determinant().abs().cbrt();
    let mm_per_scene_unit =
        f64::from(object.mm_per_unit) / (s * f64::from(object.material.sss_width));
    let sigma_s = m.sigma_s_prime.map(|x| x * mm_per_scene_unit);
    let sigma_a = m.sigma_a.map(|x| x * mm_per_scene_unit);
    (sigma_a, sigma_s)
}

/// A number as Mitsuba reads it (a 32-bit float), in a form that reads back as exactly that
/// float: Rust's shortest round-trip digits, in exponent form outside 1e-4..1e7. Nine fixed
/// decimals wrote `sigma_a = 1e-40` as `scale="0.000000000"`, an empty medium.
fn num(x: f64) -> String {
    let x = x as f32;
    if x == 0.0 || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn v3(v: impl Into<Vec3>) -> String {
    let v = v.into();
    format!(
        "{}, {}, {}",
        num(v.x.into()),
        num(v.y.into()),
        num(v.z.into())
    )
}

/// Mitsuba reads every number as a 32-bit float: a value past f32::MAX would be infinite
/// there, so it is an error naming `field` before anything is written.
fn fits(field: &str, what: &str, values: &[f64]) -> Result<()> {
    let max = f64::from(f32::MAX);
    match values.iter().find(|v| v.is_nan() || v.abs() > max) {
        Some(v) => anyhow::bail!(
            "{field}: {what} would be {v:e} in the Mitsuba scene, past the largest 32-bit float \
             ({max:e}) Mitsuba reads"
        ),
        None => Ok(()),
    }
}

fn rgb(c: [f64; 3]) -> String {
    format!("{}, {}, {}", num(c[0]), num(c[1]), num(c[2]))
}

/// An up vector for `lookat` that is not parallel to the view direction.
fn up_for(dir: Vec3, preferred: Vec3) -> Vec3 {
    if preferred.cross(dir).length_squared() > 1e-6 * dir.length_squared() {
        preferred
    } else if Vec3::Y.cross(dir).length_squared() > 1e-6 * dir.length_squared() {
        Vec3::Y
    } else {
        Vec3::X
    }
}

/// Binary little-endian PLY: float x y z nx ny nz, triangles as uchar count + uint indices.
/// `objects[i]` names the object in the error when a world-space vertex is not finite (scene
/// loading rejects such transforms; this keeps the file from ever holding one).
fn ply_bytes(object: &Object, i: usize) -> Result<Vec<u8>> {
    let mut mesh = object.mesh.clone();
    // Positions to world; normals by the inverse transpose (and re-normalised by Mitsuba).
    mesh.transform(object.transform);
    if let Some(k) = mesh
        .vertices
        .iter()
        .position(|v| !v.position.iter().chain(&v.normal).all(|x| x.is_finite()))
    {
        anyhow::bail!("objects[{i}]: world-space vertex {k} is not finite");
    }
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment subsurface export-mitsuba: {}\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        object.name.replace('\n', " "),
        mesh.vertices.len(),
        mesh.indices.len() / 3
    );
    let mut b = header.into_bytes();
    b.reserve(mesh.vertices.len() * 24 + mesh.indices.len() / 3 * 13);
    for v in &mesh.vertices {
        for x in v.position.iter().chain(v.normal.iter()) {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for t in mesh.indices.chunks_exact(3) {
        b.push(3);
        for i in t {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    Ok(b)
}

/// File names of the PLYs: index and a sanitised object name.
fn ply_name(i: usize, object: &Object) -> String {
    let clean: String = object
        .name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(40)
        .collect();
    format!("{i:02}-{clean}.ply")
}

/// The scene XML; `warnings` collects what cannot be expressed.
pub fn scene_xml(
    scene: &Scene,
    width: u32,
    height: u32,
    spp: u32,
    max_depth: u32,
    warnings: &mut Vec<String>,
) -> Result<String> {
    let d = &scene.desc;
    let pi = std::f64::consts::PI;
    let mut x = String::new();
    let cam = &d.camera;
    let (pos, target) = (Vec3::from(cam.position), Vec3::from(cam.target));
    let up = up_for(target - pos, Vec3::from(cam.up));
    writeln!(x, "<?xml version=\"1.0\" encoding=\"utf-8\"?>")?;
    writeln!(
        x,
        "<!-- Written by `subsurface export-mitsuba`; conventions in docs/lab/fidelity.md.\n     \
         Emitters are pi times our intensities: our diffuse radiance is albedo x irradiance. -->"
    )?;
    writeln!(x, "<scene version=\"3.0.0\">")?;
    writeln!(x, "  <default name=\"spp\" value=\"{spp}\"/>")?;
    writeln!(x, "  <default name=\"width\" value=\"{width}\"/>")?;
    writeln!(x, "  <default name=\"height\" value=\"{height}\"/>")?;
    writeln!(x, "  <default name=\"max_depth\" value=\"{max_depth}\"/>")?;
    writeln!(x, "  <default name=\"seed\" value=\"0\"/>")?;
    // Russian roulette only after many bounces: it is unbiased either way, but early roulette
    // on a 0.96-albedo medium adds a lot of variance for little time saved.
    writeln!(
        x,
        "  <integrator type=\"volpath\">\n    <integer name=\"max_depth\" value=\"$max_depth\"/>\n    \
         <integer name=\"rr_depth\" value=\"64\"/>\n  </integrator>"
    )?;
    writeln!(
        x,
        "  <sensor type=\"perspective\">\n    <string name=\"fov_axis\" value=\"y\"/>\n    \
         <float name=\"fov\" value=\"{}\"/>\n    <transform name=\"to_world\">\n      \
         <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    \
         <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"$spp\"/>\n      \
         <integer name=\"seed\" value=\"$seed\"/>\n    </sampler>\n    \
         <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"$width\"/>\n      \
         <integer name=\"height\" value=\"$height\"/>\n      <string name=\"pixel_format\" value=\"rgb\"/>\n      \
         <!-- A box filter: one pixel is one pixel of the rasteriser (no wider reconstruction). -->\n      \
         <rfilter type=\"box\"/>\n    </film>\n  </sensor>",
        num(cam.fov_y_deg.into()),
        v3(pos),
        v3(target),
        v3(up)
    )?;
    let amb = d.render.ambient;
    if amb.iter().any(|&a| a > 0.0) {
        writeln!(
            x,
            "  <emitter type=\"constant\">\n    <rgb name=\"radiance\" value=\"{}\"/>\n  </emitter>",
            rgb(amb.map(f64::from))
        )?;
    }
    if d.render.background != d.render.ambient {
        warnings.push(format!(
            "render.background {:?} differs from render.ambient {:?}: Mitsuba's background is the ambient environment",
            d.render.background, d.render.ambient
        ));
    }
    for (i, l) in d.lights.iter().enumerate() {
        let power = l.color.map(|c| f64::from(c) * f64::from(l.intensity) * pi);
        fits(
            &format!("lights[{i}].intensity"),
            "pi x color x intensity",
            &power,
        )?;
        let (p, t) = (Vec3::from(l.position), Vec3::from(l.target));
        if l.shadow_map_size == 0 {
            warnings.push(format!("lights[{i}]: shadow_map_size = 0 (unshadowed) cannot be expressed; Mitsuba shadows it"));
        }
        match l.kind {
            LightKind::Point => writeln!(
                x,
                "  <emitter type=\"point\">\n    <point name=\"position\" value=\"{}\"/>\n    \
                 <rgb name=\"intensity\" value=\"{}\"/>\n  </emitter>",
                v3(p),
                rgb(power)
            )?,
            LightKind::Spot => writeln!(
                x,
                "  <emitter type=\"spot\">\n    <transform name=\"to_world\">\n      \
                 <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    \
                 <rgb name=\"intensity\" value=\"{}\"/>\n    \
                 <float name=\"beam_width\" value=\"{:.6}\"/>\n    \
                 <float name=\"cutoff_angle\" value=\"{:.6}\"/>\n  </emitter>",
                v3(p),
                v3(t),
                v3(up_for(t - p, Vec3::Y)),
                rgb(power),
                l.inner_angle_deg,
                l.outer_angle_deg
            )?,
            LightKind::Directional => writeln!(
                x,
                "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    \
                 <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
                v3((t - p).normalize()),
                rgb(power)
            )?,
        }
    }
    for (i, o) in scene.objects.iter().enumerate() {
        let m = &o.material;
        for (k, t) in [
            ("albedo_texture", o.albedo_texture.is_some()),
            ("normal_texture", o.normal_texture.is_some()),
            ("specular_texture", o.specular_texture.is_some()),
        ] {
            if t {
                warnings.push(format!(
                    "objects[{i}] ({}): {k} is not exported (uniform material)",
                    o.name
                ));
            }
        }
        writeln!(
            x,
            "  <!-- objects[{i}]: {} -->\n  <shape type=\"ply\">\n    \
             <string name=\"filename\" value=\"meshes/{}\"/>\n    \
             <boolean name=\"face_normals\" value=\"false\"/>",
            o.name.replace("--", "- -"),
            ply_name(i, o)
        )?;
        if m.sss_strength > 0.0 {
            let (mm, substituted) = exported_medium(&m.medium)
                .with_context(|| format!("objects[{i}].material.medium"))?;
            if substituted {
                warnings.push(format!(
                    "objects[{i}] ({}): medium \"{}\" (d'Eon's Gaussians) has no single medium; exported as Jensen 2001 \"skin1\"",
                    o.name, m.medium
                ));
            } else if m.albedo != [1.0; 3] {
                // The real-time colour is albedo x R_d; the path tracer's is R_d alone.
                warnings.push(format!(
                    "objects[{i}] ({}): albedo {:?} is not exported (the medium's own R_d is)",
                    o.name, m.albedo
                ));
            }
            if m.sss_strength < 1.0 {
                warnings.push(format!(
                    "objects[{i}] ({}): sss_strength {} exported as a full medium",
                    o.name, m.sss_strength
                ));
            }
            let (sa, ss) = medium_per_unit(&mm, o);
            let st: [f64; 3] = std::array::from_fn(|c| sa[c] + ss[c]);
            let albedo: [f64; 3] = std::array::from_fn(|c| ss[c] / st[c]);
            // Mitsuba treats an RGB sigma_t like a reflectance (values above 1 are not
            // representable): store sigma_t / max and the max as `scale`.
            let scale = st.iter().copied().fold(0.0, f64::max);
            let field = format!("objects[{i}].scale");
            fits(
                &field,
                "the medium's sigma per scene unit (sigma in 1/mm x mm_per_unit / (scale x \
                 sss_width))",
                &[sa, ss].concat(),
            )?;
            // Below the smallest normal f32 the medium would be empty or lose its precision
            // (sigma_t = 0: no scattering; Mitsuba may flush subnormals to zero).
            anyhow::ensure!(
                st.iter().all(|&v| v as f32 >= f32::MIN_POSITIVE),
                "{field}: the medium's sigma_t would be {:e} per scene unit in the Mitsuba \
                 scene, below the smallest normal 32-bit float (mm_per_unit / (scale x \
                 sss_width) is too small)",
                st.iter().copied().fold(f64::INFINITY, f64::min)
            );
            writeln!(
                x,
                "    <!-- {}: sigma_a {:?}, sigma_s' {:?} /mm, eta {}; per scene unit: sigma_a [{}], sigma_s [{}] -->\n    \
                 <bsdf type=\"roughdielectric\">\n      <string name=\"distribution\" value=\"beckmann\"/>\n      \
                 <float name=\"alpha\" value=\"{:.6}\"/>\n      <float name=\"int_ior\" value=\"{}\"/>\n      \
                 <float name=\"ext_ior\" value=\"1.0\"/>\n    </bsdf>\n    \
                 <medium type=\"homogeneous\" name=\"interior\">\n      \
                 <rgb name=\"albedo\" value=\"{}\"/>\n      <rgb name=\"sigma_t\" value=\"{}\"/>\n      \
                 <float name=\"scale\" value=\"{}\"/>\n      <phase type=\"isotropic\"/>\n    </medium>",
                m.medium.to_string().replace("--", "- -"),
                mm.sigma_a,
                mm.sigma_s_prime,
                mm.eta,
                rgb(sa),
                rgb(ss),
                m.roughness,
                mm.eta,
                rgb(albedo),
                rgb(st.map(|s| s / scale)),
                num(scale)
            )?;
        } else {
            writeln!(
                x,
                "    <bsdf type=\"diffuse\">\n      <rgb name=\"reflectance\" value=\"{}\"/>\n    </bsdf>",
                rgb(o.albedo.map(|a| f64::from(a.min(1.0))))
            )?;
        }
        writeln!(x, "  </shape>")?;
    }
    writeln!(x, "</scene>")?;
    Ok(x)
}

/// Writes `DIR/scene.xml` and `DIR/meshes/*.ply`. Everything is built in memory first and
/// written through temporary files, so a failure leaves no half-written scene; a value the
/// export cannot write is an error that starts with `source` (the scene file) and creates
/// nothing.
pub fn export(
    scene: &Scene,
    source: &str,
    out: &Path,
    width: u32,
    height: u32,
    spp: u32,
    max_depth: u32,
) -> Result<Vec<String>> {
    anyhow::ensure!(
        width > 0 && height > 0,
        "--width/--height: must be at least 1"
    );
    anyhow::ensure!(spp > 0, "--spp: must be at least 1");
    anyhow::ensure!(max_depth > 0, "--max-depth: must be at least 1");
    let mut warnings = Vec::new();
    let xml = scene_xml(scene, width, height, spp, max_depth, &mut warnings)
        .with_context(|| source.to_string())?;
    let plys: Vec<(String, Vec<u8>)> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| Ok((ply_name(i, o), ply_bytes(o, i)?)))
        .collect::<Result<_>>()
        .with_context(|| source.to_string())?;
    let meshes = out.join("meshes");
    // The folders this export creates, outermost first: removed again (when still empty) if
    // the export fails, so a failed write ("File too large") leaves no empty meshes/ behind.
    let created: Vec<PathBuf> = [out.to_path_buf(), meshes.clone()]
        .into_iter()
        .filter(|d| !d.exists())
        .collect();
    std::fs::create_dir_all(&meshes)
        .with_context(|| format!("{}: cannot create", meshes.display()))?;
    let written = write_files(&meshes, &plys, &out.join("scene.xml"), &xml);
    if written.is_err() {
        for d in created.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
    written.map(|()| warnings)
}

/// Writes every file through a temporary file and commits them only when all are written.
fn write_files(
    meshes: &Path,
    plys: &[(String, Vec<u8>)],
    xml_path: &Path,
    xml: &str,
) -> Result<()> {
    let mut pending = Vec::new();
    for (name, bytes) in plys {
        let mut p = crate::output::PendingFile::create(&meshes.join(name))?;
        p.write_bytes(bytes)?;
        pending.push(p);
    }
    let mut p = crate::output::PendingFile::create(xml_path)?;
    p.write_bytes(xml.as_bytes())?;
    pending.push(p);
    for p in pending {
        p.commit()?;
    }
    Ok(())
}

pub fn run(args: &ExportArgs) -> Result<()> {
    let scene = crate::settings_args::load_scene(args.scene.as_ref(), None)?;
    let width = args.width.unwrap_or(scene.desc.render.width);
    let height = args.height.unwrap_or(scene.desc.render.height);
    let source = args
        .scene
        .as_ref()
        .map_or("<default scene>".into(), |p| p.display().to_string());
    let warnings = export(
        &scene,
        &source,
        &args.out,
        width,
        height,
        args.spp,
        args.max_depth,
    )?;
    for w in &warnings {
        eprintln!("note: {w}");
    }
    println!(
        "{}: {} objects, {} lights, {width}x{height}",
        args.out.join("scene.xml").display(),
        scene.objects.len(),
        scene.desc.lights.len()
    );
    Ok(())
}
