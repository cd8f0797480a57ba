use super::*;

const MINIMAL: &str = r#"
[camera]
position = [0.0, 0.0, 1.0]
target = [0.0, 0.0, 0.0]

[[lights]]
kind = "spot"
position = [0.0, 0.0, -1.0]
target = [0.0, 0.0, 0.0]

[[objects]]
mesh = { shape = "slab", width = 0.1, height = 0.1, thickness = 0.01 }
"#;

fn parse(s: &str) -> Result<SceneDesc, SceneError> {
    SceneDesc::from_toml_str(s, "t.toml")
}

/// Parses MINIMAL with one `key = value` line appended to the `[table]`
/// that is also given, expecting an error mentioning `field`.
fn invalid_with(table_line: &str, insert: &str, field: &str) {
    let s = MINIMAL.replacen(table_line, &format!("{table_line}\n{insert}"), 1);
    let e = parse(&s).expect_err(&format!("{insert} should be rejected"));
    let msg = e.to_string();
    assert!(!msg.contains('\n'), "{msg}");
    assert!(msg.starts_with("t.toml"), "{msg}");
    assert!(msg.contains(field), "`{msg}` does not name `{field}`");
}

fn cam(line: &str, field: &str) {
    invalid_with("[camera]", line, field)
}
fn light(line: &str, field: &str) {
    invalid_with("kind = \"spot\"", line, field)
}
fn obj(line: &str, field: &str) {
    invalid_with(
        "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
        line,
        field,
    )
}
fn mat(line: &str, field: &str) {
    let s = format!("{MINIMAL}\n[objects.material]\n{line}\n");
    let e = parse(&s).expect_err(&format!("{line} should be rejected"));
    let msg = e.to_string();
    assert!(!msg.contains('\n'), "{msg}");
    assert!(msg.contains(field), "`{msg}` does not name `{field}`");
}
fn render(line: &str, field: &str) {
    let s = format!("{MINIMAL}\n[render]\n{line}\n");
    let e = parse(&s).expect_err(&format!("{line} should be rejected"));
    assert!(e.to_string().contains(field), "{e} does not name {field}");
}
fn mesh(m: &str, needle: &str) {
    let s = MINIMAL.replace(
        "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
        &format!("mesh = {m}"),
    );
    let e = parse(&s).expect_err(&format!("{m} should be rejected"));
    let msg = e.to_string();
    assert!(!msg.contains('\n'), "{msg}");
    assert!(msg.contains(needle), "`{msg}` does not contain `{needle}`");
}

#[test]
fn minimal_scene_gets_defaults() {
    let d = parse(MINIMAL).unwrap();
    assert_eq!(d.camera.up, [0.0, 1.0, 0.0]);
    assert_eq!(d.camera.fov_y_deg, 30.0);
    assert_eq!(d.render, crate::settings::RenderSettings::default());
    assert_eq!(d.lights[0].kind, LightKind::Spot);
    assert_eq!(d.lights[0].shadow_map_size, 2048);
    assert_eq!(d.objects[0].mm_per_unit, 1000.0);
    assert_eq!(d.objects[0].scale, 1.0);
    assert_eq!(d.objects[0].material, MaterialDesc::default());
    let m = &d.objects[0].material;
    assert_eq!(m.roughness, 0.3);
    assert_eq!(m.specular, 0.18);
    assert_eq!(
        m.kernel_params(true),
        ([0.48, 0.41, 0.28], [1.0, 0.37, 0.3])
    );
    assert_eq!(m.kernel_params(false), ([1.0; 3], [1.0; 3]));
    assert_eq!(m.medium.to_string(), "skin");
}

