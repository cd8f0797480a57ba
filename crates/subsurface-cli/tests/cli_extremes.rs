//! Inputs that are valid one number at a time but meet a limit together, and inputs a method
//! cannot use: a mesh without UVs under the texture-space methods, a black or non-finite
//! reference for `compare`, and values past what `export-mitsuba` can write (Mitsuba reads
//! 32-bit floats). Each either works with well-defined output or fails with one `error:` line
//! naming the field and leaves no output behind.

use crate::common;

use std::path::{Path, PathBuf};

use common::{
    assert_success, error_line, gpu_tempdir, refused, scene_toml, subsurface, tempdir, text,
    write_exr,
};

/// A GLB holding one quad (0.05 units square, in the xy plane, facing +z) with positions and
/// indices only: no normals (computed) and, what matters here, no `TEXCOORD_0`.
/// A GLB with one quad primitive per entry of `uvs` (all on the same vertices), each with
/// `TEXCOORD_0` where its entry is true.
fn glb_quads(uvs: &[bool]) -> Vec<u8> {
    let p: [f32; 12] = [0., 0., 0., 0.05, 0., 0., 0.05, 0.05, 0., 0., 0.05, 0.];
    let uv: [f32; 8] = [0., 0., 1., 0., 1., 1., 0., 1.];
    let mut bin: Vec<u8> = p.iter().flat_map(|v| v.to_le_bytes()).collect();
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend([0u8; 4]);
    bin.extend(uv.iter().flat_map(|v| v.to_le_bytes()));
    let primitives: Vec<String> = uvs
        .iter()
        .map(|&has| {
            let t = if has { r#","TEXCOORD_0":2"# } else { "" };
            format!(r#"{{"attributes":{{"POSITION":0{t}}},"indices":1}}"#)
        })
        .collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{}]}}],
        "buffers":[{{"byteLength":{}}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}},
        {{"buffer":0,"byteOffset":64,"byteLength":32}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[0.05,0.05,0]}},
        {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}},
        {{"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"}}]}}"#,
        primitives.join(","),
        bin.len()
    )
    .into_bytes();
    common::glb(json, &bin)
}

fn write_scene(dir: &Path, object: &str) {
    std::fs::write(dir.join("s.toml"), scene_toml("", object)).unwrap();
}

/// A scratch directory `name` holding a scene of a sphere of `segments` in the middle of the
/// view, with the lines of `extra` added to its object, and a grey reference `ref.exr` whose
/// pixels are `reference(x, y)`; None when the test is skipped for want of a GPU adapter.
fn sphere_compare(
    name: &str,
    segments: u32,
    extra: &str,
    reference: impl Fn(u32, u32) -> f32,
) -> Option<PathBuf> {
    let dir = gpu_tempdir(name)?;
    write_scene(
        &dir,
        &format!(
            "mesh = {{ shape = \"sphere\", radius = 0.02, segments = {segments} }}\n\
             translation = [0.025, 0.025, 0.0]\n{extra}"
        ),
    );
    write_exr(&dir.join("ref.exr"), 32, 24, reference);
    Some(dir)
}

