//! Phong tessellation (Boubekeur & Alexa 2008): every triangle split into `level²` triangles
//! whose new vertices lie on the curved surface the vertex normals describe.
//!
//! Why a skin renderer needs it: shading with interpolated normals treats a low-poly mesh as
//! smooth, but its silhouette, its shadow map and a path tracer see the flat facets. Light
//! crossing a backlit finger of eight facets passes through the thin wedge where two facets
//! meet, and the faceted finger's outline then shines several times brighter and whiter
//! than a round one's (docs/lab/fidelity.md, finding 7). Tessellating the mesh once, on the CPU
//! when the scene loads, gives the rasteriser, the shadow maps and the exported reference
//! the surface the normals already promise.

use std::collections::HashMap;

use glam::{Vec2, Vec3, Vec4};

use super::{Mesh, MissingUvs, Vertex};

/// The largest `tessellate` level a scene may ask for (each level multiplies the triangle
/// count by its square).
pub const MAX_TESSELLATION: u32 = 8;

/// A position by its bits: split copies of one vertex have equal ones.
type PositionBits = [u32; 3];

/// Split copies of a vertex whose normals differ by more than this are a crease.
const CREASE_DEG: f32 = 30.0;

/// Boubekeur & Alexa's shape factor: how far the new points move from the flat triangle
/// toward the three tangent planes (their paper's recommended 3/4).
const PHONG_ALPHA: f32 = 0.75;