#[test]
fn mesh_forms() {
    let with = |m: &str| {
        parse(&MINIMAL.replace(
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
            &format!("mesh = {m}"),
        ))
        .unwrap()
        .objects[0]
            .mesh
            .clone()
    };
    assert_eq!(
        with(r#"{ gltf = "a/b.glb" }"#),
        MeshDesc::Gltf {
            path: "a/b.glb".into()
        }
    );
    assert_eq!(
        with(r#"{ shape = "wedge", length = 1, height = 2, max_thickness = 0.5 }"#),
        MeshDesc::Wedge {
            length: 1.0,
            height: 2.0,
            max_thickness: 0.5
        }
    );
    assert_eq!(
        with(r#"{ shape = "sphere", radius = 2 }"#),
        MeshDesc::Sphere {
            radius: 2.0,
            segments: 64
        }
    );
}

#[test]
fn round_trip_all_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut texts = vec![("default".to_string(), DEFAULT_SCENE_TOML.to_string())];
    for entry in std::fs::read_dir(root.join("scenes")).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            texts.push((
                p.display().to_string(),
                std::fs::read_to_string(&p).unwrap(),
            ));
        }
    }
    assert!(texts.len() >= 3, "expected scenes/*.toml");
    for (name, text) in texts {
        let d = SceneDesc::from_toml_str(&text, &name).unwrap();
        let s = d.to_toml_string();
        let d2 = SceneDesc::from_toml_str(&s, "round-trip")
            .unwrap_or_else(|e| panic!("{name}: {e}\n{s}"));
        assert_eq!(d, d2, "{name}\n{s}");
    }
    // Also every mesh kind and optional field.
    let mut d = parse(MINIMAL).unwrap();
    let mut o = d.objects[0].clone();
    o.material.albedo_texture = Some("a.png".into());
    o.material.use_gltf_color = false;
    o.mesh = MeshDesc::Sphere {
        radius: 0.3,
        segments: 7,
    };
    d.objects.push(o.clone());
    o.mesh = MeshDesc::Gltf {
        path: "x y/\"q\".glb".into(),
    };
    d.objects.push(o.clone());
    o.mesh = MeshDesc::Wedge {
        length: 0.1,
        height: 0.2,
        max_thickness: 0.03,
    };
    d.objects.push(o);
    d.lights.push(LightDesc {
        kind: LightKind::Directional,
        ..Default::default()
    });
    let s = d.to_toml_string();
    assert_eq!(SceneDesc::from_toml_str(&s, "rt").unwrap(), d, "{s}");
}

#[test]
fn syntax_and_unknown_key_errors_have_line_col() {
    let e = parse("[camera]\nposition = [0, 0, 1]\ntarget = [0,0,0]\nfoo = 1\n")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("t.toml:4:1: "), "{e}");
    assert!(e.contains("unknown field `foo`"), "{e}");
    assert!(!e.contains('\n'));
    let e = parse("[camera\n").unwrap_err().to_string();
    assert!(e.starts_with("t.toml:1:"), "{e}");
    assert!(!e.contains('\n'));
    let e = parse(&format!("{MINIMAL}\n[bogus]\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown field `bogus`"), "{e}");
    // unknown key in a nested table
    mat("glossiness = 0.5", "unknown field `glossiness`");
    // wrong type
    let e = parse(&MINIMAL.replace("kind = \"spot\"", "kind = \"area\""))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("t.toml:7:"), "{e}");
    assert!(!e.contains('\n'));
    for bad in [
        "[camera]\nposition = [0, 0]\ntarget = [0, 0, 0]\n",
        "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n[[objects]]\nmesh = { shape = \"slab\" }\n",
        "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n[[lights]]\nkind = \"point\"\n",
        "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n[[objects]]\nmesh = { gltf = \"a\" }\n[objects.material]\nroughness = \"x\"\n",
    ] {
        let e = parse(bad).unwrap_err().to_string();
        eprintln!("{e}");
        assert!(e.starts_with("t.toml:") && !e.contains('\n'), "{e}");
    }
    // missing camera
    let e = parse("").unwrap_err().to_string();
    assert!(e.contains("camera"), "{e}");
}

