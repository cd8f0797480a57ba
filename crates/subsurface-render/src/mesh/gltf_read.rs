//! Reading the primitives of a glTF scene in two passes: [`plan`] checks every accessor
//! that [`read_part`] will read and sums the vertex and index budget, allocating no
//! geometry; only then are the parts read, so a file claiming more than the budget fails
//! before any large allocation.

use std::collections::{HashMap, HashSet};

use glam::{Mat4, Vec3};
use gltf::accessor::{DataType as T, Dimensions as D};
use gltf::mesh::Semantic;

use super::gltf_check::{
    self as check, Instance, MAX_GLTF_INDICES, MAX_GLTF_VERTICES, MAX_PRIMITIVE_INSTANCES,
};
use super::{Mesh, Vertex};

/// One primitive of one node instance, checked and counted but not yet read.
pub(super) struct Part<'a> {
    pub instance: Instance,
    pub node: gltf::Node<'a>,
    pub prim: gltf::Primitive<'a>,
    /// "mesh M primitive P", for messages.
    what: String,
    vertices: usize,
    indices: usize,
}

/// First pass: checks every accessor the second pass will read and sums the budget.
pub(super) fn plan<'a>(
    doc: &'a gltf::Document,
    buffers: &[gltf::buffer::Data],
    instances: &[Instance],
    name: &str,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Part<'a>>, usize, usize), String> {
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut parts = Vec::new();
    let (mut total_v, mut total_i) = (0usize, 0usize);
    let mut non_triangle = 0usize;
    let mut skinned_done = HashSet::new();
    // Instanced meshes share accessors; checking each once keeps this linear in file size.
    let mut checked: HashMap<(usize, &'static str), usize> = HashMap::new();
    let mut check_once = |acc: &gltf::Accessor, label: &'static str, what: &str| {
        let (dims, types): (D, &[T]) = match label {
            "POSITION" | "NORMAL" => (D::Vec3, &[T::F32]),
            "TANGENT" => (D::Vec4, &[T::F32]),
            "TEXCOORD_0" => (D::Vec2, &[T::F32, T::U8, T::U16]),
            "JOINTS_0" => (D::Vec4, &[T::U8, T::U16]),
            "WEIGHTS_0" => (D::Vec4, &[T::F32, T::U8, T::U16]),
            "inverseBindMatrices" => (D::Mat4, &[T::F32]),
            _ => (D::Scalar, &[T::U8, T::U16, T::U32]),
        };
        if let Some(&count) = checked.get(&(acc.index(), label)) {
            return Ok(count);
        }
        let what = format!("{what}: {label}");
        let count = check::check_accessor(acc, buffers, dims, types, &what)?;
        checked.insert((acc.index(), label), count);
        Ok::<usize, String>(count)
    };
    for inst in instances {
        let node = &nodes[inst.node];
        let Some(gmesh) = node.mesh() else {
            continue;
        };
        if let Some(skin) = node.skin() {
            // glTF ignores a skinned node's own transform, so its instances coincide.
            if !skinned_done.insert(node.index()) {
                continue;
            }
            if let Some(acc) = skin.inverse_bind_matrices() {
                check_once(
                    &acc,
                    "inverseBindMatrices",
                    &format!("skin {}", skin.index()),
                )?;
            }
        }
        for prim in gmesh.primitives() {
            let what = format!("mesh {} primitive {}", gmesh.index(), prim.index());
            if prim.mode() != gltf::mesh::Mode::Triangles {
                non_triangle += 1;
                continue;
            }
            let pos = prim
                .get(&Semantic::Positions)
                .ok_or_else(|| format!("{what}: no POSITION attribute"))?;
            let n = check_once(&pos, "POSITION", &what)?;
            let mut attributes = vec![
                (Semantic::Normals, "NORMAL"),
                (Semantic::Tangents, "TANGENT"),
                (Semantic::TexCoords(0), "TEXCOORD_0"),
            ];
            if node.skin().is_some() {
                attributes.push((Semantic::Joints(0), "JOINTS_0"));
                attributes.push((Semantic::Weights(0), "WEIGHTS_0"));
            }
            for (sem, label) in attributes {
                if let Some(acc) = prim.get(&sem) {
                    let c = check_once(&acc, label, &what)?;
                    if c != n {
                        return Err(format!(
                            "{what}: {label} accessor {} has {c} elements but POSITION \
                             accessor {} has {n}",
                            acc.index(),
                            pos.index()
                        ));
                    }
                }
            }
            let (n_idx, idx_name) = match prim.indices() {
                Some(acc) => (
                    check_once(&acc, "index", &what)?,
                    format!("index accessor {}", acc.index()),
                ),
                None => (
                    n,
                    format!("POSITION accessor {} (not indexed)", pos.index()),
                ),
            };
            if n_idx % 3 != 0 {
                return Err(format!(
                    "{what}: {idx_name} has count {n_idx}, not a multiple of 3 (triangles)"
                ));
            }
            if parts.len() >= MAX_PRIMITIVE_INSTANCES {
                return Err(format!(
                    "more than {MAX_PRIMITIVE_INSTANCES} primitives (counting node instances)"
                ));
            }
            if n > MAX_GLTF_VERTICES - total_v {
                return Err(format!(
                    "{what}: POSITION accessor {} has count {n}; with the {total_v} vertices \
                     before it that exceeds the limit of {MAX_GLTF_VERTICES} per file",
                    pos.index()
                ));
            }
            if n_idx > MAX_GLTF_INDICES - total_i {
                return Err(format!(
                    "{what}: {idx_name} has count {n_idx}; with the {total_i} indices before \
                     it that exceeds the limit of {MAX_GLTF_INDICES} per file"
                ));
            }
            total_v += n;
            total_i += n_idx;
            parts.push(Part {
                instance: *inst,
                node: node.clone(),
                prim,
                what,
                vertices: n,
                indices: n_idx,
            });
        }
    }
    if non_triangle > 0 {
        warnings.push(format!(
            "{name}: skipped {non_triangle} non-triangle primitive(s)"
        ));
    }
    Ok((parts, total_v, total_i))
}

