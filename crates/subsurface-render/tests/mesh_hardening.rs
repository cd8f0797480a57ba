//! Malformed glTF files built in memory: each must fail fast with a one-line error that
//! names the file and the node or accessor at fault - never a panic, a stack overflow, a
//! hang, a huge allocation or a silently different mesh.

use crate::mesh_util;

use glam::Vec3;
use mesh_util::*;
use subsurface_render::mesh::{
    self, MAX_GLTF_INDICES, MAX_GLTF_VERTICES, MAX_NODE_DEPTH, MAX_NODE_INSTANCES, load_gltf_slice,
};

fn load_ok(bytes: &[u8], name: &str) -> mesh::GltfModel {
    let t0 = std::time::Instant::now();
    let m = load_gltf_slice(bytes, name).unwrap_or_else(|e| panic!("{e}"));
    assert!(t0.elapsed() < TIME_LIMIT);
    m
}

fn set_quad_positions(m: &mut Model, p: &[f32; 12]) {
    let bytes = f32_bytes(p);
    m.bin[..48].copy_from_slice(&bytes);
}

/// Overwrites the six u16 indices at the end of [`Model::quad`]'s buffer.
fn set_quad_indices(m: &mut Model, i: &[u16; 6]) {
    let at = m.bin.len() - 12;
    m.bin[at..].copy_from_slice(&u16_bytes(i));
}

/// [`Model::quad`] after `edit`, written as glTF or GLB by the ending of `name`, fails to load
/// with an error naming each of `parts`.
fn quad_err(name: &str, parts: &[&str], edit: impl FnOnce(&mut Model)) {
    let mut m = Model::quad();
    edit(&mut m);
    let bytes = if name.ends_with(".glb") {
        m.glb()
    } else {
        m.gltf()
    };
    expect_err(&bytes, name, parts);
}

/// [`quad_err`] with one field of the quad's JSON set: `json[table][index][key] = value`.
fn quad_field_err(
    name: &str,
    parts: &[&str],
    (table, index, key): (&str, usize, &str),
    value: impl Into<gltf::json::Value>,
) {
    let value = value.into();
    quad_err(name, parts, |m| m.json[table][index][key] = value);
}

