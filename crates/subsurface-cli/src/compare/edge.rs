//! The knife-edge measurement (docs/lab/fidelity.md): the image averaged along a straight shadow
//! edge, per channel, and its 10-90 % rise distance in millimetres of skin. Averaging along
//! the edge, where nothing changes, leaves a curve smooth enough to judge a blur's width
//! against a noisy path-traced reference, which pixel errors and region means cannot.

use serde::{Deserialize, Serialize};

use crate::plot;

/// Where the edge is: a rectangle (normalised image coordinates, origin top left) that the
/// edge crosses from side to side, and the direction across it.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeSpec {
    /// [x0, y0, x1, y1]
    pub rect: [f32; 4],
    /// `"y"`: a horizontal edge, the curve runs down the rows (each row averaged along x);
    /// `"x"`: a vertical edge, the curve runs along the columns.
    pub across: Axis,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
}

/// The edge's curves and widths, real-time and reference.
#[derive(Debug, Clone, Serialize)]
pub struct EdgeResult {
    /// Millimetres of skin per pixel in the plane of the camera's target.
    pub mm_per_pixel: f32,
    /// Position of each curve sample across the edge, mm from the rectangle's first row or
    /// column.
    pub position_mm: Vec<f32>,
    /// Mean radiance along the edge at each position, per channel.
    pub realtime: Vec<[f32; 3]>,
    pub reference: Vec<[f32; 3]>,
    /// 10-90 % rise distance per channel, mm.
    pub edge_width_mm: [f32; 3],
    pub edge_width_mm_reference: [f32; 3],
    /// (ours - reference) / reference of the rise distance, per channel.
    pub edge_width_rel_error: [f32; 3],
}

/// Mean of `image` along the edge at each position across it.
pub fn edge_curve(image: &[[f32; 3]], w: u32, h: u32, spec: &EdgeSpec) -> Vec<[f32; 3]> {
    let [x0, y0, x1, y1] = spec.rect;
    let xs = (x0 * w as f32) as u32..((x1 * w as f32).ceil() as u32).min(w);
    let ys = (y0 * h as f32) as u32..((y1 * h as f32).ceil() as u32).min(h);
    let (across, along) = match spec.across {
        Axis::Y => (ys, xs),
        Axis::X => (xs, ys),
    };
    across
        .map(|a| {
            let mut sum = [0.0f64; 3];
            for b in along.clone() {
                let (x, y) = match spec.across {
                    Axis::Y => (b, a),
                    Axis::X => (a, b),
                };
                for c in 0..3 {
                    sum[c] += f64::from(image[(y * w + x) as usize][c]);
                }
            }
            sum.map(|v| (v / along.len().max(1) as f64) as f32)
        })
        .collect()
}

/// 10-90 % rise distance of one channel of a step-like curve, in samples. The plateaus are
/// the means of the first and last eighth of the curve; each crossing position is the count
/// of samples below the level, softened over +-5 % of the step, so that a noisy reference
/// (a curve that crosses a level more than once) gives the mean position rather than the
/// first crossing. Exact for a monotone curve, up to the softening.
pub fn rise_samples(curve: &[f32]) -> f32 {
    let n = curve.len();
    let k = (n / 8).max(1);
    let mean = |s: &[f32]| s.iter().sum::<f32>() / s.len() as f32;
    let (a, b) = (mean(&curve[..k]), mean(&curve[n - k..]));
    let (lo, hi) = (a.min(b), a.max(b));
    if hi - lo <= 0.0 || !(hi - lo).is_finite() {
        return f32::NAN;
    }
    let below = |level: f32| -> f32 {
        curve
            .iter()
            .map(|v| {
                let t = (v - lo) / (hi - lo);
                ((level + 0.05 - t) / 0.1).clamp(0.0, 1.0)
            })
            .sum()
    };
    (below(0.9) - below(0.1)).abs()
}

/// Both curves and their widths; `mm_per_pixel` converts samples to millimetres.
pub fn measure(
    ours: &[[f32; 3]],
    reference: &[[f32; 3]],
    w: u32,
    h: u32,
    spec: &EdgeSpec,
    mm_per_pixel: f32,
) -> EdgeResult {
    let realtime = edge_curve(ours, w, h, spec);
    let refc = edge_curve(reference, w, h, spec);
    let width = |curve: &[[f32; 3]]| -> [f32; 3] {
        std::array::from_fn(|c| {
            let ch: Vec<f32> = curve.iter().map(|v| v[c]).collect();
            rise_samples(&ch) * mm_per_pixel
        })
    };
    let (ours_w, ref_w) = (width(&realtime), width(&refc));
    EdgeResult {
        mm_per_pixel,
        position_mm: (0..realtime.len())
            .map(|i| (i as f32 + 0.5) * mm_per_pixel)
            .collect(),
        realtime,
        reference: refc,
        edge_width_mm: ours_w,
        edge_width_mm_reference: ref_w,
        edge_width_rel_error: std::array::from_fn(|c| (ours_w[c] - ref_w[c]) / ref_w[c]),
    }
}

