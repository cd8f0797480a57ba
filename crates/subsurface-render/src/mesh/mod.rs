//! Triangle meshes: the GPU vertex layout, procedural shapes (slab, wedge,
//! sphere), MikkTSpace tangent generation and glTF/GLB loading.
//!
//! glTF files are untrusted input: [`load_gltf`] and [`load_gltf_slice`] return a one-line
//! [`SceneError`](crate::scene::error::SceneError) for every malformed file instead of
//! panicking, recursing without bound or allocating what a header merely claims. The limits
//! are the `MAX_*` constants re-exported here.

mod gltf;
mod gltf_check;
mod gltf_read;
mod shapes;
mod tangents;
mod tessellate;

use glam::{Mat3, Mat4, Vec3, Vec4};

pub use self::gltf::{BUILTIN_HAND_GLB, GltfModel, load_gltf, load_gltf_slice};
pub use self::gltf_check::{
    MAX_BUFFER_BYTES, MAX_GLTF_INDICES, MAX_GLTF_VERTICES, MAX_NODE_DEPTH, MAX_NODE_INSTANCES,
    MAX_PRIMITIVE_INSTANCES,
};
pub use self::tessellate::MAX_TESSELLATION;

/// One vertex as uploaded to the GPU (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Object-space position, the mesh's units.
    pub position: [f32; 3],
    /// Object-space unit normal.
    pub normal: [f32; 3],
    /// Texture coordinates (a glTF's `TEXCOORD_0`).
    pub uv: [f32; 2],
    /// xyz: unit tangent; w: bitangent sign (MikkTSpace), `bitangent = w * cross(normal, tangent)`.
    pub tangent: [f32; 4],
}

/// An indexed triangle list in object space (glTF node transforms baked in).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// The vertices the indices refer to.
    pub vertices: Vec<Vertex>,
    /// Triangle list, three indices per triangle, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Triangles whose glTF primitive had no `TEXCOORD_0` (their uvs are all the origin).
    /// A mesh where only some primitives lack UVs still covers UV space, so the coverage
    /// test alone would let texture-space diffusion render those primitives black.
    pub missing_uvs: Option<MissingUvs>,
}

/// Where a mesh's UVs are missing: the first primitive without `TEXCOORD_0` and the
/// number of triangles from all such primitives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MissingUvs {
    /// `mesh M primitive P` of the glTF file.
    pub first_primitive: String,
    /// Triangles, over all primitives without `TEXCOORD_0`.
    pub triangles: usize,
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
        if let Some(o) = &other.missing_uvs {
            match &mut self.missing_uvs {
                Some(m) => m.triangles += o.triangles,
                None => self.missing_uvs = Some(o.clone()),
            }
        }
    }

    /// Applies an affine transform: positions by `m`, normals by its inverse
    /// transpose, tangents by its upper 3x3. A mirroring transform (negative
    /// determinant) flips the triangle winding and the bitangent sign so the
    /// mesh stays counter-clockwise front-facing.
    pub fn transform(&mut self, m: Mat4) {
        let m3 = Mat3::from_mat4(m);
        // Normals and tangents only need directions, so they are transformed by the 3x3 scaled
        // to a largest entry of 1: an object scale of 1e-30 or 1e30 would otherwise underflow
        // or overflow the f32 determinant and lengths, and every normal fell back to +z.
        let big = m3
            .to_cols_array()
            .iter()
            .fold(0.0f32, |a, x| a.max(x.abs()));
        let d3 = if big.is_finite() && big.recip().is_finite() {
            m3 * big.recip()
        } else {
            m3
        };
        // Its sign says whether the transform mirrors (computed on `d3`, which cannot underflow).
        let det = d3.determinant();
        let n3 = if det.abs() > 0.0 {
            d3.inverse().transpose()
        } else {
            d3
        };
        for v in &mut self.vertices {
            v.position = m.transform_point3(Vec3::from(v.position)).to_array();
            v.normal = (n3 * Vec3::from(v.normal)).normalize_or(Vec3::Z).to_array();
            let t = Vec4::from(v.tangent);
            let t3 = (d3 * t.truncate()).normalize_or_zero();
            let w = if det < 0.0 { -t.w } else { t.w };
            v.tangent = t3.extend(w).to_array();
        }
        if det < 0.0 {
            for tri in self.indices.chunks_exact_mut(3) {
                tri.swap(1, 2);
            }
        }
    }

    /// Whether the triangles cover at least `area` of UV space (the unit square is 1;
    /// overlaps count twice). A glTF without `TEXCOORD_0` has every uv at the origin and
    /// covers 0. Stops at the first triangles that reach `area`, so a real UV layout costs a
    /// handful of triangles however large the mesh (the viewer asks on every edit).
    pub fn uv_area_at_least(&self, area: f64) -> bool {
        let mut sum = 0.0f64;
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| {
                let uv = self.vertices[i as usize].uv;
                [f64::from(uv[0]), f64::from(uv[1])]
            });
            sum += ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs() / 2.0;
            if sum >= area {
                return true;
            }
        }
        false
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
}

