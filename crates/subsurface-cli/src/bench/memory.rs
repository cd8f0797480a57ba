//! `bench`'s memory-bound figures: the byte model of each modelled pass (passes::traffic)
//! beside its measured time, and the FLIP of the few-sample mode against more fixed taps.

use serde::Serialize;
use subsurface_render::passes::traffic::{self, PassTraffic};

/// One pass's byte model at the run's size beside its measured time.
#[derive(Serialize)]
pub(super) struct Traffic {
    #[serde(flatten)]
    pub(super) model: PassTraffic,
    pub(super) ms: f64,
    /// With `--bandwidth` only.
    #[serde(flatten)]
    pub(super) bound: Option<MemoryBound>,
}

/// A pass's time against the memory limit at `--bandwidth`.
#[derive(Serialize)]
pub(super) struct MemoryBound {
    /// Time the compulsory bytes take at that rate.
    pub(super) bound_ms: f64,
    /// `ms / bound_ms`: how many times the memory limit the pass takes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) over_bound: Option<f64>,
}

/// The byte models of a `w` x `h` frame's modelled passes (screen-space SSS with `sss` and
/// whether its workgroup fetch packs on load, the baseline copy) with their measured times
/// (`[sss, copy]` ms) and, given a bandwidth, the ratio to the memory bound.
pub(super) fn traffic_of(
    (w, h): (u32, u32),
    (sss, pack_on_load): (&subsurface_render::SssSettings, bool),
    [sss_ms, copy_ms]: [f64; 2],
    gbps: Option<f64>,
) -> Vec<Traffic> {
    let models = traffic::sss_traffic(sss, pack_on_load, w, h)
        .into_iter()
        .map(|m| (m, sss_ms))
        .chain([(traffic::copy_traffic(w, h), copy_ms)]);
    models
        .map(|(model, ms)| {
            let bound = gbps.map(|g| {
                let bound_ms = model.bound_ms(g);
                MemoryBound {
                    bound_ms,
                    over_bound: (bound_ms > 0.0 && ms > 0.0).then(|| ms / bound_ms),
                }
            });
            Traffic { model, ms, bound }
        })
        .collect()
}

/// FLIP mean (LDR) of `test` against `reference`: over all pixels, and over those marked in
/// `skin` (None if there are none).
pub(super) fn flip_means(
    reference: &image::RgbaImage,
    test: &image::RgbaImage,
    skin: &[bool],
) -> (f64, Option<f64>) {
    let rgb = |i: &image::RgbaImage| image::DynamicImage::ImageRgba8(i.clone()).to_rgb8();
    let e = crate::compare::flip::flip(&rgb(reference), &rgb(test));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let all: Vec<f64> = e.iter().map(|v| f64::from(*v)).collect();
    let on_skin: Vec<f64> = all
        .iter()
        .zip(skin)
        .filter(|(_, s)| **s)
        .map(|(v, _)| *v)
        .collect();
    (mean(&all), (!on_skin.is_empty()).then(|| mean(&on_skin)))
}