/// The first non-finite element of `items`, as `(index, value)`.
fn first_non_finite<const N: usize>(items: &[[f32; N]]) -> Option<(usize, [f32; N])> {
    items
        .iter()
        .position(|v| !v.iter().all(|c| c.is_finite()))
        .map(|i| (i, items[i]))
}

/// Reads one planned primitive; returns it in world space (degenerate triangles dropped),
/// whether it had usable tangents, and how many triangles were dropped.
pub(super) fn read_part(
    part: &Part,
    buffers: &[gltf::buffer::Data],
    skin_mats: Option<&[Mat4]>,
    name: &str,
    warnings: &mut Vec<String>,
) -> Result<(Mesh, bool, usize), String> {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
    let (what, n) = (&part.what, part.vertices);
    let reader = part.prim.reader(get);
    let acc_index = |s: Semantic| part.prim.get(&s).map_or(0, |a| a.index());
    let short = |label: &str, got: usize, want: usize| {
        format!("{what}: {label} accessor yielded {got} of {want} elements")
    };
    let positions: Vec<[f32; 3]> = reader.read_positions().map_or(vec![], |i| i.collect());
    if positions.len() != n {
        return Err(short("POSITION", positions.len(), n));
    }
    if let Some((i, p)) = first_non_finite(&positions) {
        return Err(format!(
            "{what}: POSITION accessor {}: vertex {i} is not finite ({p:?})",
            acc_index(Semantic::Positions)
        ));
    }
    let mut normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(|i| i.collect());
    if normals.as_deref().and_then(first_non_finite).is_some() {
        warnings.push(format!(
            "{name}: {what}: non-finite normals; recomputing them"
        ));
        normals = None;
    }
    let uvs: Vec<[f32; 2]> = reader
        .read_tex_coords(0)
        .map(|i| i.into_f32().collect())
        .unwrap_or_default();
    if let Some((i, uv)) = first_non_finite(&uvs) {
        return Err(format!(
            "{what}: TEXCOORD_0 accessor {}: element {i} is not finite ({uv:?})",
            acc_index(Semantic::TexCoords(0))
        ));
    }
    let mut tangents: Option<Vec<[f32; 4]>> = reader.read_tangents().map(|i| i.collect());
    if tangents.as_deref().and_then(first_non_finite).is_some() {
        warnings.push(format!(
            "{name}: {what}: non-finite tangents; regenerating them"
        ));
        tangents = None;
    }
    if normals.as_ref().is_some_and(|v| v.len() != n)
        || (!uvs.is_empty() && uvs.len() != n)
        || tangents.as_ref().is_some_and(|v| v.len() != n)
    {
        return Err(format!("{what}: vertex attributes have different lengths"));
    }
    let indices: Vec<u32> = match (part.prim.indices(), reader.read_indices()) {
        (Some(acc), Some(it)) => {
            let idx: Vec<u32> = it.into_u32().collect();
            if idx.len() != part.indices {
                return Err(short("index", idx.len(), part.indices));
            }
            if let Some(k) = idx.iter().position(|&i| i as usize >= n) {
                return Err(format!(
                    "{what}: index accessor {}: index {} (entry {k}) is not below the vertex \
                     count {n}",
                    acc.index(),
                    idx[k]
                ));
            }
            idx
        }
        (None, _) => (0..n as u32).collect(),
        (Some(acc), None) => {
            return Err(format!(
                "{what}: index accessor {} is unreadable",
                acc.index()
            ));
        }
    };
    let mut mesh = Mesh {
        vertices: (0..n)
            .map(|i| Vertex {
                position: positions[i],
                normal: normals.as_ref().map_or([0.0, 0.0, 1.0], |v| v[i]),
                uv: uvs.get(i).copied().unwrap_or([0.0, 0.0]),
                tangent: tangents.as_ref().map_or([1.0, 0.0, 0.0, 1.0], |v| v[i]),
            })
            .collect(),
        indices,
        missing_uvs: None,
    };
    if normals.is_none() {
        mesh.compute_normals();
    }
    let joints: Option<Vec<[u16; 4]>> = skin_mats
        .and_then(|_| reader.read_joints(0))
        .map(|i| i.into_u16().collect());
    let weights: Option<Vec<[f32; 4]>> = skin_mats
        .and_then(|_| reader.read_weights(0))
        .map(|i| i.into_f32().collect());
    match (skin_mats, joints, weights) {
        (Some(mats), Some(joints), Some(weights))
            if joints.len() == n && weights.len() == n && !mats.is_empty() =>
        {
            for (i, v) in mesh.vertices.iter_mut().enumerate() {
                let mut m = Mat4::ZERO;
                let mut wsum = 0.0;
                for k in 0..4 {
                    let w = weights[i][k];
                    if w != 0.0 {
                        let j = joints[i][k] as usize;
                        m += *mats.get(j).unwrap_or(&Mat4::IDENTITY) * w;
                        wsum += w;
                    }
                }
                if wsum <= 0.0 {
                    m = Mat4::IDENTITY;
                } else {
                    m *= 1.0 / wsum;
                }
                let mut one = Mesh {
                    vertices: vec![*v],
                    indices: vec![],
                    missing_uvs: None,
                };
                one.transform(m);
                *v = one.vertices[0];
            }
        }
        _ => mesh.transform(part.instance.world),
    }
    if let Some(i) = mesh
        .vertices
        .iter()
        .position(|v| !v.position.iter().all(|c| c.is_finite()))
    {
        return Err(format!(
            "{what} (node {}): vertex {i} is not finite after the node or skin transform",
            part.instance.node
        ));
    }
    let before = mesh.triangle_count();
    let v = &mesh.vertices;
    let kept: Vec<u32> = mesh
        .indices
        .chunks_exact(3)
        .filter(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(v[i as usize].position));
            (b - a).cross(c - a) != Vec3::ZERO
        })
        .flatten()
        .copied()
        .collect();
    mesh.indices = kept;
    let dropped = before - mesh.triangle_count();
    if uvs.is_empty() && !mesh.indices.is_empty() {
        mesh.missing_uvs = Some(super::MissingUvs {
            first_primitive: what.clone(),
            triangles: mesh.triangle_count(),
        });
    }
    Ok((mesh, tangents.is_some(), dropped))
}
