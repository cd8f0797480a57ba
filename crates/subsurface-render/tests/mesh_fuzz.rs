//! Deterministic fuzz replay of the glTF loader: a few thousand byte- and JSON-level
//! mutations of the builtin hand and the seed corpus in `fuzz-corpus/gltf/`, each fed to
//! `load_gltf_slice`. No mutant may panic or take longer than [`TIME_LIMIT`]; a rejected
//! one must give a one-line error naming the file, an accepted one a mesh the renderer can
//! draw. Same seed, same mutants: a failure reproduces, and the failing input is written
//! under the target's tmp dir.
//!
//! `cargo test -p subsurface-render --test integration mesh_fuzz::regenerate_corpus -- --ignored`
//! rewrites the seed corpus from the builders in `mesh_util`.

use crate::common;
use crate::mesh_util;

use std::path::{Path, PathBuf};
use std::time::Instant;

use common::{Rng, fuzz_budget, named_in_order};
use gltf::json::Value;
use mesh_util::*;
use subsurface_render::mesh::{BUILTIN_HAND_GLB, load_gltf_slice};

/// Mutants per seed; the hand (94 kB, thousands of vertices) is slower to load than the
/// small seeds, so it gets fewer.
const MUTANTS_SMALL: usize = 1500;
const MUTANTS_HAND: usize = 400;

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz-corpus/gltf")
}

/// Numbers that sit on the loader's edges: zero, off-by-one, type limits, the budget and
/// beyond, fractions and overflowing floats.
const INTERESTING: &[&str] = &[
    "0",
    "1",
    "2",
    "3",
    "-1",
    "4",
    "12",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "4294967295",
    "4294967296",
    "600000000",
    "18446744073709551615",
    "0.5",
    "1e39",
    "-1e39",
    "5120",
    "5121",
    "5123",
    "5125",
    "5126",
];

/// Fields worth planting, by the top-level array whose elements they belong to:
/// node-graph edges, degenerate transforms, counts, offsets, strides, sparse storage.
const PLANTS: &[(&str, &[(&str, &str)])] = &[
    (
        "nodes",
        &[
            ("children", "[0]"),
            ("children", "[1,1,1]"),
            ("children", "[]"),
            ("mesh", "0"),
            ("skin", "0"),
            ("scale", "[0,0,0]"),
            ("scale", "[1e30,1e30,1e30]"),
            ("scale", "[-1,1,1]"),
            ("matrix", "[1e39,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]"),
            ("matrix", "[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0]"),
            ("translation", "[3e38,0,0]"),
            ("rotation", "[0,0,0,0]"),
        ],
    ),
    (
        "accessors",
        &[
            ("count", "0"),
            ("count", "65536"),
            ("count", "600000000"),
            ("byteOffset", "4294967295"),
            ("byteOffset", "4"),
            ("bufferView", "0"),
            ("componentType", "5121"),
            ("componentType", "5126"),
            ("type", r#""VEC4""#),
            ("type", r#""SCALAR""#),
            ("normalized", "true"),
            (
                "sparse",
                r#"{"count":1,"indices":{"bufferView":0,"componentType":5125},"values":{"bufferView":0}}"#,
            ),
            (
                "sparse",
                r#"{"count":3,"indices":{"bufferView":1,"componentType":5121},"values":{"bufferView":1}}"#,
            ),
        ],
    ),
    (
        "bufferViews",
        &[
            ("byteStride", "4"),
            ("byteStride", "252"),
            ("byteOffset", "1"),
            ("byteLength", "0"),
            ("byteLength", "4294967295"),
            ("buffer", "0"),
        ],
    ),
    (
        "skins",
        &[
            ("joints", "[0]"),
            ("joints", "[0,1,0]"),
            ("inverseBindMatrices", "0"),
        ],
    ),
    (
        "scenes",
        &[("nodes", "[0,0]"), ("nodes", "[]"), ("nodes", "[1]")],
    ),
    (
        "buffers",
        &[
            ("uri", r#""%FF""#),
            ("uri", r#""data:,""#),
            ("byteLength", "1"),
        ],
    ),
];

/// Attributes worth adding to a primitive, and primitive fields.
const SEMANTICS: &[&str] = &[
    "POSITION",
    "NORMAL",
    "TANGENT",
    "TEXCOORD_0",
    "JOINTS_0",
    "WEIGHTS_0",
];
const PRIMITIVE_FIELDS: &[(&str, &str)] = &[
    ("indices", "0"),
    ("indices", "3"),
    ("mode", "0"),
    ("mode", "5"),
    ("material", "0"),
];

/// JSON pointers of every value in `v` whose kind `want` accepts.
fn pointers(v: &Value, path: &mut String, want: fn(&Value) -> bool, out: &mut Vec<String>) {
    if want(v) {
        out.push(path.clone());
    }
    let len = path.len();
    match v {
        Value::Array(a) => {
            for (i, e) in a.iter().enumerate() {
                path.push_str(&format!("/{i}"));
                pointers(e, path, want, out);
                path.truncate(len);
            }
        }
        Value::Object(o) => {
            for (k, e) in o {
                path.push('/');
                path.push_str(&k.replace('~', "~0").replace('/', "~1"));
                pointers(e, path, want, out);
                path.truncate(len);
            }
        }
        _ => {}
    }
}

/// A random value of `root` that `want` accepts.
fn random_value<'a>(
    rng: &mut Rng,
    root: &'a mut Value,
    want: fn(&Value) -> bool,
) -> Option<&'a mut Value> {
    let mut all = Vec::new();
    pointers(root, &mut String::new(), want, &mut all);
    if all.is_empty() {
        return None;
    }
    let p = all.swap_remove(rng.below(all.len()));
    root.pointer_mut(&p)
}

/// A random element of the top-level array `key`, if it has any.
fn random_element<'a>(rng: &mut Rng, root: &'a mut Value, key: &str) -> Option<&'a mut Value> {
    let a = root.get_mut(key)?.as_array_mut()?;
    let n = a.len();
    (n > 0).then(|| &mut a[rng.below(n)])
}