#[test]
fn valid_quad_loads_as_gltf_and_glb() {
    for (bytes, name) in [
        (Model::quad().gltf(), "q.gltf"),
        (Model::quad().glb(), "q.glb"),
    ] {
        let m = load_ok(&bytes, name);
        assert_eq!(m.mesh.vertices.len(), 4);
        assert_eq!(m.mesh.indices, vec![0, 1, 2, 0, 2, 3]);
        assert_eq!(m.mesh.bounds(), (Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
    }
}

#[test]
fn self_cycle_is_an_error_naming_the_node() {
    let mut m = Model::quad();
    m.json["nodes"][0]["children"] = v("[0]");
    expect_err(&m.gltf(), "cycle.gltf", &["node 0", "cycle"]);
    expect_err(&m.glb(), "cycle.glb", &["node 0", "cycle"]);
}

#[test]
fn longer_cycle_is_an_error_even_outside_any_scene() {
    let mut m = Model::quad();
    m.json["nodes"] = v(r#"[{"children":[1]},{"children":[2]},{"mesh":0,"children":[1]}]"#);
    expect_err(&m.gltf(), "c3.gltf", &["node 1", "cycle"]);
    m.json.as_object_mut().unwrap().remove("scenes");
    m.json.as_object_mut().unwrap().remove("scene");
    expect_err(&m.gltf(), "c3-noscene.gltf", &["cycle"]);
}

#[test]
fn very_deep_chain_is_an_error_not_a_stack_overflow() {
    let n = 100_000;
    let mut m = Model::quad();
    let nodes: Vec<String> = (0..n)
        .map(|i| {
            if i + 1 < n {
                format!(r#"{{"children":[{}]}}"#, i + 1)
            } else {
                r#"{"mesh":0}"#.to_string()
            }
        })
        .collect();
    m.json["nodes"] = v(&format!("[{}]", nodes.join(",")));
    let deep = MAX_NODE_DEPTH.to_string();
    expect_err(
        &m.glb(),
        "deep.glb",
        &[&format!("node {deep}"), &deep, "deep"],
    );
}

#[test]
fn chain_within_the_depth_limit_loads() {
    let n = MAX_NODE_DEPTH;
    let mut m = Model::quad();
    let nodes: Vec<String> = (0..n)
        .map(|i| match i + 1 < n {
            true => format!(r#"{{"children":[{}],"translation":[1,0,0]}}"#, i + 1),
            false => r#"{"mesh":0}"#.to_string(),
        })
        .collect();
    m.json["nodes"] = v(&format!("[{}]", nodes.join(",")));
    let model = load_ok(&m.gltf(), "chain.gltf");
    assert_eq!(model.mesh.bounds().0.x, (n - 1) as f32);
}

/// Node i has node i+1 as child twice: 2^60 paths to the mesh from 61 nodes.
#[test]
fn branching_graph_sixty_deep_is_an_error_not_a_hang() {
    let mut m = Model::quad();
    let nodes: Vec<String> = (0..=60)
        .map(|i| match i < 60 {
            true => format!(r#"{{"children":[{0},{0}]}}"#, i + 1),
            false => r#"{"mesh":0}"#.to_string(),
        })
        .collect();
    m.json["nodes"] = v(&format!("[{}]", nodes.join(",")));
    let (_, largest, _) = metered(|| {
        expect_err(
            &m.glb(),
            "dag.glb",
            &[&MAX_NODE_INSTANCES.to_string(), "node instances"],
        )
    });
    assert!(largest < 64 << 20, "largest allocation {largest}");
}

/// A node reached through two parents (instancing) is drawn once per path.
#[test]
fn instanced_node_is_drawn_at_each_place() {
    let mut m = Model::quad();
    m.json["nodes"] = v(r#"[{"children":[1,2]},
        {"children":[3],"translation":[10,0,0]},
        {"children":[3],"translation":[-10,0,0]},
        {"mesh":0}]"#);
    let model = load_ok(&m.gltf(), "inst.gltf");
    assert_eq!(model.mesh.vertices.len(), 8);
    assert_eq!(model.mesh.triangle_count(), 4);
    let (lo, hi) = model.mesh.bounds();
    assert_eq!((lo.x, hi.x), (-10.0, 11.0));
}

/// The issue's 692-byte GLB: a sparse POSITION accessor claiming 600 M vertices.
#[test]
fn sparse_accessor_claiming_600m_vertices_fails_without_allocating() {
    let mut m = Model::empty();
    let idx = m.view(&u32_bytes(&[5]));
    let val = m.view(&f32_bytes(&[1., 2., 3.]));
    let a = m.push(
        "accessors",
        v(&format!(
            r#"{{"componentType":5126,"count":600000000,"type":"VEC3",
            "min":[0,0,0],"max":[1,1,1],"sparse":{{"count":1,
            "indices":{{"bufferView":{idx},"componentType":5125}},"values":{{"bufferView":{val}}}}}}}"#
        )),
    );
    m.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = a.into();
    let glb = m.glb();
    assert!(glb.len() < 1024, "{}", glb.len());
    let (_, largest, total) = metered(|| {
        expect_err(
            &glb,
            "sparse.glb",
            &[
                "mesh 0 primitive 0",
                "POSITION accessor 0",
                "600000000",
                &MAX_GLTF_VERTICES.to_string(),
            ],
        )
    });
    assert!(largest < 1 << 20, "largest allocation {largest} bytes");
    assert!(total < 16 << 20, "allocated {total} bytes in all");
}

/// The budget is per file: instances of a mesh that fits count together.
#[test]
fn vertex_budget_counts_every_instance() {
    let mut m = Model::empty();
    let idx = m.view(&u32_bytes(&[0, 1, 2]));
    let val = m.view(&f32_bytes(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]));
    let count = 1_000_002; // a multiple of 3: a valid non-indexed triangle list
    let a = m.push(
        "accessors",
        v(&format!(
            r#"{{"componentType":5126,"count":{count},"type":"VEC3","min":[0,0,0],"max":[1,1,1],
            "sparse":{{"count":3,"indices":{{"bufferView":{idx},"componentType":5125}},
            "values":{{"bufferView":{val}}}}}}}"#
        )),
    );
    m.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = a.into();
    m.json["nodes"] = v(&format!(
        r#"[{{"children":[{}]}},{{"mesh":0}}]"#,
        ["1"; 20].join(",")
    ));
    let (_, largest, _) = metered(|| {
        expect_err(
            &m.glb(),
            "budget.glb",
            &[
                "POSITION accessor 0",
                "vertices before it",
                &MAX_GLTF_VERTICES.to_string(),
            ],
        )
    });
    assert!(largest < 16 << 20, "largest allocation {largest} bytes");
}

#[test]
fn index_budget_is_checked_before_reading() {
    let mut m = Model::quad();
    let idx = m.view(&u32_bytes(&[7]));
    let val = m.view(&u32_bytes(&[1]));
    let a = m.push(
        "accessors",
        v(&format!(
            r#"{{"componentType":5125,"count":60000000,"type":"SCALAR",
            "sparse":{{"count":1,"indices":{{"bufferView":{idx},"componentType":5125}},
            "values":{{"bufferView":{val}}}}}}}"#
        )),
    );
    m.json["meshes"][0]["primitives"][0]["indices"] = a.into();
    let (_, largest, _) = metered(|| {
        expect_err(
            &m.glb(),
            "idx-budget.glb",
            &[
                &format!("index accessor {a}"),
                "60000000",
                &MAX_GLTF_INDICES.to_string(),
            ],
        )
    });
    assert!(largest < 1 << 20, "largest allocation {largest} bytes");
}

