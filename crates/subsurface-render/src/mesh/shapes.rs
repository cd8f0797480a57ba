//! Procedural test shapes (slab, wedge, sphere, cylinder) and the UV atlas that gives each of
//! their faces its own chart.

use glam::Vec3;

use super::{Mesh, Vertex};

impl Mesh {
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
    pub(super) fn from_flat_quads(quads: &[[Vec3; 4]]) -> Mesh {
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

    /// Closed cylinder centred at the origin, its axis along y: `segments` divisions around
    /// the side (smooth normals), flat caps. Backlit across its axis it is a finger whose
    /// cross-section is the same at every height, so a reference can be averaged along it.
    /// The side is chart 0 of the atlas (u around, v along), the caps charts 1 and 2.
    pub fn cylinder(radius: f32, length: f32, segments: u32) -> Mesh {
        let seg = segments.max(3);
        let half = 0.5 * length;
        let mut mesh = Mesh::default();
        let around = |s: u32| {
            let phi = s as f32 / seg as f32 * std::f32::consts::TAU;
            Vec3::new(phi.sin(), 0.0, phi.cos())
        };
        for s in 0..=seg {
            let n = around(s);
            for (v, y) in [(0.0, -half), (1.0, half)] {
                mesh.vertices.push(Vertex {
                    position: (n * radius + Vec3::Y * y).to_array(),
                    normal: n.to_array(),
                    uv: Self::atlas_uv(0, [s as f32 / seg as f32, v]),
                    tangent: [0.0; 4],
                });
            }
        }
        for s in 0..seg {
            let (a, b) = (2 * s, 2 * s + 2);
            // counter-clockwise seen from outside
            mesh.indices
                .extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
        }
        for (chart, y, ny) in [(1, -half, -1.0f32), (2, half, 1.0)] {
            let centre = mesh.vertices.len() as u32;
            let cap = |p: Vec3| Vertex {
                position: (p * radius + Vec3::Y * y).to_array(),
                normal: [0.0, ny, 0.0],
                uv: Self::atlas_uv(chart, [0.5 + 0.5 * p.x, 0.5 + 0.5 * p.z]),
                tangent: [0.0; 4],
            };
            mesh.vertices.push(cap(Vec3::ZERO));
            for s in 0..seg {
                mesh.vertices.push(cap(around(s)));
            }
            for s in 0..seg {
                let (i, j) = (centre + 1 + s, centre + 1 + (s + 1) % seg);
                if ny > 0.0 {
                    mesh.indices.extend_from_slice(&[centre, i, j]);
                } else {
                    mesh.indices.extend_from_slice(&[centre, j, i]);
                }
            }
        }
        mesh.generate_tangents();
        mesh
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{check_mesh, volume};
    use super::*;

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

    /// Checks `m` (see [`check_mesh`]) and that its bounds are `-half..half` to float precision.
    fn check_centred(m: &Mesh, half: Vec3) {
        check_mesh(m);
        let (lo, hi) = m.bounds();
        assert!((lo + half).abs().max_element() < 1e-6, "{lo}");
        assert!((hi - half).abs().max_element() < 1e-6, "{hi}");
    }

    #[test]
    fn wedge_shape() {
        let m = Mesh::wedge(0.1, 0.04, 0.02);
        check_centred(&m, Vec3::new(0.05, 0.02, 0.01));
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
    fn cylinder_shape() {
        let m = Mesh::cylinder(0.5, 3.0, 64);
        check_centred(&m, Vec3::new(0.5, 1.5, 0.5));
        // The inscribed 64-gon prism: pi r^2 L sin(2 pi / 64) / (2 pi / 64).
        let exact = std::f32::consts::PI * 0.25 * 3.0;
        let polygon = exact * (std::f32::consts::TAU / 64.0).sin() / (std::f32::consts::TAU / 64.0);
        assert!(
            (volume(&m) - polygon).abs() < 1e-4 * exact,
            "{}",
            volume(&m)
        );
        // Side normals point away from the axis.
        for v in &m.vertices {
            let p = Vec3::from(v.position);
            let n = Vec3::from(v.normal);
            if n.y == 0.0 {
                assert!((n - Vec3::new(p.x, 0.0, p.z) / 0.5).length() < 1e-5);
            }
        }
        check_mesh(&Mesh::cylinder(1.0, 1.0, 3));
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
}