fn plant(rng: &mut Rng, root: &mut Value) {
    let small = rng.below(8).to_string();
    if rng.below(4) == 0 {
        let Some(mesh) = random_element(rng, root, "meshes") else {
            return;
        };
        let Some(prims) = mesh.get_mut("primitives").and_then(Value::as_array_mut) else {
            return;
        };
        if prims.is_empty() {
            return;
        }
        let n = prims.len();
        // Earlier mutations may have made the primitive or its attributes a non-object;
        // serde_json's IndexMut panics on those, so plant only into objects.
        let Some(prim) = prims[rng.below(n)].as_object_mut() else {
            return;
        };
        if rng.below(2) == 0 {
            if let Some(a) = prim.get_mut("attributes").and_then(Value::as_object_mut) {
                a.insert(rng.pick(SEMANTICS).to_string(), v(&small));
            }
        } else {
            let (k, val) = rng.pick(PRIMITIVE_FIELDS);
            prim.insert(k.to_string(), v(val));
        }
        return;
    }
    let (key, fields) = rng.pick(PLANTS);
    if let Some(Value::Object(o)) = random_element(rng, root, key) {
        let (k, val) = rng.pick(fields);
        o.insert(k.to_string(), v(val));
    }
}

fn mutate_json(rng: &mut Rng, root: &mut Value) {
    for _ in 0..1 + rng.below(3) {
        match rng.below(10) {
            0..=3 => {
                let choice = rng.below(3);
                let new = match choice {
                    0 => rng.pick(INTERESTING).to_string(),
                    1 => rng.below(8).to_string(),
                    _ => String::new(),
                };
                if let Some(x) = random_value(rng, root, Value::is_number) {
                    *x = match (new.as_str(), x.as_i64()) {
                        ("", Some(i)) => (i + if rng.below(2) == 0 { 1 } else { -1 }).into(),
                        ("", None) => v("0"),
                        (s, _) => v(s),
                    };
                }
            }
            4..=6 => plant(rng, root),
            7 => {
                if let Some(c) = random_value(rng, root, |v| v.is_array() || v.is_object()) {
                    match c {
                        Value::Array(a) if !a.is_empty() => {
                            let i = rng.below(a.len());
                            a.remove(i);
                        }
                        Value::Object(o) if !o.is_empty() => {
                            let k = o.keys().nth(rng.below(o.len())).unwrap().clone();
                            o.remove(&k);
                        }
                        _ => {}
                    }
                }
            }
            8 => {
                if let Some(Value::Array(a)) = random_value(rng, root, Value::is_array)
                    && !a.is_empty()
                {
                    let e = a[rng.below(a.len())].clone();
                    a.push(e);
                }
            }
            _ => {
                // Anything at all, type errors included.
                if let Some(x) = random_value(rng, root, |_| true) {
                    *x = v(rng.pick(&["null", "[]", "{}", "\"\"", "0", "-1", "[0]"]));
                }
            }
        }
    }
}

