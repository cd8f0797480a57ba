//! What `bench` reports: each configuration's run (median pass times, the skin's cost, the
//! memory model), the table, the per-light slopes and the plot.

use std::collections::BTreeMap;

use anyhow::{Context, Result};
use plotters::prelude::*;
use serde::Serialize;
use subsurface_render::{PassTiming, RenderSettings};

use super::memory::Traffic;
use crate::output::PendingFile;
use crate::plot;

#[derive(Serialize)]
pub(super) struct Run {
    pub(super) characters: u32,
    /// Rows of the screen-space profile table (distinct profiles on screen).
    pub(super) profiles: u32,
    /// Lights kept of the scene's (`--lights`).
    pub(super) lights: u32,
    pub(super) width: u32,
    pub(super) height: u32,
    /// The quality preset the settings started from.
    pub(super) quality: &'static str,
    pub(super) sss: &'static str,
    /// How the screen-space passes fetched their texels (`packed`, `workgroup`, `direct`).
    pub(super) fetch: &'static str,
    pub(super) transmittance: String,
    /// Diffusion runs: the lateral shadow-map taps per shadowed light.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) lateral_taps: Option<u32>,
    /// Diffusion runs: the transmitted map's texel size asked for, and the reduction it gave (1:
    /// the taps run at every pixel).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) map_texel_mm: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) map_downsample: Option<u32>,
    /// Diffusion runs: how the transmitted map was evaluated (`compute`, `fragment`; `fragment`
    /// also where the adapter cannot run the compute evaluation).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) map_pass: Option<&'static str>,
    /// The bounce's ring (0: none).
    pub(super) bounce_ring: u32,
    /// The keys `--vary` (and the method flags) varied, with this run's values.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub(super) varied: BTreeMap<String, String>,
    /// Median frame time (sum of the passes, copy baseline excluded).
    pub(super) frame_ms: f64,
    /// `--rounds`: each round's median frame time, in the order they ran.
    pub(super) round_frame_ms: Vec<f64>,
    pub(super) passes: Vec<PassTiming>,
    /// Where the same scene's frame without any skin effect was measured.
    #[serde(flatten)]
    pub(super) skin: Option<SkinCost>,
    /// A plain full-screen copy of the diffuse target, measured in the same frames.
    pub(super) copy_ms: f64,
    /// GPU time of the subsurface-scattering passes divided by the copy's.
    pub(super) sss_over_copy: Option<f64>,
    /// Separable taps and whether they were jittered.
    pub(super) samples: u32,
    pub(super) jitter: bool,
    /// With `--flip-vs`, separable runs only.
    #[serde(flatten)]
    pub(super) flip: Option<FlipVsFixed>,
    /// Bytes the modelled passes must move (passes::traffic), with the measured time.
    pub(super) traffic: Vec<Traffic>,
}

/// The skin's cost: the frame less the same scene's frame without any skin effect (no
/// scattering, transmittance or bounce), measured in the same rounds; and that as a share of
/// the frame without them.
#[derive(Serialize)]
pub(super) struct SkinCost {
    pub(super) skin_ms: f64,
    pub(super) skin_share: f64,
}

/// FLIP mean of the frame against the `--flip-vs` fixed-tap frame: over the whole frame, and
/// over the skin pixels only (where SSS changes anything; None without skin pixels).
#[derive(Serialize)]
pub(super) struct FlipVsFixed {
    pub(super) flip_vs_fixed: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) flip_vs_fixed_skin: Option<f64>,
}

impl Run {
    /// The transmittance as the table names it: `diffusion/12:4` for diffusion with 12 lateral
    /// taps once per 4x4 pixels, so that `--lateral-taps 0,12` shows two rows.
    pub(super) fn transmittance_label(&self) -> String {
        let label = match (self.lateral_taps, self.map_downsample) {
            (Some(taps), Some(d)) => format!("{}/{taps}:{d}", self.transmittance),
            (Some(taps), None) => format!("{}/{taps}", self.transmittance),
            _ => self.transmittance.clone(),
        };
        let label = match self.map_pass {
            Some("fragment") => format!("{label} frag"),
            _ => label,
        };
        let label = match self.bounce_ring {
            0 => label,
            ring => format!("{label} b{ring}"),
        };
        // The varied keys the columns do not already show.
        let shown = [
            "quality",
            "sss.method",
            "sss.fetch",
            "transmittance.method",
            "transmittance.lateral_taps",
            "transmitted_map.texel_mm",
            "transmitted_map.pass",
            "bounce.ring",
        ];
        let label = self
            .varied
            .iter()
            .filter(|(k, _)| !shown.contains(&k.as_str()))
            .fold(label, |l, (k, v)| format!("{l} {k}={v}"));
        if self.varied.contains_key("quality") {
            format!("{} {label}", self.quality)
        } else {
            label
        }
    }
}

