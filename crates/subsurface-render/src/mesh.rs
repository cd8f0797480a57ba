//! Triangle meshes: the GPU vertex layout, procedural shapes (slab, wedge,
//! sphere), MikkTSpace tangent generation and glTF/GLB loading.

use std::path::Path;

use glam::{Mat3, Mat4, Vec3, Vec4};

use crate::scene::SceneError;

/// One vertex as uploaded to the GPU (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
    /// xyz: unit tangent; w: bitangent sign (MikkTSpace), `bitangent = w * cross(normal, tangent)`.
    pub tangent: [f32; 4],
}

/// An indexed triangle list in object space (glTF node transforms baked in).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Object-space axis-aligned bounds `(min, max)`; `(0, 0)` for an empty mesh.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        if self.vertices.is_empty() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        self.vertices.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), v| {
                let p = Vec3::from(v.position);
                (lo.min(p), hi.max(p))
            },
        )
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Appends `other` (indices are re-based).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }

    /// Applies an affine transform: positions by `m`, normals by its inverse
    /// transpose, tangents by its upper 3x3. A mirroring transform (negative
    /// determinant) flips the triangle winding and the bitangent sign so the
    /// mesh stays counter-clockwise front-facing.
    pub fn transform(&mut self, m: Mat4) {
        let m3 = Mat3::from_mat4(m);
        let det = m3.determinant();
        let n3 = if det.abs() > 0.0 {
            m3.inverse().transpose()
        } else {
            m3
        };
        for v in &mut self.vertices {
            v.position = m.transform_point3(Vec3::from(v.position)).to_array();
            v.normal = (n3 * Vec3::from(v.normal)).normalize_or(Vec3::Z).to_array();
            let t = Vec4::from(v.tangent);
            let t3 = (m3 * t.truncate()).normalize_or_zero();
            let w = if det < 0.0 { -t.w } else { t.w };
            v.tangent = t3.extend(w).to_array();
        }
        if det < 0.0 {
            for tri in self.indices.chunks_exact_mut(3) {
                tri.swap(1, 2);
            }
        }
    }

    /// Chart `index` of a 3 x 2 UV atlas: `uv` in 0..1 mapped into its cell, inset by a
    /// margin. Each face of the procedural shapes gets its own cell, because texture-space
    /// diffusion (d'Eon 2007) needs a one-to-one UV map: faces sharing UVs would all write
    /// their irradiance to the same texels. The margin leaves room for the padding that
    /// keeps the blur from pulling in black at chart borders.
    fn atlas_uv(index: usize, uv: [f32; 2]) -> [f32; 2] {
        const COLS: usize = 3;
        const ROWS: usize = 2;
        const MARGIN: f32 = 0.04; // of a cell: 12+ texels of a 1024 map
        let (cx, cy) = ((index % COLS) as f32, (index / COLS % ROWS) as f32);
        let inset = |t: f32| MARGIN + t.clamp(0.0, 1.0) * (1.0 - 2.0 * MARGIN);
        [
            (cx + inset(uv[0])) / COLS as f32,
            (cy + inset(uv[1])) / ROWS as f32,
        ]
    }

    /// Builds a mesh from a list of quads (4 corners counter-clockwise seen
    /// from the front, with a shared flat normal), quad `i` in atlas chart `i`.
    fn from_flat_quads(quads: &[[Vec3; 4]]) -> Mesh {
        let mut mesh = Mesh::default();
        let uvs = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        for (i, q) in quads.iter().enumerate() {
            let n = (q[1] - q[0]).cross(q[2] - q[0]).normalize_or(Vec3::Z);
            let base = mesh.vertices.len() as u32;
            for (p, uv) in q.iter().zip(uvs) {
                mesh.vertices.push(Vertex {
                    position: p.to_array(),
                    normal: n.to_array(),
                    uv: Self::atlas_uv(i, uv),
                    tangent: [0.0; 4],
                });
            }
            mesh.indices
                .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        mesh
    }

    /// Box centred at the origin: `width` along x, `height` along y,
    /// `thickness` along z (a backlit slab of skin is lit along z).
    pub fn slab(width: f32, height: f32, thickness: f32) -> Mesh {
        let (x, y, z) = (width * 0.5, height * 0.5, thickness * 0.5);
        let p = |sx: f32, sy: f32, sz: f32| Vec3::new(sx * x, sy * y, sz * z);
        let quads = [
            // +z
            [
                p(-1., -1., 1.),
                p(1., -1., 1.),
                p(1., 1., 1.),
                p(-1., 1., 1.),
            ],
            // -z
            [
                p(1., -1., -1.),
                p(-1., -1., -1.),
                p(-1., 1., -1.),
                p(1., 1., -1.),
            ],
            // +x
            [
                p(1., -1., 1.),
                p(1., -1., -1.),
                p(1., 1., -1.),
                p(1., 1., 1.),
            ],
            // -x
            [
                p(-1., -1., -1.),
                p(-1., -1., 1.),
                p(-1., 1., 1.),
                p(-1., 1., -1.),
            ],
            // +y
            [
                p(-1., 1., 1.),
                p(1., 1., 1.),
                p(1., 1., -1.),
                p(-1., 1., -1.),
            ],
            // -y
            [
                p(-1., -1., -1.),
                p(1., -1., -1.),
                p(1., -1., 1.),
                p(-1., -1., 1.),
            ],
        ];
        let mut m = Self::from_flat_quads(&quads);
        m.generate_tangents();
        m
    }

    /// Triangular prism centred at the origin. Its thickness along z grows
    /// linearly from 0 at `x = -length/2` to `max_thickness` at `x = +length/2`
    /// (the cross-section in the xz plane is a triangle, symmetric about z = 0);
    /// it extends `height` along y. Backlit along z it shows transmittance
    /// against thickness.
    pub fn wedge(length: f32, height: f32, max_thickness: f32) -> Mesh {
        let (x, y, z) = (length * 0.5, height * 0.5, max_thickness * 0.5);
        let apex_lo = Vec3::new(-x, -y, 0.0);
        let apex_hi = Vec3::new(-x, y, 0.0);
        let f_lo = Vec3::new(x, -y, z); // front (+z) edge at the thick end
        let f_hi = Vec3::new(x, y, z);
        let b_lo = Vec3::new(x, -y, -z);
        let b_hi = Vec3::new(x, y, -z);
        let quads = [
            // front sloped face (normal mostly +z)
            [apex_lo, f_lo, f_hi, apex_hi],
            // back sloped face (normal mostly -z)
            [b_lo, apex_lo, apex_hi, b_hi],
            // thick end (+x)
            [f_lo, b_lo, b_hi, f_hi],
        ];
        let mut m = Self::from_flat_quads(&quads);
        // End caps (triangles, y = +-height/2).
        let mut cap = |chart: usize, a: Vec3, b: Vec3, c: Vec3, n: Vec3| {
            let base = m.vertices.len() as u32;
            for p in [a, b, c] {
                m.vertices.push(Vertex {
                    position: p.to_array(),
                    normal: n.to_array(),
                    uv: Self::atlas_uv(
                        chart,
                        [
                            p.x / length + 0.5,
                            p.z / max_thickness.max(f32::MIN_POSITIVE) + 0.5,
                        ],
                    ),
                    tangent: [0.0; 4],
                });
            }
            m.indices.extend_from_slice(&[base, base + 1, base + 2]);
        };
        cap(3, apex_hi, f_hi, b_hi, Vec3::Y);
        cap(4, apex_lo, b_lo, f_lo, -Vec3::Y);
        m.generate_tangents();
        m
    }

    /// UV sphere centred at the origin with `segments` divisions around the
    /// equator (y is the pole axis) and `segments / 2` (at least 2) rings.
    pub fn sphere(radius: f32, segments: u32) -> Mesh {
        let seg = segments.max(3);
        let rings = (seg / 2).max(2);
        let mut mesh = Mesh::default();
        for r in 0..=rings {
            let v = r as f32 / rings as f32;
            let theta = v * std::f32::consts::PI;
            for s in 0..=seg {
                let u = s as f32 / seg as f32;
                let phi = u * std::f32::consts::TAU;
                let n = Vec3::new(
                    theta.sin() * phi.sin(),
                    theta.cos(),
                    theta.sin() * phi.cos(),
                );
                // Tangent along increasing u (d/dphi), analytic so poles are fine.
                let t = Vec3::new(phi.cos(), 0.0, -phi.sin());
                mesh.vertices.push(Vertex {
                    position: (n * radius).to_array(),
                    normal: n.to_array(),
                    uv: [u, v],
                    // uv.v grows downward (from +y pole) so bitangent = -dP/dtheta...
                    tangent: [t.x, t.y, t.z, 1.0],
                });
            }
        }
        let row = seg + 1;
        for r in 0..rings {
            for s in 0..seg {
                let a = r * row + s;
                let b = a + row;
                // counter-clockwise seen from outside
                if r != 0 {
                    mesh.indices.extend_from_slice(&[a, b, a + 1]);
                }
                if r != rings - 1 {
                    mesh.indices.extend_from_slice(&[a + 1, b, b + 1]);
                }
            }
        }
        mesh.generate_tangents();
        mesh
    }

    /// Computes smooth (area-weighted) vertex normals from the triangles.
    pub fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.vertices.len()];
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] =
                [tri[0], tri[1], tri[2]].map(|i| Vec3::from(self.vertices[i as usize].position));
            let n = (b - a).cross(c - a);
            for &i in tri {
                acc[i as usize] += n;
            }
        }
        for (v, n) in self.vertices.iter_mut().zip(acc) {
            v.normal = n.normalize_or(Vec3::Z).to_array();
        }
    }

    /// Generates MikkTSpace tangents (via `bevy_mikktspace`) for every vertex.
    /// Vertices for which MikkTSpace produces nothing (degenerate UVs with no
    /// usable neighbour) get an arbitrary unit tangent orthogonal to the normal.
    ///
    /// MikkTSpace writes one tangent per (face, corner); a vertex shared by
    /// faces that disagree (a UV mirror seam without split vertices) keeps the
    /// average of the tangents written for it, re-orthogonalised.
    pub fn generate_tangents(&mut self) {
        struct Geo<'a> {
            mesh: &'a Mesh,
            acc: Vec<Vec4>,
        }
        impl bevy_mikktspace::Geometry for Geo<'_> {
            fn num_faces(&self) -> usize {
                self.mesh.indices.len() / 3
            }
            fn num_vertices_of_face(&self, _face: usize) -> usize {
                3
            }
            fn position(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.vertices[self.mesh.indices[face * 3 + vert] as usize].position
            }
            fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.vertices[self.mesh.indices[face * 3 + vert] as usize].normal
            }
            fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
                self.mesh.vertices[self.mesh.indices[face * 3 + vert] as usize].uv
            }
            fn set_tangent(
                &mut self,
                ts: Option<bevy_mikktspace::TangentSpace>,
                face: usize,
                vert: usize,
            ) {
                if let Some(ts) = ts {
                    let i = self.mesh.indices[face * 3 + vert] as usize;
                    let t = ts.tangent_encoded();
                    self.acc[i] += Vec4::new(t[0], t[1], t[2], t[3]);
                }
            }
        }
        let mut geo = Geo {
            mesh: self,
            acc: vec![Vec4::ZERO; self.vertices.len()],
        };
        // The error type is uninhabited: this cannot fail.
        let _ = bevy_mikktspace::generate_tangents(&mut geo);
        let acc = geo.acc;
        for (v, a) in self.vertices.iter_mut().zip(acc) {
            let n = Vec3::from(v.normal).normalize_or(Vec3::Z);
            let t = a.truncate();
            let mut t = (t - n * n.dot(t)).normalize_or_zero();
            if t == Vec3::ZERO {
                t = n.any_orthonormal_vector();
            }
            let w = if a.w < 0.0 { -1.0 } else { 1.0 };
            v.tangent = [t.x, t.y, t.z, w];
        }
    }
}

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