impl Mesh {
    /// Splits every triangle into `level * level` triangles by Phong tessellation. Vertices on
    /// a shared edge are shared (no cracks), and an edge's points depend only on its two end
    /// vertices, so that the split copies of a UV seam land on the same positions. Normals,
    /// UVs and tangents are interpolated linearly. `level <= 1` returns the mesh unchanged.
    pub fn phong_tessellate(&self, level: u32) -> Mesh {
        if level <= 1 || self.indices.is_empty() {
            return self.clone();
        }
        let n = level;
        let mut out = Mesh {
            vertices: self.vertices.clone(),
            indices: Vec::with_capacity(self.indices.len() * (n * n) as usize),
            missing_uvs: self.missing_uvs.as_ref().map(|m| MissingUvs {
                first_primitive: m.first_primitive.clone(),
                triangles: m.triangles * (n * n) as usize,
            }),
        };
        // glTF splits a vertex along UV seams (the copies' normals agree to rounding) and
        // along creases (they differ by tens of degrees). An edge that exists as two pairs of
        // copies is cut between two triangles, and curving each side by its own normals would
        // open it into a crack. Such a seam edge is curved by its positions' normals over all
        // copies: their average along a smooth seam; along a crease none, so it stays
        // straight (a slab stays flat). Every other edge, and every triangle's inside, is
        // curved by its own vertices' normals, which also shade it.
        let pos = |i: u32| self.vertices[i as usize].position.map(f32::to_bits);
        let mut copies: HashMap<PositionBits, Vec<Vec3>> = HashMap::new();
        for v in &self.vertices {
            copies
                .entry(v.position.map(f32::to_bits))
                .or_default()
                .push(Vec3::from(v.normal));
        }
        let cos_crease = CREASE_DEG.to_radians().cos();
        let seam_normal = |i: u32| -> Option<Vec3> {
            let normals = &copies[&pos(i)];
            let smooth = normals.iter().all(|a| {
                normals
                    .iter()
                    .all(|b| a.dot(*b) >= cos_crease * a.length() * b.length())
            });
            smooth.then(|| normals.iter().sum::<Vec3>().normalize_or_zero())
        };
        let ordered = |a: u32, b: u32| if pos(a) <= pos(b) { (a, b) } else { (b, a) };
        let mut pairs: HashMap<(PositionBits, PositionBits), Vec<(u32, u32)>> = HashMap::new();
        for tri in self.indices.chunks_exact(3) {
            for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
                let (a, b) = ordered(a, b);
                let ids = pairs.entry((pos(a), pos(b))).or_default();
                if !ids.contains(&(a, b)) {
                    ids.push((a, b));
                }
            }
        }
        let is_seam = |a: u32, b: u32| {
            let (a, b) = ordered(a, b);
            pairs
                .get(&(pos(a), pos(b)))
                .is_some_and(|ids| ids.len() > 1)
        };
        let corner = |i: u32| Corner {
            vertex: self.vertices[i as usize],
            shape_normal: Some(Vec3::from(self.vertices[i as usize].normal)),
        };
        let edge_ends = |a: u32, b: u32| -> [Corner; 2] {
            if is_seam(a, b) {
                [a, b].map(|i| Corner {
                    shape_normal: seam_normal(i),
                    ..corner(i)
                })
            } else {
                [a, b].map(corner)
            }
        };
        // Interior points of an edge, keyed by its (lower, higher) vertex index, listed from
        // the lower index's end.
        let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        let mut grid = vec![0u32; ((n + 1) * (n + 2) / 2) as usize];
        let at = |a: u32, b: u32| (b * (n + 1) - b * (b.saturating_sub(1)) / 2 + a) as usize;
        for tri in self.indices.chunks_exact(3) {
            let [i0, i1, i2] = [tri[0], tri[1], tri[2]];
            let corners = [i0, i1, i2].map(corner);
            // Grid point (a, b): barycentrics ((n - a - b) / n, a / n, b / n) of (i0, i1, i2).
            for b in 0..=n {
                for a in 0..=n - b {
                    let c = n - a - b;
                    let index = match (a, b, c) {
                        (0, 0, _) => i0,
                        (_, 0, 0) => i1,
                        (0, _, 0) => i2,
                        (_, 0, _) => out.edge_point(&mut edges, edge_ends(i0, i1), [i0, i1], a, n),
                        (0, _, _) => out.edge_point(&mut edges, edge_ends(i0, i2), [i0, i2], b, n),
                        (_, _, 0) => out.edge_point(&mut edges, edge_ends(i1, i2), [i1, i2], b, n),
                        _ => {
                            let w = [c, a, b].map(|k| k as f32 / n as f32);
                            out.vertices.push(phong_vertex(&corners, w));
                            out.vertices.len() as u32 - 1
                        }
                    };
                    grid[at(a, b)] = index;
                }
            }
            for b in 0..n {
                for a in 0..n - b {
                    let (p, q, r) = (grid[at(a, b)], grid[at(a + 1, b)], grid[at(a, b + 1)]);
                    out.indices.extend([p, q, r]);
                    if a + b + 1 < n {
                        out.indices.extend([q, grid[at(a + 1, b + 1)], r]);
                    }
                }
            }
        }
        out
    }

    /// The vertex `k / n` of the way from `ends[0]` to `ends[1]` (vertex indices `ids`) on
    /// their edge, created once per edge.
    fn edge_point(
        &mut self,
        edges: &mut HashMap<(u32, u32), Vec<u32>>,
        ends: [Corner; 2],
        ids: [u32; 2],
        k: u32,
        n: u32,
    ) -> u32 {
        let ([lo, hi], k) = if ids[0] < ids[1] {
            (ends, k)
        } else {
            ([ends[1], ends[0]], n - k)
        };
        let key_ids = (ids[0].min(ids[1]), ids[0].max(ids[1]));
        let points = edges.entry(key_ids).or_insert_with(|| {
            // Evaluate from a fixed end (by position, then shape normal) so that two copies of
            // the edge on either side of a UV seam give bit-identical points.
            let key = |c: &Corner| {
                let mut k = [0u32; 6];
                let n = c.shape_normal.unwrap_or(Vec3::ZERO).to_array();
                for (dst, x) in k.iter_mut().zip(c.vertex.position.iter().chain(&n)) {
                    *dst = x.to_bits();
                }
                k
            };
            let swap = key(&hi) < key(&lo);
            (1..n)
                .map(|j| {
                    let (first, second, steps) = if swap { (hi, lo, n - j) } else { (lo, hi, j) };
                    let s = steps as f32 / n as f32;
                    let v = phong_vertex(&[first, second, first], [1.0 - s, s, 0.0]);
                    self.vertices.push(v);
                    self.vertices.len() as u32 - 1
                })
                .collect()
        });
        points[k as usize - 1]
    }
}

/// A triangle corner: its vertex, and the normal whose tangent plane shapes the surface.
#[derive(Clone, Copy)]
struct Corner {
    vertex: Vertex,
    shape_normal: Option<Vec3>,
}

