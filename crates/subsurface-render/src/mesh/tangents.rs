//! MikkTSpace tangent generation.

use glam::{Vec3, Vec4};

use super::Mesh;

impl Mesh {
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

#[cfg(test)]
mod tests {
    use super::super::test_util::check_mesh;
    use super::*;

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
}
