//! The bounce's flux pyramid and its gather (`passes::bounce` of subsurface-render,
//! bounce_build.wgsl and bounce.wgsl), on the CPU: the oracle the GPU pyramid and the gathered
//! light are compared with.
//!
//! Every shadow-map texel is a lit point; a cell keeps sums over its points (flux, flux x
//! position, flux x normal, flux over the cosine of incidence, flux x squared distance from
//! the light), each level summing 2 x 2 cells of the level below. A shaded point reads each
//! level from `ring` to `2 ring` of its cells away from its own place in the map, and each
//! cell sends it flux / (pi (d^2 + R^2)) times the cosines, R^2 twice the cell's spread (a
//! uniform disc's points lie R^2 / 2 from its centre on average).

/// One cell's sums, per unit of the light's colour.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FluxCell {
    /// Sum of flux x position.
    pub position_sum: [f64; 3],
    /// Sum of flux.
    pub flux: f64,
    /// Sum of flux x unit normal.
    pub normal_sum: [f64; 3],
    /// Sum of flux / cos(incidence): what the boundary reflects.
    pub reflected: f64,
    /// Sum of flux x squared distance from the light's origin.
    pub spread: f64,
}

impl FluxCell {
    fn add(&mut self, o: &FluxCell) {
        for c in 0..3 {
            self.position_sum[c] += o.position_sum[c];
            self.normal_sum[c] += o.normal_sum[c];
        }
        self.flux += o.flux;
        self.reflected += o.reflected;
        self.spread += o.spread;
    }
}

/// One level: `size` x `size` cells, row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct FluxLevel {
    /// Cells per side.
    pub size: usize,
    /// `size * size` cells, row by row.
    pub cells: Vec<FluxCell>,
}

impl FluxLevel {
    /// The cell in column `i`, row `j`.
    pub fn at(&self, i: usize, j: usize) -> &FluxCell {
        &self.cells[j * self.size + i]
    }
}

/// The level above `level`: `size / 2` cells a side, each the sum of its 2 x 2 children; an
/// odd side's last row and column go to the last cell.
pub fn downsample(level: &FluxLevel) -> FluxLevel {
    let n = level.size;
    let size = (n / 2).max(1);
    let mut cells = vec![FluxCell::default(); size * size];
    for j in 0..n {
        for i in 0..n {
            let (pi, pj) = ((i / 2).min(size - 1), (j / 2).min(size - 1));
            cells[pj * size + pi].add(level.at(i, j));
        }
    }
    FluxLevel { size, cells }
}

/// Every level from `base` up to one cell.
pub fn pyramid(base: FluxLevel) -> Vec<FluxLevel> {
    let mut levels = vec![base];
    while levels.last().is_some_and(|l| l.size > 1) {
        let next = downsample(levels.last().expect("not empty"));
        levels.push(next);
    }
    levels
}