#[derive(Serialize)]
pub(super) struct Report {
    pub(super) adapter: String,
    pub(super) warmup: u32,
    pub(super) frames: u32,
    pub(super) rounds: u32,
    /// `--bandwidth`, GB/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) bandwidth_gbps: Option<f64>,
    /// `--flip-vs`: the fixed-tap count the FLIP figures compare with.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) flip_vs: Option<u32>,
    pub(super) runs: Vec<Run>,
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Passes that belong to subsurface scattering (screen or texture space).
pub(super) fn is_sss_pass(name: &str) -> bool {
    name == "sss" || name.starts_with("texture")
}

/// GPU time of the subsurface-scattering passes among `passes`.
pub(super) fn sss_ms(passes: &[PassTiming]) -> f64 {
    // A fold from +0.0, not `sum` (which starts at -0.0): no SSS pass prints as 0.000.
    passes
        .iter()
        .filter(|p| is_sss_pass(&p.name))
        .map(|p| p.ms)
        .fold(0.0, |a, b| a + b)
}

/// A frame's GPU time: its passes, the copy baseline left out.
pub(super) fn frame_sum(frame: &[PassTiming]) -> f64 {
    frame
        .iter()
        .filter(|t| t.name != "copy")
        .map(|t| t.ms)
        .sum()
}

/// The run of `samples` (each frame's passes) of `characters` copies rendered with `s`.
pub(super) fn summarise(samples: Vec<Vec<PassTiming>>, characters: u32, s: &RenderSettings) -> Run {
    let mut names: Vec<String> = Vec::new();
    for t in samples.iter().flatten() {
        if !names.contains(&t.name) {
            names.push(t.name.clone());
        }
    }
    let per_pass = |name: &str| {
        median(
            samples
                .iter()
                .map(|f| f.iter().filter(|t| t.name == name).map(|t| t.ms).sum())
                .collect(),
        )
    };
    let copy_ms = per_pass("copy");
    let passes: Vec<PassTiming> = names
        .iter()
        .filter(|n| n.as_str() != "copy")
        .map(|n| PassTiming {
            name: n.clone(),
            ms: per_pass(n),
        })
        .collect();
    let frame_ms = median(samples.iter().map(|f| frame_sum(f)).collect());
    let sss_ms = sss_ms(&passes);
    Run {
        characters,
        profiles: 1,
        lights: 0,
        width: s.width,
        height: s.height,
        quality: s.quality.name(),
        sss: s.sss.method.name(),
        fetch: s.sss.fetch.name(),
        transmittance: s.transmittance.method.name().to_string(),
        lateral_taps: None,
        map_texel_mm: None,
        map_downsample: None,
        map_pass: None,
        bounce_ring: s.bounce.ring,
        varied: BTreeMap::new(),
        frame_ms,
        round_frame_ms: Vec::new(),
        passes,
        skin: None,
        copy_ms,
        sss_over_copy: (sss_ms > 0.0 && copy_ms > 0.0).then(|| sss_ms / copy_ms),
        samples: s.sss.samples,
        jitter: s.sss.jitter,
        flip: None,
        traffic: Vec::new(),
    }
}

pub(super) fn table(report: &Report) -> String {
    let mut out = if report.rounds > 1 {
        format!(
            "{} — median of {} rounds x {} frames, each after {} warm-up, configurations in turn\n",
            report.adapter, report.rounds, report.frames, report.warmup
        )
    } else {
        format!(
            "{} — median of {} frames after {} warm-up\n",
            report.adapter, report.frames, report.warmup
        )
    };
    out += &format!(
        "{:>5} {:>8} {:>6} {:>10} {:>10} {:>9} {:>17} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}\n",
        "chars",
        "profiles",
        "lights",
        "size",
        "sss",
        "fetch",
        "transm.",
        "frame ms",
        "shadow",
        "map",
        "bounce",
        "lighting",
        "sss ms",
        "sss/copy",
        "skin ms",
        "skin %"
    );
    for r in &report.runs {
        let p = |n: &str| r.passes.iter().find(|p| p.name == n).map_or(0.0, |p| p.ms);
        let sss = sss_ms(&r.passes);
        out += &format!(
            "{:>5} {:>8} {:>6} {:>10} {:>10} {:>9} {:>17} {:>10.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9} {:>9} {:>7}\n",
            r.characters,
            r.profiles,
            r.lights,
            format!("{}x{}", r.width, r.height),
            r.sss,
            r.fetch,
            r.transmittance_label(),
            r.frame_ms,
            p("shadow"),
            p("transmitted"),
            p("bounce build") + p("bounce"),
            p("lighting"),
            sss,
            r.sss_over_copy.map_or("-".into(), |x| format!("{x:.2}")),
            r.skin
                .as_ref()
                .map_or("-".into(), |c| format!("{:.3}", c.skin_ms)),
            r.skin
                .as_ref()
                .map_or("-".into(), |c| format!("{:.1}", 100.0 * c.skin_share)),
        );
    }
    if let Some(n) = report.flip_vs {
        out += &format!("\nFLIP mean of the frame against {n} fixed taps (separable runs)\n");
        for (r, flip) in report
            .runs
            .iter()
            .filter_map(|r| r.flip.as_ref().map(|f| (r, f)))
        {
            out += &format!(
                "{:>10} {} taps{}: {:.4} (skin pixels: {})\n",
                format!("{}x{}", r.width, r.height),
                r.samples,
                if r.jitter { " jittered" } else { "" },
                flip.flip_vs_fixed,
                flip.flip_vs_fixed_skin
                    .map_or("-".into(), |f| format!("{f:.4}"))
            );
        }
    }
    out + &per_light(report) + &traffic_table(report)
}

/// With several `--lights` counts: the lighting and shadow passes' cost per light, the slope
/// between the fewest and the most lights of runs that differ in nothing else.
fn per_light(report: &Report) -> String {
    let mut out = String::new();
    let same = |a: &Run, b: &Run| {
        (a.characters, a.profiles, a.width, a.height, a.sss, a.fetch)
            == (b.characters, b.profiles, b.width, b.height, b.sss, b.fetch)
            && (
                &a.transmittance,
                a.lateral_taps,
                a.map_downsample,
                a.bounce_ring,
                &a.varied,
            ) == (
                &b.transmittance,
                b.lateral_taps,
                b.map_downsample,
                b.bounce_ring,
                &b.varied,
            )
    };
    let pass = |r: &Run, n: &str| r.passes.iter().find(|p| p.name == n).map_or(0.0, |p| p.ms);
    for (i, r) in report.runs.iter().enumerate() {
        // Each group once, from its first run.
        if report.runs[..i].iter().any(|o| same(o, r)) {
            continue;
        }
        let group: Vec<&Run> = report.runs.iter().filter(|o| same(o, r)).collect();
        let fewest = group
            .iter()
            .min_by_key(|r| r.lights)
            .expect("r is in its group");
        let most = group
            .iter()
            .max_by_key(|r| r.lights)
            .expect("r is in its group");
        if fewest.lights == most.lights {
            continue;
        }
        if out.is_empty() {
            out += "\ncost per light (slope between the fewest and the most lights)\n";
        }
        let k = f64::from(most.lights - fewest.lights);
        let slope = |n: &str| (pass(most, n) - pass(fewest, n)) / k;
        out += &format!(
            "{:>10} {:>10} {:>10} lights {}..{}: lighting {:.3} ms, shadow {:.3} ms per light\n",
            format!("{}x{}", r.width, r.height),
            r.sss,
            r.transmittance_label(),
            fewest.lights,
            most.lights,
            slope("lighting"),
            slope("shadow"),
        );
    }
    out
}

const PLOT_SIZE: (u32, u32) = (900, 560);

/// Frame time (solid) and SSS time (dashed) against the number of characters, per method.
pub(super) fn plot(pending: PendingFile, report: &Report) -> Result<()> {
    let img = plot::draw_image(PLOT_SIZE, |root| draw(root, report)).context("--plot")?;
    pending.write_png(&image::DynamicImage::ImageRgb8(img).to_rgba8())
}

fn draw(root: &plot::Area, report: &Report) -> plot::DrawResult {
    let max_n = report
        .runs
        .iter()
        .map(|r| r.characters)
        .max()
        .unwrap_or(1)
        .max(2) as f64;
    let max_ms = report
        .runs
        .iter()
        .map(|r| r.frame_ms)
        .fold(0.0, f64::max)
        .max(1e-3)
        * 1.1;
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("GPU time vs characters — {}", report.adapter),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_n * 1.05, 0.0..max_ms)?;
    chart
        .configure_mesh()
        .x_desc("characters")
        .y_desc("ms (solid: frame, dashed: SSS)")
        .draw()?;
    let mut keys: Vec<(&str, String, u32, u32)> = Vec::new();
    for r in &report.runs {
        let k = (r.sss, r.transmittance_label(), r.width, r.height);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (i, (sss, tm, w, h)) in keys.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let pts: Vec<&Run> = report
            .runs
            .iter()
            .filter(|r| {
                r.sss == *sss && &r.transmittance_label() == tm && r.width == *w && r.height == *h
            })
            .collect();
        let frame = pts.iter().map(|r| (r.characters as f64, r.frame_ms));
        plot::line(&mut chart, frame, colour, format!("{sss} {tm} {w}x{h}"))?;
        let sss = pts.iter().map(|r| (r.characters as f64, sss_ms(&r.passes)));
        plot::dashed(&mut chart, sss, colour, (6, 4))?;
    }
    // plotters' default size for legend text.
    plot::legend(&mut chart, 12)
}

/// The byte-model table: per run and modelled pass, the bytes, the measured time and (with
/// --bandwidth) its ratio to the memory bound.
fn traffic_table(report: &Report) -> String {
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
                t.bound
                    .as_ref()
                    .map_or("-".into(), |b| format!("{:.3}", b.bound_ms)),
                t.bound
                    .as_ref()
                    .and_then(|b| b.over_bound)
                    .map_or("-".into(), |x| format!("{x:.1}")),
            );
        }
    }
    if let Some(g) = report.bandwidth_gbps {
        out += &format!("bound: compulsory bytes at --bandwidth {g} GB/s\n");
    }
    out
}