#[test]
fn valid_sparse_accessor_still_loads() {
    let m = Model::quad_sparse(&u16_bytes(&[2]), U16, &[2., 2., 0.]);
    let model = load_ok(&m.glb(), "sparse-ok.glb");
    assert_eq!(model.mesh.vertices[2].position, [2.0, 2.0, 0.0]);
}

#[test]
fn bad_sparse_indices_are_errors() {
    for (indices, name) in [([2u32, 1], "order.glb"), ([1, 9], "range.glb")] {
        let m = Model::quad_sparse(&u32_bytes(&indices), U32, &[2., 2., 0., 3., 3., 0.]);
        expect_err(&m.glb(), name, &["POSITION accessor 0", "sparse index"]);
    }
    // Sparse values claimed beyond their view.
    quad_err(
        "values.glb",
        &["POSITION accessor 0", "run past the end"],
        |m| {
            *m = Model::quad_sparse(&u32_bytes(&[0, 1]), U32, &[2., 2., 0.]);
            m.json["accessors"][0]["sparse"]["count"] = 2.into();
        },
    );
}

#[test]
fn index_accessor_with_count_zero_is_an_error_not_unindexed() {
    quad_field_err(
        "zero.gltf",
        &["index accessor 3", "count 0"],
        ("accessors", 3, "count"),
        0,
    );
}

#[test]
fn index_count_not_a_multiple_of_three_is_an_error() {
    quad_field_err(
        "five.gltf",
        &["index accessor 3", "count 5", "multiple of 3"],
        ("accessors", 3, "count"),
        5,
    );
    quad_err(
        "noidx.gltf",
        &["POSITION accessor 0", "not indexed", "count 4"],
        |m| {
            let primitive = m.json["meshes"][0]["primitives"][0].as_object_mut();
            primitive.unwrap().remove("indices");
        },
    );
}

#[test]
fn index_past_the_vertex_count_is_an_error() {
    quad_err(
        "oob.glb",
        &["index accessor 3", "index 9", "vertex count 4"],
        |m| set_quad_indices(m, &[0, 1, 2, 0, 2, 9]),
    );
}

#[test]
fn index_accessor_past_its_buffer_is_an_error_not_unindexed() {
    quad_field_err(
        "short.glb",
        &["index accessor 3", "run past the end"],
        ("bufferViews", 3, "byteLength"),
        6,
    );
    quad_field_err(
        "view.glb",
        &["index accessor 3", "does not fit in buffer 0"],
        ("bufferViews", 3, "byteLength"),
        1000,
    );
    quad_field_err(
        "offset.glb",
        &["index accessor 3"],
        ("accessors", 3, "byteOffset"),
        v("18446744073709551000"),
    );
}