/// Where and what a shaded point gathers.
pub struct Gather<'a> {
    /// The point's place in the light's map, in finest cells (uv x the finest level's size).
    pub at: [f64; 2],
    /// The map's size in finest cells (`size / base_texels` of the light's own map).
    pub cells: f64,
    /// The finest level read (the one whose cells are about `cell_mm` wide at the point).
    pub first: usize,
    /// Cells between the point and the next level (`BounceSettings::ring`).
    pub ring: f64,
    /// A finest cell's area on the surface at the point.
    pub cell_area: f64,
    /// The shaded point.
    pub point: [f64; 3],
    /// The point's unit normal.
    pub normal: [f64; 3],
    /// Where the light is (its squared distances are the cells' `spread`).
    pub light_origin: [f64; 3],
    /// The unit direction toward the light from a cell's mean position.
    pub to_light: &'a dyn Fn([f64; 3]) -> [f64; 3],
    /// The senders' diffuse albedo.
    pub albedo: [f64; 3],
    /// The boundary's reflection (pi f_r N.L) at normal `n`, light `l`, toward `w`.
    pub reflection: &'a dyn Fn([f64; 3], [f64; 3], [f64; 3]) -> f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The irradiance the lit cells send the point, per unit of the light's colour (bounce.wgsl,
/// `bounce_irradiance`, one light).
pub fn gather(levels: &[FluxLevel], g: &Gather) -> [f64; 3] {
    let mut e = [0.0; 3];
    let ring = g.ring;
    for (k, level) in levels.iter().enumerate().skip(g.first) {
        let scale = (1u64 << k) as f64;
        let dim = ((g.cells / scale) as usize).clamp(1, level.size);
        let uk = [g.at[0] / scale, g.at[1] / scale];
        let last = k == levels.len() - 1 || 2.0 * ring * scale >= 1.5 * g.cells;
        let flat = g.cell_area * scale * scale / std::f64::consts::PI;
        for j in 0..dim {
            for i in 0..dim {
                let d = [i as f64 + 0.5 - uk[0], j as f64 + 0.5 - uk[1]];
                let r = (d[0] * d[0] + d[1] * d[1]).sqrt();
                if (k > g.first && r < ring) || (!last && r >= 2.0 * ring) {
                    continue;
                }
                let c = level.at(i, j);
                if c.flux <= 0.0 {
                    continue;
                }
                let x = c.position_sum.map(|v| v / c.flux);
                let off = [0, 1, 2].map(|a| g.point[a] - x[a]);
                let d2 = dot(off, off);
                if d2 <= 0.0 {
                    continue;
                }
                let w = off.map(|v| v / d2.sqrt());
                let cos_p = -dot(g.normal, w);
                if cos_p <= 0.0 {
                    continue;
                }
                let cos_d = dot(c.normal_sum, w).max(0.0);
                let len = dot(c.normal_sum, c.normal_sum).sqrt().max(1e-300);
                let n_s = c.normal_sum.map(|v| v / len);
                let rel = [0, 1, 2].map(|a| x[a] - g.light_origin[a]);
                let spread = (2.0 * (c.spread / c.flux - dot(rel, rel))).max(flat);
                let reflected =
                    c.reflected * (g.reflection)(n_s, (g.to_light)(x), w) * dot(n_s, w).max(0.0);
                let f = cos_p / (std::f64::consts::PI * (d2 + spread));
                for ch in 0..3 {
                    e[ch] += (g.albedo[ch] * cos_d + reflected) * f;
                }
            }
        }
        if last {
            break;
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(x: [f64; 3], flux: f64) -> FluxCell {
        FluxCell {
            position_sum: x.map(|v| v * flux),
            flux,
            normal_sum: [0.0, flux, 0.0],
            reflected: flux,
            spread: flux * dot(x, x),
        }
    }

    /// Every level holds the whole flux, and a parent the sum of its children (odd sides
    /// included).
    #[test]
    fn levels_keep_the_flux() {
        for size in [8usize, 7, 5, 1] {
            let cells = (0..size * size)
                .map(|k| cell([k as f64, 0.0, 1.0], 1.0 + (k % 3) as f64))
                .collect();
            let levels = pyramid(FluxLevel { size, cells });
            let total = |l: &FluxLevel| l.cells.iter().map(|c| c.flux).sum::<f64>();
            let t0 = total(&levels[0]);
            for l in &levels {
                assert!((total(l) - t0).abs() < 1e-9, "size {size}");
            }
            assert_eq!(levels.last().unwrap().size, 1);
        }
        let l = downsample(&FluxLevel {
            size: 2,
            cells: vec![cell([0.0; 3], 1.0); 4],
        });
        assert_eq!(l.cells[0].flux, 4.0);
    }

    /// A wide lit floor seen from a point above it, facing it: the gather gives the disc's
    /// view factor (a lit plane of radiosity B gives B at any height below the horizon, here
    /// the flux per unit area times the albedo), within the pyramid's error.
    #[test]
    fn a_point_facing_a_wide_lit_floor_takes_its_radiosity() {
        // 512 finest cells of 1 mm on a side, each of unit flux per mm^2, at y = 0; the point
        // 20 mm above the centre, facing down. The floor's edge is 256 mm away: the disc of
        // that radius sends 1 - h^2 / (h^2 + R^2) = 0.994 of the plane's.
        let size = 512;
        let cells = (0..size * size)
            .map(|k| {
                let (i, j) = (k % size, k / size);
                let mut c = cell([i as f64 + 0.5 - 256.0, 0.0, j as f64 + 0.5 - 256.0], 1.0);
                // Squared distances from a light 1 m above the centre, as the GPU sums them.
                let x = [i as f64 + 0.5 - 256.0, -1000.0, j as f64 + 0.5 - 256.0];
                c.spread = dot(x, x);
                c
            })
            .collect();
        let levels = pyramid(FluxLevel { size, cells });
        let to_light = |_| [0.0, 1.0, 0.0];
        let none = |_, _, _| 0.0;
        for ring in [2.0, 4.0] {
            let e = gather(
                &levels,
                &Gather {
                    at: [256.0, 256.0],
                    cells: size as f64,
                    first: 0,
                    ring,
                    cell_area: 1.0,
                    point: [0.0, 20.0, 0.0],
                    normal: [0.0, -1.0, 0.0],
                    light_origin: [0.0, 1000.0, 0.0],
                    to_light: &to_light,
                    albedo: [1.0, 0.5, 0.0],
                    reflection: &none,
                },
            );
            // Flux 1 per mm^2 sent on diffusely with albedo 1: radiosity 1.
            let want = 1.0 - 400.0 / (400.0 + 256.0 * 256.0);
            assert!(
                (e[0] / want - 1.0).abs() < 0.1,
                "ring {ring}: {} against {want}",
                e[0]
            );
            assert!((e[1] - 0.5 * e[0]).abs() < 1e-12 && e[2] == 0.0);
        }
    }
}