#[test]
fn invalid_mesh_tables() {
    mesh(
        r#"{ shape = "slab", width = 1, height = 1 }"#,
        "needs `thickness`",
    );
    mesh(
        r#"{ shape = "slab", width = 1, height = 1, thickness = 1, radius = 2 }"#,
        "`radius` does not apply",
    );
    mesh(r#"{ gltf = "a.glb", shape = "slab" }"#, "not both");
    mesh(
        r#"{ gltf = "a.glb", radius = 1 }"#,
        "`radius` does not apply",
    );
    mesh("{}", "needs `gltf");
    mesh(r#"{ shape = "cube" }"#, "cube");
    mesh(
        r#"{ gltf = "a.glb", colour = 1 }"#,
        "unknown field `colour`",
    );
    let e = parse(&MINIMAL.replace("width = 0.1", "width = 0.1, depth = 2"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("t.toml:12:"), "{e}");
}

#[test]
fn invalid_non_finite() {
    cam("fov_y_deg = nan", "camera.fov_y_deg");
    cam("near = inf", "camera.near");
    light("intensity = -inf", "lights[0].intensity");
    light("shadow_bias = nan", "lights[0].shadow_bias");
    obj("translation = [0.0, nan, 0.0]", "objects[0].translation[1]");
    obj(
        "rotation_deg = [inf, 0.0, 0.0]",
        "objects[0].rotation_deg[0]",
    );
    mat("roughness = nan", "objects[0].material.roughness");
    render("exposure_ev = nan", "render.exposure_ev");
    let e = parse(&MINIMAL.replace("position = [0.0, 0.0, 1.0]", "position = [0.0, nan, 1.0]"))
        .unwrap_err()
        .to_string();
    assert_eq!(e, "t.toml: camera.position[1]: must be finite (got NaN)");
}

#[test]
fn invalid_camera() {
    cam("near = 0.0", "camera.near");
    cam("near = -1.0", "camera.near");
    cam("near = 2.0\nfar = 1.0", "camera.far");
    // A far/near ratio past 1e6 leaves the 32-bit depth no precision.
    cam("near = 1e-30", "camera.near");
    cam("fov_y_deg = 0.0", "camera.fov_y_deg");
    cam("fov_y_deg = 180.0", "camera.fov_y_deg");
    cam("up = [0.0, 0.0, 1.0]", "camera.up");
    cam("up = [0.0, 0.0, 0.0]", "camera.up");
    let e = parse(&MINIMAL.replace(
        "target = [0.0, 0.0, 0.0]\n\n[[lights]]",
        "target = [0.0, 0.0, 1.0]\n\n[[lights]]",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("camera.target"), "{e}");
    // Finite ends whose difference squared overflows f32: the direction normalised to 0/NaN.
    let e = parse(
        &MINIMAL
            .replacen(
                "position = [0.0, 0.0, 1.0]",
                "position = [3e38, 0.0, 1.0]",
                1,
            )
            .replacen("target = [0.0, 0.0, 0.0]", "target = [-3e38, 0.0, 0.0]", 1),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("t.toml: camera.target: must be within"),
        "{e}"
    );
}

#[test]
fn invalid_render() {
    render("width = 0", "render.width");
    render("height = 16385", "render.height");
    render("ambient = [0.1, -0.1, 0.0]", "render.ambient[1]");
    render("background = [-1.0, 0.0, 0.0]", "render.background[0]");
    render("width = -5", "render.width");
    render(
        "transmitted_map = { texel_mm = 60.0 }",
        "render.transmitted_map.texel_mm",
    );
    // Keys that moved name their new place.
    let s = format!("{MINIMAL}\n[render.transmittance]\nlateral_texel_mm = 2.0\n");
    let e = parse(&s).unwrap_err().to_string();
    assert!(
        e.contains("render.transmittance.lateral_texel_mm")
            && e.contains("render.transmitted_map.texel_mm"),
        "{e}"
    );
}

#[test]
fn invalid_lights() {
    light("intensity = -1.0", "lights[0].intensity");
    light("color = [1.0, -0.5, 1.0]", "lights[0].color[1]");
    light("inner_angle_deg = 0.0", "lights[0].inner_angle_deg");
    light(
        "inner_angle_deg = 40.0\nouter_angle_deg = 30.0",
        "lights[0].inner_angle_deg",
    );
    light("outer_angle_deg = 90.0", "lights[0].outer_angle_deg");
    light("shadow_map_size = 8", "lights[0].shadow_map_size");
    light("shadow_map_size = 8193", "lights[0].shadow_map_size");
    light("shadow_bias = -0.1", "lights[0].shadow_bias");
    // spot with position == target
    let e = parse(&MINIMAL.replace("position = [0.0, 0.0, -1.0]", "position = [0.0, 0.0, 0.0]"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("lights[0].target"), "{e}");
    // A spot 3e38 away from its target: |d|^2 overflows and the direction normalised to 0.
    let e = parse(&MINIMAL.replace("position = [0.0, 0.0, -1.0]", "position = [3e38, 0.0, 0.0]"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("lights[0].target: must be within"), "{e}");
    // point lights: angles and target are not checked beyond finiteness
    let ok = MINIMAL
        .replace(
            "kind = \"spot\"",
            "kind = \"point\"\nouter_angle_deg = 120.0",
        )
        .replace("position = [0.0, 0.0, -1.0]", "position = [0.0, 0.0, 0.0]");
    parse(&ok).unwrap();
    // shadow_map_size = 0 (no shadow) is fine
    parse(&MINIMAL.replace("kind = \"spot\"", "kind = \"spot\"\nshadow_map_size = 0")).unwrap();
}

#[test]
fn invalid_objects() {
    let e = parse(&MINIMAL.replace(
        "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
        "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }\nmm_per_unit = -1",
    ))
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "t.toml: objects[0].mm_per_unit: must be finite and > 0 (got -1)"
    );
    obj("mm_per_unit = 0.0", "objects[0].mm_per_unit");
    obj("scale = 0.0", "objects[0].scale");
    obj("tessellate = 0", "objects[0].tessellate");
    obj("tessellate = 9", "objects[0].tessellate");
    mesh(
        r#"{ shape = "slab", width = 0, height = 1, thickness = 1 }"#,
        "objects[0].mesh.width",
    );
    mesh(
        r#"{ shape = "slab", width = 1, height = -1, thickness = 1 }"#,
        "objects[0].mesh.height",
    );
    mesh(
        r#"{ shape = "slab", width = 1, height = 1, thickness = 0 }"#,
        "objects[0].mesh.thickness",
    );
    mesh(
        r#"{ shape = "wedge", length = 0, height = 1, max_thickness = 1 }"#,
        "objects[0].mesh.length",
    );
    mesh(
        r#"{ shape = "wedge", length = 1, height = 1, max_thickness = -1 }"#,
        "objects[0].mesh.max_thickness",
    );
    mesh(
        r#"{ shape = "sphere", radius = 0 }"#,
        "objects[0].mesh.radius",
    );
    mesh(
        r#"{ shape = "sphere", radius = 1, segments = 2 }"#,
        "objects[0].mesh.segments",
    );
    mesh(
        r#"{ shape = "sphere", radius = 1, segments = 1025 }"#,
        "objects[0].mesh.segments",
    );
    mesh(r#"{ gltf = "" }"#, "objects[0].mesh.gltf");
}

/// `tessellate = N` gives the object N x N triangles per authored one, pulled out onto the
/// surface its normals describe (a coarse sphere's triangles move outward, none inward).
#[test]
fn tessellate_splits_and_rounds_the_mesh() {
    let load = |more: &str| {
        let s = MINIMAL.replace(
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
            &format!("mesh = {{ shape = \"sphere\", radius = 1.0, segments = 8 }}\n{more}"),
        );
        Scene::from_desc(parse(&s).unwrap(), Path::new("."), "t.toml").unwrap()
    };
    let flat = load("");
    let round = load("tessellate = 3");
    let (f, r) = (&flat.objects[0].mesh, &round.objects[0].mesh);
    assert_eq!(r.triangle_count(), f.triangle_count() * 9);
    let mean_radius = |m: &crate::mesh::Mesh| {
        m.vertices
            .iter()
            .map(|v| glam::Vec3::from(v.position).length())
            .sum::<f32>()
            / m.vertices.len() as f32
    };
    assert!(
        mean_radius(f) > 0.999,
        "the authored vertices are on the sphere"
    );
    let new_points = r.vertices.len() - f.vertices.len();
    assert!(new_points > 0);
    assert!(
        mean_radius(r) > 0.97,
        "tessellated points near the sphere: {}",
        mean_radius(r)
    );
    // Flat, the same points would be on the facets, some well inside.
    let flat_mid = f
        .indices
        .chunks_exact(3)
        .map(|t| {
            t.iter()
                .map(|i| glam::Vec3::from(f.vertices[*i as usize].position))
                .sum::<glam::Vec3>()
                .length()
                / 3.0
        })
        .fold(f32::INFINITY, f32::min);
    assert!(flat_mid < 0.9, "{flat_mid}");
    // The default scene rounds its low-poly hand.
    let d = Scene::default_scene();
    assert_eq!(d.desc.objects[0].tessellate, 3);
}

/// Each number is valid, but the object in world space does not fit in f32: rejected when the
/// scene loads, naming the field that overflowed.
#[test]
fn world_extent_past_f32_is_an_error() {
    let load = |m: &str, more: &str| {
        let s = MINIMAL.replace(
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
            &format!("mesh = {m}\n{more}"),
        );
        Scene::from_desc(parse(&s).unwrap(), Path::new("."), "t.toml").map(|_| ())
    };
    let sphere = r#"{ shape = "sphere", radius = 1e38, segments = 8 }"#;
    let e = load(sphere, "scale = 3e38").unwrap_err().to_string();
    assert_eq!(
        e,
        "t.toml: objects[0].scale: the mesh's extent times the scale overflows 32-bit floats"
    );
    let e = load(sphere, "translation = [3e38, 0.0, 0.0]")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("t.toml: objects[0].translation: "), "{e}");
    // Extreme but representable: fine.
    load(sphere, "").unwrap();
    load(r#"{ shape = "sphere", radius = 1e-30 }"#, "scale = 1e-30").unwrap();
}

#[test]
fn invalid_materials() {
    mat("roughness = 0.0", "objects[0].material.roughness");
    mat("roughness = 1.5", "objects[0].material.roughness");
    mat("specular = -0.1", "objects[0].material.specular");
    mat("sss_strength = 1.1", "objects[0].material.sss_strength");
    mat("sss_strength = -0.1", "objects[0].material.sss_strength");
    mat("sss_width = 0.0", "objects[0].material.sss_width");
    mat("translucency = -1.0", "objects[0].material.translucency");
    mat(
        "kernel_strength = [0.5, 1.5, 0.5]",
        "objects[0].material.kernel_strength[1]",
    );
    mat(
        "falloff = [-0.1, 0.5, 0.5]",
        "objects[0].material.falloff[0]",
    );
    mat("albedo = [0.5, 0.5, -0.5]", "objects[0].material.albedo[2]");
    mat("profile = \"\"", "objects[0].material.medium");
    mat("medium = \"velvet\"", "objects[0].material.medium");
    mat(
        "medium = { sigma_a = [0.0, 1.0, 1.0], sigma_s = [1.0, 1.0, 1.0] }",
        "objects[0].material.medium",
    );
    mat(
        "medium = { sigma_a = [1.0, 1.0, 1.0], sigma_s = [1.0, 1.0, 1.0], eta = 20.0 }",
        "objects[0].material.medium",
    );
    mat(
        "albedo_texture = \"\"",
        "objects[0].material.albedo_texture",
    );
    // Boundaries that are valid.
    let ok = format!(
        "{MINIMAL}\n[objects.material]\nroughness = 1.0\nsss_strength = 0.0\nspecular = 0.0\ntranslucency = 0.0\nkernel_strength = [0.0, 1.0, 0.0]\n"
    );
    parse(&ok).unwrap();
}

#[test]
fn default_scene_loads() {
    let s = Scene::default_scene();
    assert_eq!(s.objects.len(), s.desc.objects.len());
    assert!(s.objects.len() >= 2);
    let shadowed = s
        .desc
        .lights
        .iter()
        .filter(|l| l.shadow_map_size > 0)
        .count();
    assert!(shadowed >= 2);
    let hand = &s.objects[0];
    assert_eq!(hand.mm_per_unit, 1000.0);
    assert!(hand.mesh.vertices.len() > 1000);
    let (lo, hi) = s.bounds();
    eprintln!("default scene bounds {lo} .. {hi}");
    assert!((hi - lo).max_element() < 1.0);
    // Camera looks at the scene.
    let cam = &s.desc.camera;
    let c = (lo + hi) * 0.5;
    let dir = (Vec3::from(cam.target) - Vec3::from(cam.position)).normalize();
    let to_c = (c - Vec3::from(cam.position)).normalize();
    assert!(dir.dot(to_c) > 0.95);
    // Hand orientation (see default_scene.toml): in object space the fingers
    // point to -y, the palm faces -x and the thumb is at -z; in the world the
    // fingers point up, the palm faces the camera (+z), the thumb is at +x.
    let w = |p: [f32; 3]| hand.transform.transform_point3(Vec3::from(p));
    let wrist = w([0.039, 0.056, 0.009]);
    let middle_tip = w([0.030, -0.122, 0.016]);
    let thumb_tip = w([-0.0098, -0.0359, -0.0687]);
    let pinky_tip = w([0.0174, -0.0821, 0.0611]);
    assert!(middle_tip.y - wrist.y > 0.15, "{wrist} {middle_tip}");
    assert!(thumb_tip.x - pinky_tip.x > 0.08, "{thumb_tip} {pinky_tip}");
    assert!(thumb_tip.z > pinky_tip.z);
    // The wedge: thin edge toward the hand.
    let (wlo, whi) = s.objects[1].world_bounds();
    assert!(wlo.x > hand.world_bounds().1.x);
    assert!((whi.z - wlo.z - 0.025).abs() < 1e-6);
}

#[test]
fn scene_files_validate_and_refer_to_existing_assets() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for name in ["head.toml", "five-lights.toml"] {
        let p = root.join("scenes").join(name);
        let d = SceneDesc::from_toml_str(&std::fs::read_to_string(&p).unwrap(), name).unwrap();
        if name == "five-lights.toml" {
            assert!(d.lights.iter().filter(|l| l.shadow_map_size > 0).count() >= 5);
        }
        if !root
            .join("../shared/assets/LeePerrySmith/LeePerrySmith.glb")
            .exists()
        {
            continue;
        }
        let t0 = std::time::Instant::now();
        let s = Scene::load_file(&p).unwrap_or_else(|e| panic!("{e}"));
        eprintln!(
            "{name}: loaded in {:?}, bounds {:?}",
            t0.elapsed(),
            s.bounds()
        );
        let head = &s.objects[0];
        assert_eq!(head.mm_per_unit, 48.0);
        assert!(head.albedo_texture.is_some());
        assert!(head.normal_texture.is_some());
        assert!(head.specular_texture.is_some());
    }
}

#[test]
fn asset_errors_name_scene_field_and_file() {
    let dir = std::env::temp_dir().join(format!("subsurface-scene-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bad.glb"), b"glTF garbage").unwrap();
    std::fs::write(dir.join("bad.png"), b"\x89PNG\r\n\x1a\n garbage").unwrap();
    let scene = |mesh: &str, mat: &str| {
        let s = format!(
            "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n[[objects]]\nmesh = {mesh}\n[objects.material]\n{mat}\n"
        );
        let p = dir.join("s.toml");
        std::fs::write(&p, s).unwrap();
        Scene::load_file(&p).err().expect("should fail").to_string()
    };
    let slab = r#"{ shape = "slab", width = 1, height = 1, thickness = 1 }"#;
    let e = scene(r#"{ gltf = "missing.glb" }"#, "");
    assert!(
        e.contains("s.toml: objects[0].mesh.gltf: ") && e.contains("missing.glb: cannot read"),
        "{e}"
    );
    let e = scene(r#"{ gltf = "bad.glb" }"#, "");
    assert!(e.contains("bad.glb: not a valid glTF file"), "{e}");
    let e = scene(slab, "albedo_texture = \"nope.png\"");
    assert!(
        e.contains("objects[0].material.albedo_texture: ") && e.contains("nope.png: cannot read"),
        "{e}"
    );
    let e = scene(slab, "normal_texture = \"bad.png\"");
    assert!(
        e.contains("objects[0].material.normal_texture: ")
            && e.contains("bad.png: cannot decode image"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");
    let e = Scene::load_file(&dir.join("nonexistent.toml"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("nonexistent.toml: cannot read"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn replace_model_refits_camera() {
    let mut s = Scene::default_scene();
    let dir0 = (Vec3::from(s.desc.camera.target) - Vec3::from(s.desc.camera.position)).normalize();
    // Write the hand GLB to a temp file and load it as a model scaled... it is the same
    // hand, so the new scene is just the hand.
    let dir = std::env::temp_dir().join(format!("subsurface-model-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("hand.glb");
    std::fs::write(&p, mesh::BUILTIN_HAND_GLB).unwrap();
    s.replace_model(&p).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.desc.objects.len(), 1);
    assert_eq!(s.objects[0].mm_per_unit, 1000.0);
    assert_eq!(s.objects[0].albedo, SKIN_ALBEDO);
    let cam = &s.desc.camera;
    let dir1 = (Vec3::from(cam.target) - Vec3::from(cam.position)).normalize();
    assert!(dir0.dot(dir1) > 0.9999);
    let (c, r) = super::reframe::bounding_sphere(s.bounds());
    assert!((Vec3::from(cam.target) - c).length() < 1e-5);
    let dist = (Vec3::from(cam.position) - c).length();
    let half = cam.fov_y_deg.to_radians() * 0.5; // 16:9, vertical is narrower
    assert!((r / dist - half.sin()).abs() < 1e-4);
    assert!(cam.near < dist - r && cam.far > dist + r);
    s.desc.validate("after replace").unwrap();
    // Round-trips with the absolute path.
    let t = s.desc.to_toml_string();
    assert_eq!(SceneDesc::from_toml_str(&t, "x").unwrap(), s.desc);
    assert!(s.replace_model(&dir.join("missing.glb")).is_err());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn euler_convention() {
    let o = ObjectDesc {
        name: String::new(),
        mesh: MeshDesc::Sphere {
            radius: 1.0,
            segments: 8,
        },
        mm_per_unit: 1.0,
        translation: [1.0, 2.0, 3.0],
        rotation_deg: [0.0, 90.0, 0.0],
        scale: 2.0,
        tessellate: 1,
        material: MaterialDesc::default(),
    };
    // +x rotated 90 deg about y -> -z, scaled by 2, translated.
    let p = o.transform().transform_point3(Vec3::X);
    assert!((p - Vec3::new(1.0, 2.0, 1.0)).length() < 1e-5, "{p}");
}
