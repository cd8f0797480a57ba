//! Transmittance against thickness (docs/lab/fidelity.md): the pixels of a backlit scene binned
//! by the thickness the light crosses to reach them, real-time and reference averaged per bin
//! and channel. Binning along lines of constant thickness (the wedge's columns) averages the
//! path tracer's noise away where a pixel comparison would drown in it, and the thickness
//! comes from the renderer's own shadow maps (`--view thickness`), so any backlit scene can
//! be measured, not only the wedge.

use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use crate::plot;

/// Which pixels and how finely: a rectangle (normalised, origin top left) and the bin width.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ThicknessSpec {
    /// [x0, y0, x1, y1]
    pub rect: [f32; 4],
    /// Bin width, profile millimetres (> 0).
    pub bin_mm: f32,
    /// Thickest bin edge, profile millimetres (> bin_mm).
    pub max_mm: f32,
}

/// One bin: its centre, how many pixels, and both means.
#[derive(Debug, Clone, Serialize)]
pub struct ThicknessBin {
    pub thickness_mm: f32,
    pub pixels: usize,
    pub realtime: [f32; 3],
    pub reference: [f32; 3],
    /// (ours - reference) / reference per channel.
    pub rel_error: [f32; 3],
    /// Per channel: the reference here is above 1 % of its value in the thinnest bin, where
    /// the target applies (below, what is left is the reference's noise floor).
    pub significant: [bool; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct ThicknessResult {
    pub bins: Vec<ThicknessBin>,
    /// Largest |rel_error| over the significant bins, per channel.
    pub max_abs_rel_error: [f32; 3],
}

/// Bins the pixels of `rect` whose thickness is known (>= 0) and in range.
pub fn measure(
    ours: &[[f32; 3]],
    reference: &[[f32; 3]],
    thickness_mm: &[f32],
    w: u32,
    h: u32,
    spec: &ThicknessSpec,
) -> ThicknessResult {
    let n = (spec.max_mm / spec.bin_mm).ceil().max(1.0) as usize;
    let mut sums = vec![([0.0f64; 3], [0.0f64; 3], 0usize); n];
    let [x0, y0, x1, y1] = spec.rect;
    for y in (y0 * h as f32) as u32..((y1 * h as f32).ceil() as u32).min(h) {
        for x in (x0 * w as f32) as u32..((x1 * w as f32).ceil() as u32).min(w) {
            let i = (y * w + x) as usize;
            let s = thickness_mm[i];
            if !(s >= 0.0 && s < spec.max_mm) {
                continue;
            }
            let b = &mut sums[((s / spec.bin_mm) as usize).min(n - 1)];
            for c in 0..3 {
                b.0[c] += f64::from(ours[i][c]);
                b.1[c] += f64::from(reference[i][c]);
            }
            b.2 += 1;
        }
    }
    let mut bins: Vec<ThicknessBin> = sums
        .iter()
        .enumerate()
        .filter(|(_, b)| b.2 > 0)
        .map(|(i, (a, r, k))| {
            let (a, r) = (
                a.map(|v| (v / *k as f64) as f32),
                r.map(|v| (v / *k as f64) as f32),
            );
            ThicknessBin {
                thickness_mm: (i as f32 + 0.5) * spec.bin_mm,
                pixels: *k,
                realtime: a,
                reference: r,
                rel_error: std::array::from_fn(|c| (a[c] - r[c]) / r[c]),
                significant: [false; 3],
            }
        })
        .collect();
    let thinnest = bins.first().map_or([0.0; 3], |b| b.reference);
    let mut max_abs = [0.0f32; 3];
    for b in &mut bins {
        for c in 0..3 {
            b.significant[c] = b.reference[c] > 0.01 * thinnest[c] && b.reference[c] > 0.0;
            if b.significant[c] {
                max_abs[c] = max_abs[c].max(b.rel_error[c].abs());
            }
        }
    }
    ThicknessResult {
        bins,
        max_abs_rel_error: max_abs,
    }
}

impl ThicknessResult {
    /// The significant bin of channel `c` with the largest |rel_error|: its thickness and its
    /// signed error (the legend says which way and where, not only how far).
    pub fn worst(&self, c: usize) -> Option<(f32, f32)> {
        self.bins
            .iter()
            .filter(|b| b.significant[c])
            .map(|b| (b.thickness_mm, b.rel_error[c]))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    }
}

/// Radiance against thickness on a log axis: real-time solid, reference dashed.
pub fn draw(root: &plot::Area, t: &ThicknessResult, title: &str) -> plot::DrawResult {
    let x_max = t.bins.last().map_or(1.0, |b| f64::from(b.thickness_mm)) + 0.5;
    let all = || {
        t.bins
            .iter()
            .flat_map(|b| b.realtime.iter().chain(&b.reference))
            .map(|v| f64::from(*v))
    };
    let y_max = all().fold(1e-9, f64::max) * 2.0;
    let y_min = (all().filter(|v| *v > 0.0).fold(y_max, f64::min) * 0.5).max(y_max * 1e-6);
    let mut chart = plot::chart_builder(root, title, 70)
        .build_cartesian_2d(0.0..x_max, (y_min..y_max).log_scale())?;
    let x_desc = "thickness the light crosses (mm)";
    plot::axes(&mut chart, x_desc, "mean radiance", true)?;
    for (c, color) in plot::CHANNEL_COLORS.into_iter().enumerate() {
        let pts = |f: fn(&ThicknessBin) -> [f32; 3]| -> Vec<(f64, f64)> {
            t.bins
                .iter()
                .map(|b| (f64::from(b.thickness_mm), f64::from(f(b)[c]).max(y_min)))
                .collect()
        };
        let worst = t.worst(c).map_or_else(String::new, |(mm, e)| {
            format!(": worst {:+.0}% at {mm:.1} mm", 100.0 * e)
        });
        let label = format!(
            "{} real-time (reference dashed){worst}",
            plot::CHANNEL_NAMES[c]
        );
        plot::line(&mut chart, pts(|b| b.realtime), color, label)?;
        plot::dashed(&mut chart, pts(|b| b.reference), color, (8, 5))?;
    }
    plot::legend(&mut chart, 14)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixels_are_binned_by_thickness_and_thin_noise_is_left_out() {
        // 4 pixels: 0.5 mm (twice), 1.5 mm, and unknown (-1).
        let s = [0.5, 0.5, 1.5, -1.0];
        let ours = [
            [1.0, 1.0, 1.0],
            [3.0, 3.0, 3.0],
            [0.5, 0.005, 0.5],
            [9.0; 3],
        ];
        let reference = [[2.0, 2.0, 2.0], [2.0, 2.0, 2.0], [1.0, 0.01, 0.0], [1.0; 3]];
        let spec = ThicknessSpec {
            rect: [0.0, 0.0, 1.0, 1.0],
            bin_mm: 1.0,
            max_mm: 4.0,
        };
        let t = measure(&ours, &reference, &s, 2, 2, &spec);
        assert_eq!(t.bins.len(), 2);
        assert_eq!((t.bins[0].pixels, t.bins[1].pixels), (2, 1));
        assert_eq!(t.bins[0].realtime, [2.0; 3]);
        assert_eq!(t.bins[1].rel_error[0], -0.5);
        // Green at 1.5 mm is 0.5 % of the thinnest bin: not significant; blue is zero.
        assert_eq!(t.bins[1].significant, [true, false, false]);
        assert_eq!(t.max_abs_rel_error, [0.5, 0.0, 0.0]);
        // The legend's worst bin keeps its sign and says where it is.
        assert_eq!(t.worst(0), Some((1.5, -0.5)));
        assert_eq!(t.worst(1), Some((0.5, 0.0)));
        assert_eq!(t.worst(2), Some((0.5, 0.0)));
    }
}