/// The Phong-tessellated vertex at barycentrics `w` of the triangle `c`.
fn phong_vertex(c: &[Corner; 3], w: [f32; 3]) -> Vertex {
    let p = |i: usize| Vec3::from(c[i].vertex.position);
    let flat: Vec3 = (0..3).map(|i| p(i) * w[i]).sum();
    // The flat point projected onto each corner's tangent plane, blended by the same weights.
    let curved: Vec3 = (0..3)
        .map(|i| {
            // A crease corner does not pull: its projection is the flat point itself.
            let n = c[i].shape_normal.unwrap_or(Vec3::ZERO);
            (flat - (flat - p(i)).dot(n) * n) * w[i]
        })
        .sum();
    let position = flat.lerp(curved, PHONG_ALPHA);
    let v = |i: usize| &c[i].vertex;
    let normal = (0..3)
        .map(|i| Vec3::from(v(i).normal) * w[i])
        .sum::<Vec3>()
        .normalize_or(Vec3::from(v(0).normal));
    let uv: Vec2 = (0..3).map(|i| Vec2::from(v(i).uv) * w[i]).sum();
    let t: Vec3 = (0..3)
        .map(|i| Vec4::from(v(i).tangent).truncate() * w[i])
        .sum();
    // Re-orthogonalised against the new normal (Gram-Schmidt), as MikkTSpace's are.
    let tangent = (t - normal * normal.dot(t)).normalize_or(normal.any_orthonormal_vector());
    Vertex {
        position: position.into(),
        normal: normal.into(),
        uv: uv.into(),
        tangent: tangent.extend(v(0).tangent[3]).into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_points_lie_on_the_surface_the_normals_describe() {
        // A sphere of 8 segments (4 rings), as coarse as a low-poly finger, with radial
        // normals. Flat, its facets' centres are up to 13 % inside the sphere; tessellated,
        // every point is within 6 % of it (the quadratic patches overshoot a little midway).
        let r = 0.01;
        let mesh = Mesh::sphere(r, 8);
        let radii = |m: &Mesh| -> (f32, f32) {
            m.vertices.iter().fold((f32::INFINITY, 0.0), |(lo, hi), v| {
                let d = Vec3::from(v.position).length();
                (lo.min(d), hi.max(d))
            })
        };
        let centres = mesh.indices.chunks_exact(3).map(|t| {
            t.iter()
                .map(|i| Vec3::from(mesh.vertices[*i as usize].position))
                .sum::<Vec3>()
                .length()
                / 3.0
        });
        let flat_min = centres.fold(f32::INFINITY, f32::min);
        let t = mesh.phong_tessellate(4);
        let (lo, hi) = radii(&t);
        assert!(
            flat_min < r * 0.9,
            "flat facet centres: {flat_min} of r {r}"
        );
        assert!(
            lo > r * 0.94 && hi < r * 1.06,
            "tessellated points within 6 % of the sphere: {lo}..{hi} of r {r}"
        );
        assert_eq!(t.triangle_count(), mesh.triangle_count() * 16);
    }

    #[test]
    fn shared_edges_share_vertices_and_a_flat_mesh_stays_flat() {
        // A slab's faces are flat and its normals are the face normals: nothing moves, and
        // each face's n x n grid has (n + 1)^2 vertices (no duplicates along the diagonal).
        let slab = Mesh::slab(0.1, 0.1, 0.01);
        let n = 3;
        let t = slab.phong_tessellate(n);
        let faces = slab.triangle_count() / 2;
        assert_eq!(t.vertices.len(), faces * ((n + 1) * (n + 1)) as usize);
        let (lo, hi) = slab.bounds();
        let (tlo, thi) = t.bounds();
        assert!((lo - tlo).abs().max_element() < 1e-7 && (hi - thi).abs().max_element() < 1e-7);
        // Every edge of the result is used by exactly two triangles within each face's grid
        // or lies on the face's border: no T-junctions inside a face.
        let mut count: HashMap<(u32, u32), u32> = HashMap::new();
        for tri in t.indices.chunks_exact(3) {
            for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(count.values().all(|c| *c <= 2));
    }

    /// Edges (of vertices welded by exact position) not shared by exactly two triangles.
    fn open_edges(m: &Mesh) -> usize {
        let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
        let ids: Vec<u32> = m
            .vertices
            .iter()
            .map(|v| {
                let next = weld.len() as u32;
                *weld.entry(v.position.map(f32::to_bits)).or_insert(next)
            })
            .collect();
        let mut count: HashMap<(u32, u32), u32> = HashMap::new();
        for tri in m.indices.chunks_exact(3) {
            let w = tri.iter().map(|i| ids[*i as usize]).collect::<Vec<_>>();
            for (a, b) in [(w[0], w[1]), (w[1], w[2]), (w[2], w[0])] {
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        count.values().filter(|c| **c != 2).count()
    }

    #[test]
    fn tessellation_opens_no_cracks() {
        // The built-in hand splits its vertices along UV seams; the split copies of a seam
        // edge must tessellate to bit-identical points, or the seam opens (light leaks in the
        // path tracer, the shadow map sees through). Every edge that was open stays open as
        // `level` pieces, and no other edge opens.
        let hand = crate::mesh::load_gltf_slice(crate::mesh::BUILTIN_HAND_GLB, "hand")
            .expect("builtin hand")
            .mesh;
        let before = open_edges(&hand);
        for level in [2, 3] {
            let after = open_edges(&hand.phong_tessellate(level));
            assert_eq!(after, before * level as usize, "level {level}");
        }
    }
}
