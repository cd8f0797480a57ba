//! glTF/GLB loading: every triangle primitive of the default scene, node transforms (or
//! the skin's bind pose) baked in, plus the material of the largest primitive.
//!
//! Files are untrusted. Loading runs in two passes: the first checks the node graph and
//! every accessor it will read (types, byte ranges, counts against the
//! [`MAX_GLTF_VERTICES`](super::MAX_GLTF_VERTICES)/[`MAX_GLTF_INDICES`](super::MAX_GLTF_INDICES) budget) without allocating geometry; only
//! then does the second read, with the totals reserved up front.

use std::path::Path;

use glam::Mat4;

use super::Mesh;
use super::gltf_check::{self as check, Instance, MAX_BUFFER_BYTES};
use super::gltf_read::{plan, read_part};
use crate::scene::error::SceneError;

/// The geometry and material of a glTF/GLB file.
#[derive(Clone)]
pub struct GltfModel {
    /// All primitives of all mesh nodes of the default scene, node transforms
    /// (or, for skinned meshes, the bind pose) baked in.
    pub mesh: Mesh,
    /// Base colour factor of the material of the primitive with the most triangles.
    pub base_color_factor: [f32; 4],
    /// Base colour texture of that material (sRGB-encoded), if any.
    pub base_color_texture: Option<image::RgbaImage>,
    /// Tangent-space normal map of that material (linear), if any.
    pub normal_texture: Option<image::RgbaImage>,
    /// Metallic-roughness `roughnessFactor` of that material.
    pub roughness: f32,
}

/// Bytes of the vendored WebXR generic right hand (MIT), used by `builtin:hand`.
pub const BUILTIN_HAND_GLB: &[u8] =
    include_bytes!("../../../../assets/webxr-generic-hand/right.glb");

/// Longest message kept from a dependency's error: the crate's validator lists every
/// problem, which for a generated file can be megabytes.
const MAX_MESSAGE_CHARS: usize = 400;

/// Flattens a message to one line (a local copy of the scene module's helper, so that
/// mesh does not depend on scene beyond its error type) and caps its length.
fn one_line(s: &str) -> String {
    let s = s
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ");
    match s.char_indices().nth(MAX_MESSAGE_CHARS) {
        Some((cut, _)) => format!("{}...", &s[..cut]),
        None => s,
    }
}

fn gltf_err(name: &str, e: impl std::fmt::Display) -> SceneError {
    SceneError::Gltf {
        file: name.to_string(),
        msg: one_line(&e.to_string()),
    }
}

/// Loads a `.glb` or `.gltf` file (external buffers and images are resolved
/// relative to its directory). See [`load_gltf_slice`] for what is rejected.
pub fn load_gltf(path: &Path) -> Result<GltfModel, SceneError> {
    let name = path.display().to_string();
    let io_err = |msg: String| SceneError::Io {
        file: name.clone(),
        msg: one_line(&msg),
    };
    // A FIFO or device would block or never end; a huge file cannot be a mesh we accept.
    let bytes = crate::input::read_regular(path, MAX_BUFFER_BYTES).map_err(io_err)?;
    load_gltf_impl(&bytes, &name, path.parent())
}

/// Loads a glTF from memory (GLB, or glTF JSON with only embedded data URIs).
/// `name_for_errors` names the file in error messages.
///
/// Every malformed file gives a one-line [`SceneError::Gltf`] naming the file and the
/// node, mesh, primitive or accessor at fault; none panics, recurses without bound or
/// allocates more than the budget. Rejected:
/// - node cycles, hierarchies deeper than [`MAX_NODE_DEPTH`](super::MAX_NODE_DEPTH), or
///   expanding to more than [`MAX_NODE_INSTANCES`](super::MAX_NODE_INSTANCES) instances;
/// - accessors of the wrong type, with count 0, or reaching past their buffer (sparse
///   parts included);
/// - more than [`MAX_GLTF_VERTICES`](super::MAX_GLTF_VERTICES) vertices or
///   [`MAX_GLTF_INDICES`](super::MAX_GLTF_INDICES) indices in total, instances included;
/// - index counts that are not a multiple of 3, indices past the vertex count;
/// - non-finite positions or texture coordinates (before or after node transforms);
/// - models of zero extent (all vertices in one point, e.g. a zero node scale).
///
/// Tolerated, with a `log::warn`: non-triangle primitives (skipped), non-finite normals or
/// tangents (recomputed: they derive from positions and UVs, and some exporters write NaN
/// normals for degenerate faces), and zero-area triangles (dropped: they cover no pixels,
/// and their undefined normals would poison smooth normals and MikkTSpace).
pub fn load_gltf_slice(bytes: &[u8], name_for_errors: &str) -> Result<GltfModel, SceneError> {
    load_gltf_impl(bytes, name_for_errors, None)
}