fn mutate_bytes(rng: &mut Rng, data: &[u8], hot: usize) -> Vec<u8> {
    let mut d = data.to_vec();
    for _ in 0..1 + rng.below(4) {
        if d.is_empty() {
            break;
        }
        // Mostly hit the structural head (GLB header and JSON), sometimes anywhere.
        let span = if rng.below(4) == 0 {
            d.len()
        } else {
            hot.min(d.len())
        };
        let at = rng.below(span);
        match rng.below(6) {
            0 => d[at] ^= 1 << rng.below(8),
            1 => d[at] = rng.pick(&[0, 0xff, 0x7f, 0x80, b'0', b'9', b'"', b'[', b'{']),
            2 => {
                let at = at & !3;
                let x: u32 = rng.pick(&[0, 1, 3, 11, 0xffff_ffff, 0x7fff_ffff, 0x2400_0000]);
                let end = (at + 4).min(d.len());
                d[at..end].copy_from_slice(&x.to_le_bytes()[..end - at]);
            }
            3 => d.truncate(at),
            4 => {
                let end = (at + 1 + rng.below(64)).min(d.len());
                d.drain(at..end);
            }
            _ => {
                let end = (at + 1 + rng.below(64)).min(d.len());
                let chunk = d[at..end].to_vec();
                d.splice(at..at, chunk);
            }
        }
    }
    d
}

/// JSON and BIN chunks of a well-formed GLB.
fn split_glb(glb: &[u8]) -> Option<(&[u8], &[u8])> {
    let len = u32::from_le_bytes(glb.get(12..16)?.try_into().ok()?) as usize;
    let json = glb.get(20..20 + len)?;
    let bin = glb.get(20 + len + 8..).unwrap_or(&[]);
    Some((json, bin))
}

/// One mutant of `seed`: a third byte-level, the rest JSON-level.
fn mutant(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let glb_parts = split_glb(seed).filter(|_| seed.starts_with(b"glTF"));
    let json_bytes = glb_parts.map_or(seed, |(j, _)| j);
    if rng.below(3) == 0 {
        let hot = if glb_parts.is_some() {
            20 + json_bytes.len()
        } else {
            seed.len()
        };
        return mutate_bytes(rng, seed, hot);
    }
    let mut root: Value = match gltf::json::deserialize::from_slice(json_bytes) {
        Ok(v) => v,
        Err(_) => return mutate_bytes(rng, seed, seed.len()),
    };
    mutate_json(rng, &mut root);
    let json = gltf::json::serialize::to_vec(&root).unwrap();
    match glb_parts {
        Some((_, bin)) => glb(&json, bin),
        None => json,
    }
}

/// What an accepted mutant must satisfy for the renderer.
fn check_model(m: &subsurface_render::mesh::GltfModel) -> Result<(), String> {
    let mesh = &m.mesh;
    if mesh.indices.is_empty() || !mesh.indices.len().is_multiple_of(3) {
        return Err(format!("{} indices", mesh.indices.len()));
    }
    if let Some(i) = mesh
        .indices
        .iter()
        .find(|&&i| i as usize >= mesh.vertices.len())
    {
        return Err(format!("index {i} >= {} vertices", mesh.vertices.len()));
    }
    let finite = |x: &[f32]| x.iter().all(|c| c.is_finite());
    if let Some(v) = mesh.vertices.iter().find(|v| {
        !finite(&v.position) || !finite(&v.normal) || !finite(&v.uv) || !finite(&v.tangent)
    }) {
        return Err(format!("non-finite vertex {v:?}"));
    }
    Ok(())
}

fn seeds() -> Vec<(String, Vec<u8>)> {
    let mut seeds = vec![("builtin-hand.glb".to_string(), BUILTIN_HAND_GLB.to_vec())];
    let files: Vec<PathBuf> = std::fs::read_dir(corpus_dir())
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    seeds.extend(named_in_order(files, |p| std::fs::read(p)));
    seeds
}