fn gltf_err(name: &str, e: impl std::fmt::Display) -> SceneError {
    SceneError::Gltf {
        file: name.to_string(),
        msg: crate::scene::one_line(&e.to_string()),
    }
}

/// Loads a `.glb` or `.gltf` file (external buffers and images are resolved
/// relative to its directory).
pub fn load_gltf(path: &Path) -> Result<GltfModel, SceneError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SceneError::Io {
        file: name.clone(),
        msg: crate::scene::one_line(&e.to_string()),
    })?;
    load_gltf_impl(&bytes, &name, path.parent())
}

/// Loads a glTF from memory (GLB, or glTF JSON with only embedded data URIs).
/// `name_for_errors` names the file in error messages.
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

fn load_gltf_impl(bytes: &[u8], name: &str, base: Option<&Path>) -> Result<GltfModel, SceneError> {
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(bytes).map_err(|e| gltf_err(name, e))?;
    let buffers = gltf::import_buffers(&document, base, blob).map_err(|e| gltf_err(name, e))?;
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());

    // World transforms of every node of the scene(s).
    let n_nodes = document.nodes().count();
    let mut world: Vec<Option<Mat4>> = vec![None; n_nodes];
    fn visit(node: gltf::Node, parent: Mat4, world: &mut [Option<Mat4>]) {
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        world[node.index()] = Some(m);
        for c in node.children() {
            visit(c, m, world);
        }
    }
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let mut roots: Vec<gltf::Node> = scene.map(|s| s.nodes().collect()).unwrap_or_default();
    let has_mesh = |roots: &[gltf::Node], world: &mut Vec<Option<Mat4>>| {
        for r in roots {
            visit(r.clone(), Mat4::IDENTITY, world);
        }
        document
            .nodes()
            .any(|n| n.mesh().is_some() && world[n.index()].is_some())
    };
    if !has_mesh(&roots, &mut world) {
        // No scene, or the default scene has no mesh: use every root node.
        let mut is_child = vec![false; n_nodes];
        for n in document.nodes() {
            for c in n.children() {
                is_child[c.index()] = true;
            }
        }
        roots = document.nodes().filter(|n| !is_child[n.index()]).collect();
        world = vec![None; n_nodes];
        has_mesh(&roots, &mut world);
    }

    let mut mesh = Mesh::default();
    let mut all_have_tangents = true;
    let mut best_material: Option<(usize, gltf::Material)> = None;
    for node in document.nodes() {
        let (Some(gmesh), Some(node_world)) = (node.mesh(), world[node.index()]) else {
            continue;
        };
        // Skinned meshes: glTF ignores the skinned node's own transform and
        // poses vertices by `jointWorld * inverseBindMatrix`. With the default
        // node transforms (the bind pose for the WebXR hand), each vertex is
        // `sum_j w_j * (jointWorld_j * IBM_j) * v`. For right.glb this
        // product is the identity up to float noise (the raw positions are
        // already in bind pose); we still apply it so that files whose skeleton
        // root carries a transform are placed correctly.
        let skin_mats: Option<Vec<Mat4>> = node.skin().map(|skin| {
            let ibms: Vec<Mat4> = skin
                .reader(get)
                .read_inverse_bind_matrices()
                .map(|it| it.map(|m| Mat4::from_cols_array_2d(&m)).collect())
                .unwrap_or_default();
            skin.joints()
                .enumerate()
                .map(|(j, joint)| {
                    let jw = world[joint.index()].unwrap_or_else(|| {
                        // Joint outside the visited scene: use its local chain.
                        Mat4::from_cols_array_2d(&joint.transform().matrix())
                    });
                    jw * ibms.get(j).copied().unwrap_or(Mat4::IDENTITY)
                })
                .collect()
        });
        for prim in gmesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                log::warn!(
                    "{name}: skipping a non-triangle primitive ({:?})",
                    prim.mode()
                );
                continue;
            }
            let reader = prim.reader(get);
            let Some(positions) = reader.read_positions() else {
                continue;
            };
            let positions: Vec<[f32; 3]> = positions.collect();
            let n = positions.len();
            let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(|i| i.collect());
            let uvs: Vec<[f32; 2]> = reader
                .read_tex_coords(0)
                .map(|i| i.into_f32().collect())
                .unwrap_or_default();
            let tangents: Option<Vec<[f32; 4]>> = reader.read_tangents().map(|i| i.collect());
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..n as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
                return Err(gltf_err(
                    name,
                    format!("index {bad} out of range (primitive has {n} vertices)"),
                ));
            }
            if normals.as_ref().is_some_and(|v| v.len() != n)
                || (!uvs.is_empty() && uvs.len() != n)
                || tangents.as_ref().is_some_and(|v| v.len() != n)
            {
                return Err(gltf_err(name, "vertex attributes have different lengths"));
            }
            all_have_tangents &= tangents.is_some();
            let mut part = Mesh {
                vertices: (0..n)
                    .map(|i| Vertex {
                        position: positions[i],
                        normal: normals.as_ref().map_or([0.0, 0.0, 1.0], |v| v[i]),
                        uv: uvs.get(i).copied().unwrap_or([0.0, 0.0]),
                        tangent: tangents.as_ref().map_or([1.0, 0.0, 0.0, 1.0], |v| v[i]),
                    })
                    .collect(),
                indices: indices.chunks_exact(3).flatten().copied().collect(),
            };
            if normals.is_none() {
                part.compute_normals();
            }
            let joints: Option<Vec<[u16; 4]>> =
                reader.read_joints(0).map(|i| i.into_u16().collect());
            let weights: Option<Vec<[f32; 4]>> =
                reader.read_weights(0).map(|i| i.into_f32().collect());
            match (&skin_mats, joints, weights) {
                (Some(mats), Some(joints), Some(weights))
                    if joints.len() == n && weights.len() == n && !mats.is_empty() =>
                {
                    for (i, v) in part.vertices.iter_mut().enumerate() {
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
                        };
                        one.transform(m);
                        *v = one.vertices[0];
                    }
                }
                _ => part.transform(node_world),
            }
            let tris = part.triangle_count();
            if best_material.as_ref().is_none_or(|(t, _)| tris > *t) {
                best_material = Some((tris, prim.material()));
            }
            mesh.append(&part);
        }
    }
    if mesh.indices.is_empty() {
        return Err(gltf_err(name, "no triangle mesh in the default scene"));
    }
    if !all_have_tangents {
        mesh.generate_tangents();
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
        if bc.is_some() || nt.is_some() {
            let images =
                gltf::import_images(&document, base, &buffers).map_err(|e| gltf_err(name, e))?;
            let img = |i: Option<usize>| -> Result<Option<image::RgbaImage>, SceneError> {
                match i {
                    None => Ok(None),
                    Some(i) => images
                        .get(i)
                        .and_then(convert_image)
                        .map(Some)
                        .ok_or_else(|| gltf_err(name, format!("image {i}: unsupported format"))),
                }
            };
            model.base_color_texture = img(bc)?;
            model.normal_texture = img(nt)?;
        }
    }
    Ok(model)
}