/// The curves across the edge: real-time solid, reference dashed, one colour per channel,
/// each channel divided by the reference's bright plateau so that all three share one axis.
pub fn draw(root: &plot::Area, e: &EdgeResult, title: &str) -> plot::DrawResult {
    let x_max = f64::from(e.position_mm.last().copied().unwrap_or(1.0)) + 0.5;
    let n = e.reference.len();
    let k = (n / 8).max(1);
    let plateau: [f64; 3] = std::array::from_fn(|c| {
        let ends = [&e.reference[..k], &e.reference[n - k..]];
        ends.map(|s| s.iter().map(|v| f64::from(v[c])).sum::<f64>() / k as f64)
            .into_iter()
            .fold(1e-12, f64::max)
    });
    let mut chart =
        plot::chart_builder(root, title, 60).build_cartesian_2d(0.0..x_max, -0.05..1.25)?;
    let (x_desc, y_desc) = (
        "position across the edge (mm)",
        "radiance / reference's lit plateau",
    );
    plot::axes(&mut chart, x_desc, y_desc, false)?;
    for (c, color) in plot::CHANNEL_COLORS.into_iter().enumerate() {
        let pts = |curve: &[[f32; 3]]| -> Vec<(f64, f64)> {
            e.position_mm
                .iter()
                .zip(curve)
                .map(|(x, v)| (f64::from(*x), f64::from(v[c]) / plateau[c]))
                .collect()
        };
        let label = format!(
            "{} real-time {:.2} mm (reference {:.2} mm, dashed)",
            plot::CHANNEL_NAMES[c],
            e.edge_width_mm[c],
            e.edge_width_mm_reference[c]
        );
        plot::line(&mut chart, pts(&e.realtime), color, label)?;
        plot::dashed(&mut chart, pts(&e.reference), color, (8, 5))?;
    }
    plot::legend(&mut chart, 14)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_ramp_rises_over_80_percent_of_its_length() {
        // 0 for 20 samples, a ramp over 40, 1 for 20: 10-90 % spans 32 samples.
        let c: Vec<f32> = (0..80)
            .map(|i| ((i as f32 - 20.0 + 0.5) / 40.0).clamp(0.0, 1.0))
            .collect();
        let r = rise_samples(&c);
        assert!((r - 32.0).abs() < 0.6, "{r}");
        // Falling instead of rising, or scaled and offset: the same width.
        let f: Vec<f32> = c.iter().rev().map(|v| 3.0 * v + 2.0).collect();
        assert!((rise_samples(&f) - r).abs() < 1e-3);
        // A hard step: about one sample.
        let s: Vec<f32> = (0..80).map(|i| if i < 40 { 0.0 } else { 1.0 }).collect();
        assert!(rise_samples(&s) < 1.5);
        assert!(rise_samples(&[1.0; 16]).is_nan());
    }

    #[test]
    fn noise_that_crosses_a_level_twice_does_not_move_the_width() {
        let c: Vec<f32> = (0..80)
            .map(|i| ((i as f32 - 20.0 + 0.5) / 40.0).clamp(0.0, 1.0))
            .collect();
        let mut noisy = c.clone();
        // A spike above the 90 % level on the dark side, balanced by a dip after it.
        noisy[10] = 0.95;
        noisy[11] = -0.95;
        let (a, b) = (rise_samples(&c), rise_samples(&noisy));
        assert!((a - b).abs() < 1.1, "{a} vs {b}");
    }

    #[test]
    fn the_curve_averages_along_the_edge() {
        // 4x4 image, a horizontal edge between rows 1 and 2; columns differ by noise.
        let img: Vec<[f32; 3]> = (0..16)
            .map(|i| {
                let (x, y) = (i % 4, i / 4);
                let v = if y >= 2 { 1.0 } else { 0.0 } + if x % 2 == 0 { 0.1 } else { -0.1 };
                [v, 2.0 * v, 0.0]
            })
            .collect();
        let spec = EdgeSpec {
            rect: [0.0, 0.0, 1.0, 1.0],
            across: Axis::Y,
        };
        let c = edge_curve(&img, 4, 4, &spec);
        assert_eq!(c.len(), 4);
        for (y, v) in c.iter().enumerate() {
            let want = if y >= 2 { 1.0 } else { 0.0 };
            assert!((v[0] - want).abs() < 1e-6 && (v[1] - 2.0 * want).abs() < 1e-6);
        }
        let along_x = edge_curve(
            &img,
            4,
            4,
            &EdgeSpec {
                across: Axis::X,
                ..spec
            },
        );
        assert!(along_x.iter().all(|v| (v[0] - 0.5).abs() < 0.11));
    }
}