fn convert_image(data: &gltf::image::Data) -> Option<image::RgbaImage> {
    use gltf::image::Format as F;
    let n = (data.width as usize) * (data.height as usize);
    let px = &data.pixels;
    let (channels, bytes_per) = match data.format {
        F::R8 => (1, 1),
        F::R8G8 => (2, 1),
        F::R8G8B8 => (3, 1),
        F::R8G8B8A8 => (4, 1),
        F::R16 => (1, 2),
        F::R16G16 => (2, 2),
        F::R16G16B16 => (3, 2),
        F::R16G16B16A16 => (4, 2),
        F::R32G32B32FLOAT | F::R32G32B32A32FLOAT => return None,
    };
    if px.len() < n * channels * bytes_per {
        return None;
    }
    let mut out = Vec::with_capacity(n * 4);
    for i in 0..n {
        // 16-bit channels: take the most significant byte (little endian).
        let c = |k: usize| px[(i * channels + k) * bytes_per + bytes_per - 1];
        let rgba = match channels {
            1 => [c(0), c(0), c(0), 255],
            2 => [c(0), c(0), c(0), c(1)],
            3 => [c(0), c(1), c(2), 255],
            _ => [c(0), c(1), c(2), c(3)],
        };
        out.extend_from_slice(&rgba);
    }
    image::RgbaImage::from_raw(data.width, data.height, out)
}

/// Node instances of the default scene (or the first); when that has no mesh, of every
/// root node, as earlier versions did for files whose scene list is empty or wrong.
fn scene_instances(doc: &gltf::Document) -> Result<Vec<Instance>, String> {
    let nodes = &doc.as_json().nodes;
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let roots: Vec<usize> = scene
        .map(|s| s.nodes().map(|n| n.index()).collect())
        .unwrap_or_default();
    let instances = check::expand_instances(doc, &roots)?;
    if instances.iter().any(|i| nodes[i.node].mesh.is_some()) {
        return Ok(instances);
    }
    let mut is_child = vec![false; nodes.len()];
    for n in nodes {
        for c in n.children.iter().flatten() {
            is_child[c.value()] = true;
        }
    }
    let roots: Vec<usize> = (0..nodes.len()).filter(|&i| !is_child[i]).collect();
    check::expand_instances(doc, &roots)
}