/// Bytes of the vendored WebXR generic right hand (MIT), used by `builtin:hand`.
pub const BUILTIN_HAND_GLB: &[u8] = include_bytes!("../../../assets/webxr-generic-hand/right.glb");

#[cfg(test)]
mod tests {
    use super::*;

    fn check_mesh(m: &Mesh) {
        assert!(!m.indices.is_empty());
        assert_eq!(m.indices.len() % 3, 0);
        for &i in &m.indices {
            assert!((i as usize) < m.vertices.len());
        }
        for v in &m.vertices {
            let n = Vec3::from(v.normal);
            let t = Vec4::from(v.tangent);
            assert!((n.length() - 1.0).abs() < 1e-3, "normal {n}");
            assert!((t.truncate().length() - 1.0).abs() < 1e-3, "tangent {t}");
            assert!(n.dot(t.truncate()).abs() < 1e-3, "tangent not orthogonal");
            assert!(t.w == 1.0 || t.w == -1.0);
        }
        // Triangles wind counter-clockwise seen from the side their normals face.
        let mut agree = 0usize;
        for tri in m.indices.chunks_exact(3) {
            let p: Vec<Vec3> = tri
                .iter()
                .map(|&i| Vec3::from(m.vertices[i as usize].position))
                .collect();
            let face_n = (p[1] - p[0]).cross(p[2] - p[0]);
            let vn: Vec3 = tri
                .iter()
                .map(|&i| Vec3::from(m.vertices[i as usize].normal))
                .sum();
            if face_n.dot(vn) > 0.0 {
                agree += 1;
            }
        }
        assert!(
            agree * 100 >= m.triangle_count() * 95,
            "{agree}/{}",
            m.triangle_count()
        );
    }