#[test]
fn accessor_of_the_wrong_type_is_an_error() {
    quad_field_err(
        "f32idx.glb",
        &["index accessor 3", "expected Scalar"],
        ("accessors", 3, "componentType"),
        F32,
    );
    quad_field_err(
        "vec2pos.glb",
        &["POSITION accessor 0", "expected Vec3"],
        ("accessors", 0, "type"),
        "VEC2",
    );
    // i8 UVs
    quad_field_err(
        "i8uv.glb",
        &["TEXCOORD_0 accessor 2"],
        ("accessors", 2, "componentType"),
        5120,
    );
}

#[test]
fn stride_shorter_than_an_element_is_an_error() {
    quad_field_err(
        "stride.glb",
        &["POSITION accessor 0", "byteStride 4"],
        ("bufferViews", 0, "byteStride"),
        4,
    );
}

#[test]
fn attribute_counts_must_match() {
    quad_field_err(
        "counts.glb",
        &["NORMAL accessor 1", "3 elements", "has 4"],
        ("accessors", 1, "count"),
        3,
    );
}

#[test]
fn missing_position_accessor_is_an_error_not_a_panic() {
    quad_err(
        "pos99.gltf",
        &["POSITION accessor 99 does not exist"],
        |m| {
            m.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 99.into();
        },
    );
}

#[test]
fn non_finite_positions_are_errors() {
    for (bad, name) in [(f32::NAN, "nan.glb"), (f32::INFINITY, "inf.glb")] {
        quad_err(
            name,
            &["POSITION accessor 0", "vertex 1", "not finite"],
            |m| {
                set_quad_positions(m, &[0., 0., 0., bad, 0., 0., 1., 1., 0., 0., 1., 0.]);
            },
        );
    }
    quad_err("allnan.glb", &["POSITION accessor 0", "vertex 0"], |m| {
        set_quad_positions(m, &[f32::NAN; 12]);
    });
}

#[test]
fn transform_overflowing_to_infinity_is_an_error() {
    quad_err("huge.glb", &["node 1", "not finite after"], |m| {
        m.json["nodes"] = v(r#"[{"children":[1],"scale":[1e30,1e30,1e30]},
            {"mesh":0,"scale":[1e30,1e30,1e30]}]"#);
    });
}