fn load_gltf_impl(bytes: &[u8], name: &str, base: Option<&Path>) -> Result<GltfModel, SceneError> {
    let err = |msg: String| gltf_err(name, msg);
    check::check_glb_header(bytes).map_err(err)?;
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| gltf_err(name, e))?;
    check::check_before_validation(document.as_json()).map_err(err)?;
    let document =
        gltf::Document::from_json(document.into_json()).map_err(|e| gltf_err(name, e))?;
    for b in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            check::check_uri(uri, base, &format!("buffer {}", b.index())).map_err(err)?;
        }
    }
    let buffers = gltf::import_buffers(&document, base, blob).map_err(|e| gltf_err(name, e))?;
    check::check_node_cycles(&document).map_err(err)?;
    let instances = scene_instances(&document).map_err(err)?;
    // Warnings are printed only when the file loads: a file that fails printed a WARN line
    // before its one `error:` line (a glTF of points only).
    let mut warnings = Vec::new();
    let (parts, total_v, total_i) =
        plan(&document, &buffers, &instances, name, &mut warnings).map_err(err)?;

    // World transform of each node's first instance, for skin joints.
    let mut first_world: Vec<Option<Mat4>> = vec![None; document.as_json().nodes.len()];
    for i in instances.iter().rev() {
        first_world[i.node] = Some(i.world);
    }
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());

    let mut mesh = Mesh {
        vertices: Vec::with_capacity(total_v),
        indices: Vec::with_capacity(total_i),
        missing_uvs: None,
    };
    let mut best_material: Option<(usize, gltf::Material)> = None;
    let mut dropped = 0;
    for part in &parts {
        // Skinned meshes: glTF ignores the skinned node's own transform and
        // poses vertices by `jointWorld * inverseBindMatrix`. With the default
        // node transforms (the bind pose for the WebXR hand), each vertex is
        // `sum_j w_j * (jointWorld_j * IBM_j) * v`. For right.glb this
        // product is the identity up to float noise (the raw positions are
        // already in bind pose); we still apply it so that files whose skeleton
        // root carries a transform are placed correctly.
        let skin_mats: Option<Vec<Mat4>> = part.node.skin().map(|skin| {
            let joints = skin.joints().count();
            let ibms: Vec<Mat4> = skin
                .reader(get)
                .read_inverse_bind_matrices()
                .map(|it| {
                    it.take(joints)
                        .map(|m| Mat4::from_cols_array_2d(&m))
                        .collect()
                })
                .unwrap_or_default();
            skin.joints()
                .enumerate()
                .map(|(j, joint)| {
                    let jw = first_world[joint.index()].unwrap_or_else(|| {
                        // Joint outside the visited scene: use its local transform.
                        Mat4::from_cols_array_2d(&joint.transform().matrix())
                    });
                    jw * ibms.get(j).copied().unwrap_or(Mat4::IDENTITY)
                })
                .collect()
        });
        let (mut part_mesh, has_tangents, d) =
            read_part(part, &buffers, skin_mats.as_deref(), name, &mut warnings).map_err(err)?;
        // Per primitive, as glTF defines tangents: over the whole model, mikktspace welds the
        // identical corners of every instance of a primitive into one vertex group, and 99,000
        // instances of one quad kept it busy for minutes.
        if !has_tangents {
            part_mesh.generate_tangents();
        }
        dropped += d;
        let tris = part_mesh.triangle_count();
        if best_material.as_ref().is_none_or(|(t, _)| tris > *t) {
            best_material = Some((tris, part.prim.material()));
        }
        mesh.append(&part_mesh);
    }
    if mesh.vertices.is_empty() {
        // Say why (e.g. only points or lines), in the error rather than a WARN line before it.
        let why = warnings
            .iter()
            .map(|w| w.strip_prefix(&format!("{name}: ")).unwrap_or(w))
            .collect::<Vec<_>>()
            .join("; ");
        return Err(err(if why.is_empty() {
            "no triangle mesh in the default scene".into()
        } else {
            format!("no triangle mesh in the default scene ({why})")
        }));
    }
    let (lo, hi) = mesh.bounds();
    if (hi - lo).max_element() <= 0.0 {
        return Err(err(format!(
            "the model has zero extent: all {} vertices are at {lo} after node transforms",
            mesh.vertices.len()
        )));
    }
    // Corners of +-3e38 are finite, but the extent between them is not: such a model
    // rendered nothing, with exit 0.
    if !(hi - lo).is_finite() {
        return Err(err(format!(
            "the model's extent overflows 32-bit floats: its vertices span {} to {} after \
             node transforms",
            crate::scene::sci(lo),
            crate::scene::sci(hi)
        )));
    }
    if mesh.indices.is_empty() {
        return Err(err(format!("all {dropped} triangles have zero area")));
    }
    if dropped > 0 {
        warnings.push(format!("{name}: dropped {dropped} zero-area triangle(s)"));
    }

    let mut model = GltfModel {
        mesh,
        base_color_factor: [1.0; 4],
        base_color_texture: None,
        normal_texture: None,
        roughness: 1.0,
    };
    if let Some((_, mat)) = best_material {
        let pbr = mat.pbr_metallic_roughness();
        model.base_color_factor = pbr.base_color_factor();
        model.roughness = pbr.roughness_factor();
        let bc = pbr
            .base_color_texture()
            .map(|t| t.texture().source().index());
        let nt = mat.normal_texture().map(|t| t.texture().source().index());
        model.base_color_texture = load_image(&document, bc, &buffers, base, name)?;
        model.normal_texture = load_image(&document, nt, &buffers, base, name)?;
    }
    for w in warnings {
        log::warn!("{w}");
    }
    Ok(model)
}

/// Decodes image `index` (only the images the material uses: decoding is the slow,
/// memory-hungry part, and the image crate's default limits bound each one).
fn load_image(
    doc: &gltf::Document,
    index: Option<usize>,
    buffers: &[gltf::buffer::Data],
    base: Option<&Path>,
    name: &str,
) -> Result<Option<image::RgbaImage>, SceneError> {
    let Some(i) = index else {
        return Ok(None);
    };
    let err = |e: String| gltf_err(name, format!("image {i}: {e}"));
    let img = doc
        .images()
        .nth(i)
        .ok_or_else(|| err("does not exist".into()))?;
    let source = img.source();
    match &source {
        gltf::image::Source::View { view, .. } => {
            check::view_bytes(view, buffers).map_err(err)?;
        }
        gltf::image::Source::Uri { uri, .. } => {
            check::check_uri(uri, base, &format!("image {i}")).map_err(|e| gltf_err(name, e))?;
        }
    }
    // The crate refuses every URI without a base directory, data URIs included, although
    // those never touch the file system; check_uri has already refused the others.
    let data = gltf::image::Data::from_source(source, base.or(Some(Path::new(""))), buffers)
        .map_err(|e| err(e.to_string()))?;
    convert_image(&data)
        .map(Some)
        .ok_or_else(|| err(format!("unsupported format {:?}", data.format)))
}