/// Helpers shared by the unit tests of the submodules.
#[cfg(test)]
pub(crate) mod test_util {
    use super::*;

    /// Asserts the invariants every mesh handed to the renderer must keep: valid indices,
    /// unit normals and tangents, orthogonal tangent frames, and consistent winding.
    pub fn check_mesh(m: &Mesh) {
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

    /// Signed volume enclosed by a closed mesh (positive when it winds outwards).
    pub fn volume(m: &Mesh) -> f32 {
        m.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] =
                    [t[0], t[1], t[2]].map(|i| Vec3::from(m.vertices[i as usize].position));
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::test_util::{check_mesh, volume};
    use super::*;

    #[test]
    fn transform_mirror_keeps_winding() {
        let mut m = Mesh::slab(1.0, 2.0, 3.0);
        m.transform(Mat4::from_scale(Vec3::new(-2.0, 1.0, 1.0)));
        check_mesh(&m);
        assert!(volume(&m) > 0.0);
        assert!((volume(&m) - 12.0).abs() < 1e-4);
    }

    #[test]
    fn transform_at_extreme_scales_keeps_normals() {
        let reference = Mesh::sphere(1.0, 8);
        for s in [1e-30f32, 1e30] {
            let mut m = reference.clone();
            m.transform(Mat4::from_scale(Vec3::splat(s)));
            for (a, b) in m.vertices.iter().zip(&reference.vertices) {
                let (na, nb) = (Vec3::from(a.normal), Vec3::from(b.normal));
                assert!(na.dot(nb) > 0.999, "scale {s}: {na} vs {nb}");
            }
        }
    }

    #[test]
    fn append_rebases_indices_and_bounds_cover_both() {
        let mut a = Mesh::slab(1.0, 1.0, 1.0);
        let mut b = Mesh::slab(1.0, 1.0, 1.0);
        b.transform(Mat4::from_translation(Vec3::new(3.0, 0.0, 0.0)));
        let (na, nb) = (a.vertices.len(), b.indices.len());
        a.append(&b);
        check_mesh(&a);
        assert_eq!(a.triangle_count() * 3, nb * 2);
        assert!(a.indices[nb..].iter().all(|&i| i as usize >= na));
        let (lo, hi) = a.bounds();
        assert_eq!(lo, Vec3::splat(-0.5));
        assert_eq!(hi, Vec3::new(3.5, 0.5, 0.5));
        assert_eq!(Mesh::default().bounds(), (Vec3::ZERO, Vec3::ZERO));
    }

    #[test]
    fn uv_area_is_zero_without_uvs() {
        let mut m = Mesh::sphere(1.0, 16);
        assert!(m.uv_area_at_least(0.1));
        for v in &mut m.vertices {
            v.uv = [0.0, 0.0];
        }
        assert!(!m.uv_area_at_least(1e-12));
        assert!(!Mesh::default().uv_area_at_least(1e-12));
    }
}