#[test]
fn seeds_load() {
    let seeds = seeds();
    assert!(seeds.len() >= 6, "corpus missing? {} seeds", seeds.len());
    for (name, bytes) in &seeds {
        let m = load_gltf_slice(bytes, name).unwrap_or_else(|e| panic!("{e}"));
        check_model(&m).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn mutants_never_panic_hang_or_yield_broken_meshes() {
    let t_all = Instant::now();
    let mut failures = Vec::new();
    let (mut accepted, mut rejected) = (0, 0);
    let out_dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let budget = fuzz_budget();
    let seeds = seeds();
    let rounds = if budget.is_some() { usize::MAX } else { 1 };
    'run: for round in 0..rounds {
        for (s, (seed_name, seed)) in seeds.iter().enumerate() {
            let base = budget.map_or(0x9e37_79b9_7f4a_7c15, |(_, b)| {
                b ^ (round as u64).wrapping_mul(0x9e37_79b9)
            });
            let mut rng = Rng(base ^ (s as u64 + 1).wrapping_mul(0x1234_5678_9abc));
            let n = if s == 0 { MUTANTS_HAND } else { MUTANTS_SMALL };
            for i in 0..n {
                if budget.is_some_and(|(d, _)| t_all.elapsed() > d) {
                    break 'run;
                }
                let bytes = mutant(&mut rng, seed);
                let name = format!("{seed_name}#{i}");
                let t0 = Instant::now();
                let r = std::panic::catch_unwind(|| load_gltf_slice(&bytes, &name));
                let dt = t0.elapsed();
                let problem = match &r {
                    Err(_) => Some("panicked".to_string()),
                    Ok(_) if dt > TIME_LIMIT => Some(format!("took {dt:?}")),
                    Ok(Err(e)) => {
                        rejected += 1;
                        let e = e.to_string();
                        let ok = e.starts_with(&format!("{name}: ")) && !e.contains('\n');
                        (!ok).then(|| format!("bad message {e:?}"))
                    }
                    Ok(Ok(m)) => {
                        accepted += 1;
                        check_model(m).err()
                    }
                };
                if let Some(p) = problem {
                    let file = out_dir.join(format!("mesh_fuzz_{seed_name}_{i}.bin"));
                    let _ = std::fs::write(&file, &bytes);
                    failures.push(format!("{name}: {p} (input saved to {})", file.display()));
                }
            }
        }
    }
    eprintln!(
        "{accepted} mutants loaded, {rejected} rejected ({} executions), in {:?}",
        accepted + rejected,
        t_all.elapsed()
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
    // Mutants that all fail at the first byte would test nothing.
    assert!(
        accepted > 100 && rejected > 1000,
        "{accepted} accepted, {rejected} rejected"
    );
}

/// Writes the seed corpus. Run with `--ignored` after changing the builders.
#[test]
#[ignore]
fn regenerate_corpus() {
    let dir = corpus_dir();
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, bytes: Vec<u8>| std::fs::write(dir.join(name), bytes).unwrap();
    let quad = Model::quad();
    write("quad.gltf", quad.gltf());
    write("quad.glb", quad.glb());

    write(
        "sparse.glb",
        Model::quad_sparse(&u16_bytes(&[2]), U16, &[2., 2., 0.]).glb(),
    );

    let mut m = Model::quad();
    m.json["nodes"] = v(r#"[{"children":[1,2]},
        {"children":[3],"translation":[2,0,0]},
        {"children":[3],"rotation":[0,0,0.7071068,0.7071068]},
        {"mesh":0,"scale":[1,1,-1]}]"#);
    write("instanced.gltf", m.gltf());

    // Skinned: the joint's translation moves the bind pose.
    let mut m = Model::quad();
    m.attribute("JOINTS_0", &[0u8; 16], U8, 4, "VEC4");
    m.attribute(
        "WEIGHTS_0",
        &f32_bytes(&[1., 0., 0., 0.].repeat(4)),
        F32,
        4,
        "VEC4",
    );
    let t = [
        1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
    ];
    let ibm = m.accessor(&f32_bytes(&t), F32, 1, "MAT4");
    m.json["skins"] = v(&format!(
        r#"[{{"joints":[1],"inverseBindMatrices":{ibm}}}]"#
    ));
    m.json["nodes"] = v(r#"[{"mesh":0,"skin":0},{"translation":[0,0,1]}]"#);
    m.json["scenes"] = v(r#"[{"nodes":[0,1]}]"#);
    write("skinned.glb", m.glb());

    // Tangents given, u8 normalised UVs, u32 indices.
    let mut m = Model::empty();
    let p = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
    m.attribute("POSITION", &f32_bytes(&p), F32, 4, "VEC3");
    m.attribute(
        "TANGENT",
        &f32_bytes(&[1., 0., 0., 1.].repeat(4)),
        F32,
        4,
        "VEC4",
    );
    let uv = m.attribute(
        "TEXCOORD_0",
        &[0, 0, 255, 0, 255, 255, 0, 255],
        U8,
        4,
        "VEC2",
    );
    m.json["accessors"][uv]["normalized"] = true.into();
    let i = m.accessor(&u32_bytes(&[0, 1, 2, 0, 2, 3]), U32, 6, "SCALAR");
    m.json["meshes"][0]["primitives"][0]["indices"] = i.into();
    write("tangents-u8uv.gltf", m.gltf());
}