// The integration tests' encoder, so that both kinds of test share one copy.
#[cfg(test)]
#[path = "../../tests/mesh_util/base64.rs"]
mod base64;

#[cfg(test)]
mod tests {
    use super::super::test_util::check_mesh;
    use super::base64::base64_encode;
    use super::*;

    #[test]
    fn builtin_hand_loads_in_bind_pose() {
        let model = load_gltf_slice(BUILTIN_HAND_GLB, "right.glb").unwrap();
        let m = &model.mesh;
        check_mesh(m);
        let (lo, hi) = m.bounds();
        let size = hi - lo;
        eprintln!("hand bounds {lo} .. {hi} size {size}");
        // A real hand, in metres.
        assert!(
            size.max_element() > 0.1 && size.max_element() < 0.3,
            "{size}"
        );
        assert!(size.min_element() > 0.01, "{size}");
        assert_eq!(model.base_color_factor, [0.5, 0.5, 0.5, 1.0]);
        assert!(model.base_color_texture.is_none());
        // Bind pose equals the raw positions for this file (see load_gltf_impl).
        let doc = gltf::Gltf::from_slice(BUILTIN_HAND_GLB).unwrap();
        let acc = doc.accessors().next().unwrap();
        let (amin, amax) = (acc.min().unwrap(), acc.max().unwrap());
        let f = |v: &gltf::json::Value, i| v[i].as_f64().unwrap() as f32;
        for i in 0..3 {
            assert!(
                (lo[i] - f(&amin, i)).abs() < 1e-3,
                "axis {i}: {lo} vs {amin}"
            );
            assert!(
                (hi[i] - f(&amax, i)).abs() < 1e-3,
                "axis {i}: {hi} vs {amax}"
            );
        }
    }

    #[test]
    fn head_loads_fast_with_generated_tangents() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/assets/LeePerrySmith/LeePerrySmith.glb");
        if !path.exists() {
            eprintln!("skipping: {} not found", path.display());
            return;
        }
        let t0 = std::time::Instant::now();
        let model = load_gltf(&path).unwrap();
        let dt = t0.elapsed();
        eprintln!(
            "head: {} vertices, {} triangles, bounds {:?}, loaded in {dt:?}",
            model.mesh.vertices.len(),
            model.mesh.triangle_count(),
            model.mesh.bounds()
        );
        check_mesh(&model.mesh);
        assert!(dt.as_secs_f32() < 2.0, "too slow: {dt:?}");
    }

    #[test]
    fn gltf_errors_are_one_line_and_name_the_file() {
        let e = load_gltf_slice(b"not a gltf at all", "bad.glb")
            .err()
            .unwrap();
        let s = e.to_string();
        assert!(s.starts_with("bad.glb: "), "{s}");
        assert!(!s.contains('\n'));
        let e = load_gltf(Path::new("/nonexistent/x.glb")).err().unwrap();
        let s = e.to_string();
        assert!(s.starts_with("/nonexistent/x.glb: "), "{s}");
        assert!(!s.contains('\n'));
        // Truncated GLB.
        let e = load_gltf_slice(&BUILTIN_HAND_GLB[..BUILTIN_HAND_GLB.len() / 2], "cut.glb")
            .err()
            .unwrap();
        assert!(e.to_string().starts_with("cut.glb: "), "{e}");
    }

    #[test]
    fn long_dependency_messages_are_capped() {
        let s = one_line(&"x\n".repeat(10_000));
        assert!(!s.contains('\n'));
        assert!(s.chars().count() <= MAX_MESSAGE_CHARS + 3, "{}", s.len());
        assert_eq!(one_line("a\n  b  \n\nc"), "a; b; c");
    }

    /// A minimal non-indexed glTF (embedded base64 buffer) with a node
    /// transform: one triangle, translated by (1,2,3) and scaled by 2.
    #[test]
    fn non_indexed_gltf_with_node_transform() {
        let mut bin = Vec::new();
        for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in p {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        let b64 = base64_encode(&bin);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[1,2,3],"scale":[2,2,2]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
                "min":[0,0,0],"max":[1,1,0]}}]}}"#
        );
        let model = load_gltf_slice(json.as_bytes(), "tri.gltf").unwrap();
        let m = &model.mesh;
        assert_eq!(m.indices, vec![0, 1, 2]);
        assert_eq!(m.vertices[1].position, [3.0, 2.0, 3.0]);
        assert_eq!(m.vertices[2].position, [1.0, 4.0, 3.0]);
        assert_eq!(m.vertices[0].normal, [0.0, 0.0, 1.0]);
        assert_eq!(model.base_color_factor, [1.0; 4]);
    }
}