    fn volume(m: &Mesh) -> f32 {
        m.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] =
                    [t[0], t[1], t[2]].map(|i| Vec3::from(m.vertices[i as usize].position));
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Texture-space diffusion needs every face in its own part of the UV square: faces with
    /// different normals never share a UV cell, and all UVs lie in 0..1.
    #[test]
    fn procedural_faces_have_their_own_uv_charts() {
        for m in [Mesh::slab(0.05, 0.04, 0.01), Mesh::wedge(0.08, 0.04, 0.008)] {
            let mut cells: std::collections::HashMap<(u32, u32), [i32; 3]> = Default::default();
            for t in m.indices.chunks_exact(3) {
                let v: Vec<&Vertex> = t.iter().map(|&i| &m.vertices[i as usize]).collect();
                let c = v.iter().fold([0.0f32; 2], |a, v| {
                    assert!(v.uv.iter().all(|x| (0.0..=1.0).contains(x)), "{:?}", v.uv);
                    [a[0] + v.uv[0] / 3.0, a[1] + v.uv[1] / 3.0]
                });
                let cell = ((c[0] * 3.0) as u32, (c[1] * 2.0) as u32);
                // Every corner of the triangle is in the same cell as its centre.
                for v in &v {
                    let inside =
                        (v.uv[0] * 3.0).floor() as u32 == cell.0 || (v.uv[0] * 3.0).fract() == 0.0;
                    assert!(inside, "triangle crosses cells: {:?}", v.uv);
                }
                let n = v[0].normal.map(|x| (x * 1000.0).round() as i32);
                let prev = cells.entry(cell).or_insert(n);
                assert_eq!(*prev, n, "two faces share UV cell {cell:?}");
            }
            assert!(cells.len() >= 5, "{} charts", cells.len());
        }
    }

