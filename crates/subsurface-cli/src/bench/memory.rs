//! `bench`'s memory-bound figures: the byte model of each modelled pass (passes::traffic)
//! beside its measured time, and the FLIP of the few-sample mode against more fixed taps.

use serde::Serialize;
use subsurface_render::passes::traffic::{self, PassTraffic};

use super::{Report, Run, sss_ms};

/// One pass's byte model at the run's size beside its measured time.
#[derive(Serialize)]
pub(super) struct Traffic {
    #[serde(flatten)]
    model: PassTraffic,
    ms: f64,
    /// Time the compulsory bytes take at `--bandwidth`.
    #[serde(skip_serializing_if = "Option::is_none")]
    bound_ms: Option<f64>,
    /// `ms / bound_ms`: how many times the memory limit the pass takes.
    #[serde(skip_serializing_if = "Option::is_none")]
    over_bound: Option<f64>,
}

/// The byte models of the run's modelled passes (screen-space SSS, the baseline copy) with
/// their measured times and, given a bandwidth, the ratio to the memory bound.
pub(super) fn traffic_of(
    run: &Run,
    sss: &subsurface_render::SssSettings,
    gbps: Option<f64>,
) -> Vec<Traffic> {
    let (w, h) = (run.width, run.height);
    let models = traffic::sss_traffic(sss, w, h)
        .into_iter()
        .map(|m| (m, sss_ms(&run.passes)))
        .chain([(traffic::copy_traffic(w, h), run.copy_ms)]);
    models
        .map(|(model, ms)| {
            let bound_ms = gbps.map(|g| model.bound_ms(g));
            Traffic {
                over_bound: bound_ms.filter(|b| *b > 0.0 && ms > 0.0).map(|b| ms / b),
                model,
                ms,
                bound_ms,
            }
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

/// The byte-model table: per run and modelled pass, the bytes, the measured time and (with
/// --bandwidth) its ratio to the memory bound.
pub(super) fn traffic_table(report: &Report) -> String {
    let mut out = String::from(
        "\nmemory traffic (compulsory: each input texel read once, each output texel written \
         once; per tap: every texel each tap filters, no cache)\n",
    );
    out += &format!(
        "{:>10} {:>10} {:>9} {:>7} {:>6} {:>9} {:>9} {:>11} {:>9} {:>9} {:>8}\n",
        "size",
        "sss",
        "fetch",
        "jitter",
        "pass",
        "read MB",
        "write MB",
        "per-tap MB",
        "ms",
        "bound ms",
        "x bound"
    );
    let mb = |b: u64| b as f64 / 1e6;
    for r in &report.runs {
        for t in &r.traffic {
            out += &format!(
                "{:>10} {:>10} {:>9} {:>7} {:>6} {:>9.1} {:>9.1} {:>11.1} {:>9.3} {:>9} {:>8}\n",
                format!("{}x{}", r.width, r.height),
                r.sss,
                r.fetch,
                if r.jitter { "yes" } else { "no" },
                t.model.name,
                mb(t.model.read_bytes),
                mb(t.model.write_bytes),
                mb(t.model.read_bytes_per_tap + t.model.write_bytes),
                t.ms,
                t.bound_ms.map_or("-".into(), |b| format!("{b:.3}")),
                t.over_bound.map_or("-".into(), |x| format!("{x:.1}")),
            );
        }
    }
    if let Some(g) = report.bandwidth_gbps {
        out += &format!("bound: compulsory bytes at --bandwidth {g} GB/s\n");
    }
    out
}