#[test]
fn texture_space_methods_on_a_mesh_without_uvs_fail_naming_the_object() {
    let Some(dir) = gpu_tempdir("nouv") else {
        return;
    };
    std::fs::write(dir.join("nouv.glb"), glb_quads(&[false])).unwrap();
    write_scene(&dir, r#"mesh = { gltf = "nouv.glb" }"#);
    // The mesh itself is fine: screen-space scattering renders it.
    assert_success(&subsurface(&["render", "s.toml", "-o", "ok.png"], &dir));
    for (flags, method) in [
        (["--sss", "texture"], "sss.method \"texture\""),
        (["--transmittance", "tsm"], "transmittance.method \"tsm\""),
    ] {
        let mut args = vec!["render", "s.toml", "-o", "x.png", "--texture-size", "64"];
        args.extend(flags);
        let e = refused(&args, &dir, "x.png");
        assert!(
            e.starts_with(
                "error: objects[0].mesh.gltf: nouv.glb (object0) has no texture coordinates"
            ),
            "{e}"
        );
        assert!(e.contains(method), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A mesh where only some primitives have UVs covers UV space, so the coverage test passed
/// it and texture-space diffusion drew the primitives without UVs black with exit 0.
#[test]
fn texture_space_on_a_mesh_with_some_primitives_without_uvs_names_the_primitive() {
    let Some(dir) = gpu_tempdir("someuv") else {
        return;
    };
    std::fs::write(dir.join("some.glb"), glb_quads(&[true, false, true])).unwrap();
    write_scene(&dir, r#"mesh = { gltf = "some.glb" }"#);
    let args = [
        "render",
        "s.toml",
        "-o",
        "x.png",
        "--texture-size",
        "64",
        "--sss",
        "texture",
    ];
    let e = refused(&args, &dir, "x.png");
    assert!(
        e.starts_with(
            "error: objects[0].mesh.gltf: some.glb (object0) 2 of its 6 triangles have no \
             texture coordinates (mesh 0 primitive 1 has no TEXCOORD_0)"
        ),
        "{e}"
    );
    // With UVs on every primitive the same file renders in texture space.
    std::fs::write(dir.join("some.glb"), glb_quads(&[true, true])).unwrap();
    assert_success(&subsurface(&args, &dir));
    assert!(dir.join("x.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn compare_against_a_black_reference_reports_no_nan() {
    let Some(dir) = sphere_compare("black", 16, "", |_, _| 0.0) else {
        return;
    };
    let out = subsurface(&["compare", "ref.exr", "s.toml", "--json"], &dir);
    assert_success(&out);
    let json = String::from_utf8_lossy(&out.stdout);
    for bad in ["NaN", "nan", "inf"] {
        assert!(!json.contains(bad), "{bad} in {json}");
    }
    let r: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(r["rmse"].as_f64().unwrap() > 0.0, "{json}");
    assert!(r["rel_rmse"].is_null(), "{json}");
    let skin = &r["regions"][0];
    assert_eq!(skin["name"], "skin");
    assert!(skin["pixels"].as_u64().unwrap() > 0, "{json}");
    assert!(skin["rel_error"].is_null(), "{json}");
    assert!(
        skin["note"]
            .as_str()
            .unwrap()
            .contains("reference is black"),
        "{json}"
    );
    // The text report says so in words.
    let out = subsurface(&["compare", "ref.exr", "s.toml"], &dir);
    assert_success(&out);
    let t = text(&out);
    assert!(t.contains("skin n/a (black reference)"), "{t}");
    assert!(!t.contains("NaN") && !t.contains("inf"), "{t}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `--linear` writes the radiance that was compared: the RMSE recomputed from that EXR and the
/// reference is the one reported.
#[test]
fn compare_writes_the_compared_linear_radiance() {
    let Some(dir) = sphere_compare("linear", 16, "", |x, y| 0.01 * (x + y) as f32) else {
        return;
    };
    let out = subsurface(
        &[
            "compare", "ref.exr", "s.toml", "--json", "--linear", "ours.exr",
        ],
        &dir,
    );
    assert_success(&out);
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ours = image::open(dir.join("ours.exr")).unwrap().to_rgb32f();
    assert_eq!(ours.dimensions(), (32, 24));
    let sq: f64 = ours
        .enumerate_pixels()
        .flat_map(|(x, y, p)| {
            let want = 0.01 * (x + y) as f32;
            p.0.map(|v| f64::from(v - want).powi(2))
        })
        .sum();
    let rmse = (sq / (32.0 * 24.0 * 3.0)).sqrt();
    let reported = r["rmse"].as_f64().unwrap();
    assert!(rmse > 0.01, "a lit sphere differs from the ramp: {rmse}");
    assert!(
        (rmse - reported).abs() <= 1e-5 * reported,
        "{rmse} vs {reported}"
    );
    // A bad destination fails before rendering, naming the flag's file.
    let e = error_line(&subsurface(
        &[
            "compare",
            "ref.exr",
            "s.toml",
            "--linear",
            "no/such/dir/x.exr",
        ],
        &dir,
    ));
    assert!(e.contains("no/such/dir/x.exr"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `--supersample N` renders N x N samples per pixel and box-filters them like the path
/// tracer's film: inside the sphere every pixel keeps its value (a smooth surface), while the
/// silhouette's pixels take the share of their area that is skin. (No specular: a highlight
/// is as sharp as the pixels that sample it; no scattering or transmittance, so each pixel's
/// shading is its own and the film filter is all that is measured.)
#[test]
fn compare_supersamples_like_a_box_filter() {
    let Some(dir) = sphere_compare(
        "supersample",
        64,
        "[objects.material]\nspecular = 0.0",
        |_, _| 0.1,
    ) else {
        return;
    };
    let linear = |ss: &str, name: &str| {
        assert_success(&subsurface(
            &[
                "compare",
                "ref.exr",
                "s.toml",
                "--supersample",
                ss,
                "--linear",
                name,
                "--sss",
                "none",
                "--transmittance",
                "off",
            ],
            &dir,
        ));
        image::open(dir.join(name)).unwrap().to_rgb32f()
    };
    let one = linear("1", "one.exr");
    let four = linear("4", "four.exr");
    let lum = |p: &image::Rgb<f32>| p.0.iter().sum::<f32>();
    let (mut inside, mut edge) = (0, 0);
    let (mut sum_one, mut sum_four) = (0.0, 0.0);
    for y in 2..22i32 {
        for x in 2..30i32 {
            // Two pixels in from the outline every neighbour is skin lit from the same side.
            let around = (-2..=2)
                .flat_map(|j| (-2..=2).map(move |i| (x + i, y + j)))
                .all(|(i, j)| lum(one.get_pixel(i as u32, j as u32)) > 1.0);
            let (x, y) = (x as u32, y as u32);
            let (a, b) = (lum(one.get_pixel(x, y)), lum(four.get_pixel(x, y)));
            if around {
                // Shading varies smoothly inside: the box mean is near the centre's value (the
                // sphere is ten pixels across, so a pixel spans some shading).
                assert!((b / a - 1.0).abs() < 0.2, "({x}, {y}): {b} vs {a}");
                sum_one += a;
                sum_four += b;
                inside += 1;
            } else if a < 0.1 && b > 0.1 {
                // Just outside the sphere's outline (the background is about 0.06) a pixel
                // still holds some skin.
                edge += 1;
            }
        }
    }
    assert!(inside > 8 && edge > 4, "{inside} inside, {edge} edge");
    // Lambert shading falls like a cosine towards the outline, a concave function across a
    // pixel, so the box mean sits a little below the centre's value, never above it.
    let ratio = sum_four / sum_one;
    assert!(ratio > 0.95 && ratio < 1.002, "{sum_four} vs {sum_one}");
    for bad in ["0", "9"] {
        let e = refused(
            &[
                "compare",
                "ref.exr",
                "s.toml",
                "--supersample",
                bad,
                "-o",
                "c.png",
            ],
            &dir,
            "c.png",
        );
        assert!(
            e.starts_with("error: --supersample: must be in 1..=8"),
            "{e}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The reference is read before anything else, so no GPU is needed to reject it.
#[test]
fn compare_rejects_a_reference_with_nan_or_inf_pixels() {
    let dir = tempdir("nanref");
    write_scene(&dir, r#"mesh = { shape = "sphere", radius = 0.02 }"#);
    for (name, bad) in [("nan.exr", f32::NAN), ("inf.exr", f32::INFINITY)] {
        write_exr(&dir.join(name), 32, 24, |x, y| {
            if (x, y) == (5, 3) { bad } else { 0.5 }
        });
        let e = refused(&["compare", name, "s.toml", "-o", "c.png"], &dir, "c.png");
        assert!(
            e.starts_with(&format!("error: {name}: pixel (5, 3) is [")),
            "{e}"
        );
        assert!(e.ends_with("the reference must be finite and >= 0"), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// [`scene_toml`] with a skin sphere of `radius` and the `object` lines.
fn export_scene(light: &str, radius: &str, object: &str) -> String {
    scene_toml(
        light,
        &format!("mesh = {{ shape = \"sphere\", radius = {radius}, segments = 12 }}\n{object}"),
    )
}

/// Every number in the attributes of `scene.xml` fits Mitsuba's 32-bit floats, and every
/// float of every PLY is finite with unit normals.
fn assert_finite_export(out: &Path, what: &str) {
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    let mut numbers = 0;
    for value in xml.split("value=\"").skip(1) {
        let value = &value[..value.find('"').unwrap()];
        for token in value.split(',').map(str::trim) {
            if let Ok(v) = token.parse::<f64>() {
                numbers += 1;
                assert!(v.abs() <= f64::from(f32::MAX), "{what}: {token} in {value}");
            }
        }
        assert!(
            !value.contains("NaN") && !value.contains("inf"),
            "{what}: {value}"
        );
    }
    assert!(numbers > 20, "{what}: only {numbers} numbers");
    for ply in std::fs::read_dir(out.join("meshes")).unwrap() {
        let bytes = std::fs::read(ply.unwrap().path()).unwrap();
        let end = b"end_header\n";
        let body = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let header = String::from_utf8_lossy(&bytes[..body]);
        let n: usize = header
            .lines()
            .find_map(|l| l.strip_prefix("element vertex "))
            .unwrap()
            .parse()
            .unwrap();
        let floats: Vec<f32> = bytes[body..body + n * 24]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        for v in floats.chunks_exact(6) {
            assert!(v.iter().all(|x| x.is_finite()), "{what}: vertex {v:?}");
            let len = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]).sqrt();
            assert!((len - 1.0).abs() < 1e-3, "{what}: normal {v:?}");
        }
    }
}

#[test]
fn export_mitsuba_writes_finite_numbers_at_the_extremes() {
    let dir = tempdir("export-extremes");
    let cases = [
        ("intensity = 1e38", "0.04", ""),
        ("color = [1e38, 0.0, 1.0]", "0.04", ""),
        ("", "0.04", "scale = 1e-30"),
        ("", "0.04", "scale = 1e30"),
        ("", "1e-30", "scale = 1e-30"),
        ("", "1e30", "translation = [1e38, 0.0, 0.0]"),
        ("", "0.04", "material = { sss_width = 1e-30 }"),
        ("", "0.04", "material = { sss_width = 3e38 }"),
        ("", "0.04", "mm_per_unit = 1e-30"),
    ];
    for (i, (light, radius, object)) in cases.iter().enumerate() {
        let what = format!("{light} {radius} {object}");
        let scene = format!("s{i}.toml");
        std::fs::write(dir.join(&scene), export_scene(light, radius, object)).unwrap();
        let out = format!("out{i}");
        let run = subsurface(&["export-mitsuba", &scene, "--out", &out], &dir);
        assert!(run.status.success(), "{what}: {}", text(&run));
        assert_finite_export(&dir.join(&out), &what);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn export_mitsuba_rejects_what_mitsuba_cannot_read_and_writes_nothing() {
    let dir = tempdir("export-reject");
    let cases = [
        (
            "intensity = 3e38\ncolor = [3e38, 3e38, 3e38]",
            "0.04",
            "",
            "s.toml: lights[0].intensity: pi x color x intensity would be",
        ),
        (
            "",
            "0.04",
            "mm_per_unit = 3e38\nscale = 1e-30",
            "s.toml: objects[0].scale: the medium's sigma per scene unit",
        ),
        (
            "",
            "1e38",
            "scale = 3e38",
            "s.toml: objects[0].scale: the mesh's extent times the scale overflows",
        ),
        (
            "target = [0.0, 0.0, 3e38]",
            "0.04",
            "",
            "s.toml: lights[0].target: must be within",
        ),
    ];
    for (light, radius, object, expected) in cases {
        std::fs::write(dir.join("s.toml"), export_scene(light, radius, object)).unwrap();
        let e = refused(&["export-mitsuba", "s.toml", "--out", "out"], &dir, "out");
        assert!(e.starts_with(&format!("error: {expected}")), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