    #[test]
    fn slab_shape() {
        let m = Mesh::slab(2.0, 3.0, 0.5);
        check_mesh(&m);
        let (lo, hi) = m.bounds();
        assert_eq!(lo, Vec3::new(-1.0, -1.5, -0.25));
        assert_eq!(hi, Vec3::new(1.0, 1.5, 0.25));
        assert!((volume(&m) - 3.0).abs() < 1e-4);
    }

    #[test]
    fn wedge_shape() {
        let m = Mesh::wedge(0.1, 0.04, 0.02);
        check_mesh(&m);
        let (lo, hi) = m.bounds();
        assert!((lo - Vec3::new(-0.05, -0.02, -0.01)).abs().max_element() < 1e-6);
        assert!((hi - Vec3::new(0.05, 0.02, 0.01)).abs().max_element() < 1e-6);
        // Volume of the prism: 0.5 * length * max_thickness * height.
        assert!((volume(&m) - 0.5 * 0.1 * 0.02 * 0.04).abs() < 1e-9);
        // Thickness at x=-L/2 is 0: every vertex at x=-L/2 has z=0.
        for v in &m.vertices {
            if (v.position[0] + 0.05).abs() < 1e-6 {
                assert_eq!(v.position[2], 0.0);
            }
        }
    }