#[test]
fn non_finite_uvs_are_errors() {
    quad_err("uv.glb", &["TEXCOORD_0 accessor 2", "element 0"], |m| {
        let at = 96; // positions (48) + normals (48)
        m.bin[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    });
}

/// Normals derive from positions, so non-finite ones are recomputed (with a warning).
#[test]
fn non_finite_normals_are_recomputed() {
    let mut m = Model::quad();
    m.bin[48..52].copy_from_slice(&f32::NAN.to_le_bytes());
    let model = load_ok(&m.glb(), "normal.glb");
    for v in &model.mesh.vertices {
        assert_eq!(v.normal, [0.0, 0.0, 1.0]);
        assert!(v.tangent.iter().all(|c| c.is_finite()));
    }
}

#[test]
fn zero_extent_models_are_errors() {
    quad_err("point.glb", &["has zero extent"], |m| {
        set_quad_positions(m, &[0.5; 12]);
    });
    quad_err("scale0.glb", &["has zero extent"], |m| {
        m.json["nodes"][0]["scale"] = v("[0,0,0]");
    });
}

#[test]
fn zero_area_triangles_are_dropped() {
    let mut m = Model::quad();
    set_quad_indices(&mut m, &[0, 1, 2, 0, 0, 1]);
    let model = load_ok(&m.glb(), "degenerate.glb");
    assert_eq!(model.mesh.indices, vec![0, 1, 2]);
    // Collinear positions: the model has extent but nothing to draw.
    quad_err("line.glb", &["all 2 triangles have zero area"], |m| {
        set_quad_positions(m, &[0., 0., 0., 1., 0., 0., 2., 0., 0., 3., 0., 0.]);
    });
}

#[test]
fn undecodable_buffer_uri_is_an_error_not_a_panic() {
    let mut m = Model::quad();
    let len = m.bin.len();
    m.json["buffers"] = v(&format!(r#"[{{"byteLength":{len},"uri":"%FF%FE.bin"}}]"#));
    let json = gltf::json::serialize::to_vec(&m.json).unwrap();
    expect_err(&json, "uri.gltf", &["buffer 0", "percent-encoded"]);
}

#[test]
fn glb_header_shorter_than_the_header_is_an_error_not_a_panic() {
    let mut glb = Model::quad().glb();
    glb[8..12].copy_from_slice(&4u32.to_le_bytes());
    expect_err(&glb, "hdr.glb", &["12-byte header"]);
}

/// A PNG base colour texture embedded as a data URI loads from memory.
fn textured_quad(png_uri: &str) -> Model {
    let mut m = Model::quad();
    m.json["images"] = v(&format!(r#"[{{"uri":"{png_uri}"}}]"#));
    m.json["textures"] = v(r#"[{"source":0}]"#);
    m.json["materials"] = v(r#"[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}]"#);
    m.json["meshes"][0]["primitives"][0]["material"] = 0.into();
    m
}

fn png_bytes() -> Vec<u8> {
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([10, 20, 30, 255]));
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png).unwrap();
    png.into_inner()
}

#[test]
fn embedded_texture_loads_from_memory() {
    let uri = format!("data:image/png;base64,{}", base64_encode(&png_bytes()));
    let model = load_ok(&textured_quad(&uri).gltf(), "tex.gltf");
    let tex = model.base_color_texture.expect("texture");
    assert_eq!(tex.dimensions(), (2, 2));
    assert_eq!(tex.get_pixel(1, 1).0, [10, 20, 30, 255]);
}

#[test]
fn bad_images_are_errors_not_panics() {
    let m = textured_quad("hand.png");
    expect_err(&m.gltf(), "ext.gltf", &["image 0", "external"]);
    let mut m = textured_quad("x");
    let view = m.view(&png_bytes());
    m.json["bufferViews"][view]["byteLength"] = 100_000.into();
    m.json["images"] = v(&format!(
        r#"[{{"bufferView":{view},"mimeType":"image/png"}}]"#
    ));
    expect_err(&m.glb(), "imgview.glb", &["image 0", "does not fit"]);
    let m = textured_quad("data:image/png;base64,AAAA");
    expect_err(&m.gltf(), "notpng.gltf", &["image 0"]);
}

#[test]
fn load_gltf_refuses_what_is_not_a_regular_file() {
    let dir = std::env::temp_dir();
    let e = mesh::load_gltf(&dir)
        .err()
        .expect("a directory is not a glTF");
    let s = e.to_string();
    assert!(s.starts_with(&dir.display().to_string()), "{s}");
    assert!(s.contains("not a regular file") && !s.contains('\n'), "{s}");
}

/// `load_gltf` resolves external buffers beside the file, but only regular files.
#[test]
fn external_buffers_must_be_regular_files() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh_hardening_ext");
    std::fs::create_dir_all(&dir).unwrap();
    let m = Model::quad();
    std::fs::write(dir.join("quad data.bin"), &m.bin).unwrap();
    let mut json = m.json.clone();
    let len = m.bin.len();
    json["buffers"] = v(&format!(
        r#"[{{"byteLength":{len},"uri":"quad%20data.bin"}}]"#
    ));
    let ok = dir.join("ext.gltf");
    std::fs::write(&ok, gltf::json::serialize::to_vec(&json).unwrap()).unwrap();
    let model = mesh::load_gltf(&ok).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(model.mesh.vertices.len(), 4);

    json["buffers"] = v(&format!(
        r#"[{{"byteLength":{len},"uri":"file:///dev/zero"}}]"#
    ));
    let bad = dir.join("zero.gltf");
    std::fs::write(&bad, gltf::json::serialize::to_vec(&json).unwrap()).unwrap();
    let t0 = std::time::Instant::now();
    let e = mesh::load_gltf(&bad)
        .err()
        .expect("/dev/zero is no buffer")
        .to_string();
    assert!(t0.elapsed() < TIME_LIMIT);
    assert!(e.starts_with(&bad.display().to_string()), "{e}");
    assert!(
        e.contains("buffer 0") && e.contains("not a regular file"),
        "{e}"
    );
}