    #[test]
    fn sphere_shape() {
        let m = Mesh::sphere(2.0, 32);
        check_mesh(&m);
        for v in &m.vertices {
            assert!((Vec3::from(v.position).length() - 2.0).abs() < 1e-4);
        }
        let v = volume(&m);
        let exact = 4.0 / 3.0 * std::f32::consts::PI * 8.0;
        assert!(v > 0.95 * exact && v <= exact, "{v} vs {exact}");
        check_mesh(&Mesh::sphere(1.0, 3));
    }

    #[test]
    fn tangents_follow_uv_u_direction() {
        // A quad in the xy plane with u along +x, v along +y: tangent = +x, w = +1.
        let mut m = Mesh::slab(1.0, 1.0, 1.0);
        for v in &mut m.vertices {
            v.tangent = [0.0; 4];
        }
        m.generate_tangents();
        for v in &m.vertices {
            if v.normal == [0.0, 0.0, 1.0] {
                assert!((Vec3::from_slice(&v.tangent[..3]) - Vec3::X).length() < 1e-5);
                assert_eq!(v.tangent[3], 1.0);
            }
        }
        // Mirrored UVs (u decreasing along +x) flip the tangent direction.
        let mut q = Mesh::from_flat_quads(&[[
            Vec3::new(0., 0., 0.),
            Vec3::new(1., 0., 0.),
            Vec3::new(1., 1., 0.),
            Vec3::new(0., 1., 0.),
        ]]);
        for v in &mut q.vertices {
            v.uv[0] = 1.0 - v.uv[0];
        }
        q.generate_tangents();
        for v in &q.vertices {
            assert!((Vec3::from_slice(&v.tangent[..3]) + Vec3::X).length() < 1e-5);
            // bitangent = w * cross(n, t) = w * cross(z, -x) = w * -y must be +y (v up).
            assert_eq!(v.tangent[3], -1.0);
        }
    }

    #[test]
    fn tangents_degenerate_uvs_are_still_orthonormal() {
        let mut m = Mesh::sphere(1.0, 8);
        for v in &mut m.vertices {
            v.uv = [0.5, 0.5];
        }
        m.generate_tangents();
        check_mesh(&m);
    }

    #[test]
    fn transform_mirror_keeps_winding() {
        let mut m = Mesh::slab(1.0, 2.0, 3.0);
        m.transform(Mat4::from_scale(Vec3::new(-2.0, 1.0, 1.0)));
        check_mesh(&m);
        assert!(volume(&m) > 0.0);
        assert!((volume(&m) - 12.0).abs() < 1e-4);
    }

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

    fn base64_encode(data: &[u8]) -> String {
        const T: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in data.chunks(3) {
            let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
            let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
            for k in 0..4 {
                if k <= c.len() {
                    s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    s.push('=');
                }
            }
        }
        s
    }
}
