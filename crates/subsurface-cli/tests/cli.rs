//! The `subsurface` binary as users run it: outputs, JSON shapes, and one-line errors with a
//! non-zero exit and no partial file for bad input.

use crate::common;

use std::process::Output;

use common::{run_with_gpu, subsurface, tempdir};

fn stderr_line(out: &Output) -> String {
    let s = String::from_utf8_lossy(&out.stderr).to_string();
    // lavapipe itself prints "error: XDG_RUNTIME_DIR is invalid" without a display; not ours.
    let lines: Vec<&str> = s
        .lines()
        .filter(|l| l.starts_with("error") && !l.contains("XDG_RUNTIME_DIR"))
        .collect();
    assert_eq!(lines.len(), 1, "expected one error line, got: {s}");
    assert!(!s.contains("panicked") && !s.contains("backtrace"), "{s}");
    lines[0].to_string()
}

#[test]
fn render_writes_a_png_and_a_summary_line() {
    let args = [
        "render", "--width", "96", "--height", "64", "--out", "hand.png",
    ];
    let Some((dir, out)) = run_with_gpu("render", &args) else {
        return;
    };
    let img = image::open(dir.join("hand.png")).unwrap();
    assert_eq!((img.width(), img.height()), (96, 64));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("96x64") && stdout.contains("total"),
        "{stdout}"
    );
}

#[test]
fn bad_input_is_one_line_nonzero_and_leaves_no_file() {
    let dir = tempdir("bad");
    std::fs::write(
        dir.join("bad.toml"),
        "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\nbogus = 1\n",
    )
    .unwrap();
    std::fs::write(dir.join("corrupt.glb"), b"not a glb").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &["render", "missing.toml", "--out", "o.png"],
            "missing.toml",
        ),
        (&["render", "bad.toml", "--out", "o.png"], "bogus"),
        (
            &["render", "--model", "corrupt.glb", "--out", "o.png"],
            "corrupt.glb",
        ),
        (&["render", "--width", "0", "--out", "o.png"], "width"),
        (
            &["render", "--height", "100000", "--out", "o.png"],
            "height",
        ),
        (&["render", "--samples", "4", "--out", "o.png"], "samples"),
        (
            &["render", "--exposure-ev", "nan", "--out", "o.png"],
            "exposure",
        ),
        (&["render", "--out", "no/such/dir/o.png"], "o.png"),
        (&["kernel", "--samples", "64", "--json"], "samples"),
        (&["bench", "--bandwidth", "0"], "--bandwidth"),
        (&["bench", "--flip-vs", "8"], "--flip-vs"),
        (&["bench", "--lateral-taps", "0,33"], "--lateral-taps"),
    ];
    for (args, needle) in cases {
        let out = subsurface(args, &dir);
        assert!(!out.status.success(), "{args:?} succeeded");
        let line = stderr_line(&out);
        assert!(line.contains(needle), "{args:?}: {line}");
        assert!(!dir.join("o.png").exists(), "{args:?} left an output file");
    }
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("partial"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn kernel_json_has_n_taps_centre_first() {
    let out = subsurface(
        &["kernel", "--samples", "11", "--json"],
        &std::env::temp_dir(),
    );
    assert!(out.status.success());
    let taps: Vec<[f32; 4]> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(taps.len(), 11);
    assert_eq!(taps[0][3], 0.0, "centre tap first");
}

/// `bench` at 64x48, one warm-up and two timed frames, JSON, with the flags of `extra` (split
/// at white space, as a shell would).
fn small_bench(extra: &str) -> Vec<&str> {
    let mut args = vec![
        "bench", "--width", "64", "--height", "48", "--warmup", "1", "--frames", "2", "--json",
    ];
    args.extend(extra.split_whitespace());
    args
}

/// The JSON report of `subsurface ARGS`, run in a scratch directory `name`; None when the
/// test is skipped for want of a GPU adapter.
fn bench_json(name: &str, args: &[&str]) -> Option<serde_json::Value> {
    let (_, out) = run_with_gpu(name, args)?;
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

/// The runs of [`small_bench`] with `extra` (see [`bench_json`]).
fn bench_runs(extra: &str) -> Option<Vec<serde_json::Value>> {
    let v = bench_json("bench", &small_bench(extra))?;
    Some(v["runs"].as_array().unwrap().clone())
}

#[test]
fn bench_json_has_runs_with_positive_times() {
    let Some(runs) = bench_runs("--characters 1,2 --sss none,separable") else {
        return;
    };
    assert_eq!(runs.len(), 4, "2 character counts x 2 methods");
    for r in &runs {
        assert!(r["characters"] == 1 || r["characters"] == 2, "{r}");
        assert!(r["width"] == 64 && r["height"] == 48, "{r}");
        assert!(r["frame_ms"].as_f64().unwrap() > 0.0, "{r}");
        let passes = r["passes"].as_array().unwrap();
        assert!(
            passes
                .iter()
                .all(|p| p["name"].is_string() && p["ms"].as_f64().unwrap() >= 0.0)
        );
    }
    assert_eq!(runs[1]["sss"], "separable");
    assert_eq!(runs[3]["characters"], 2);
    assert!(
        runs[1]["passes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|p| p["name"] == "sss")
    );
}

/// `--rounds 3` measures each configuration three times, in turn: each run carries the three
/// rounds' frame times and reports the median over all their frames (one frame a round: the
/// middle round's). `--rounds 0` is one line of error.
#[test]
fn bench_rounds_measure_each_configuration_in_turn() {
    let mut args = small_bench("--sss none --transmittance off,paper --rounds 3");
    let frames = args.iter().position(|a| *a == "--frames").unwrap() + 1;
    args[frames] = "1";
    let Some(v) = bench_json("bench-rounds", &args) else {
        return;
    };
    assert_eq!(v["rounds"], 3);
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2, "one run per configuration, not per round");
    for r in runs {
        let mut rounds: Vec<f64> = r["round_frame_ms"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(rounds.len(), 3, "{r}");
        assert!(rounds.iter().all(|ms| *ms > 0.0), "{r}");
        rounds.sort_by(f64::total_cmp);
        let median = r["frame_ms"].as_f64().unwrap();
        assert!(
            (median - rounds[1]).abs() <= 1e-9 * median,
            "median {median}, rounds {rounds:?}"
        );
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_subsurface"))
        .args(["bench", "--rounds", "0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(
        errors,
        ["error: --rounds: must be in 1..=100 (got 0)"],
        "{err}"
    );
}

/// `--lateral-taps 0,12` measures `diffusion` at both counts; the other methods once.
#[test]
fn bench_measures_diffusion_at_each_lateral_tap_count() {
    let Some(runs) = bench_runs("--sss none --transmittance paper,diffusion --lateral-taps 0,12")
    else {
        return;
    };
    let runs: Vec<(String, Option<u64>)> = runs
        .iter()
        .map(|r| {
            let tm = r["transmittance"].as_str().unwrap().to_string();
            (tm, r["lateral_taps"].as_u64())
        })
        .collect();
    assert_eq!(
        runs,
        [
            ("paper".to_string(), None),
            ("diffusion".to_string(), Some(0)),
            ("diffusion".to_string(), Some(12)),
        ]
    );
}

/// `--map-texel-mm 0,20` measures `diffusion` with the taps at every pixel and on the
/// transmitted map: each run says the reduction it got, and only the map's run times a map
/// pass (at 64x48 the default hand's pixels are about 7 profile mm, so 20 mm gives 2x2).
#[test]
fn bench_measures_diffusion_with_and_without_the_transmitted_map() {
    let Some(runs) = bench_runs("--sss none --transmittance diffusion --map-texel-mm 0,20") else {
        return;
    };
    let got: Vec<(Option<f64>, Option<u64>, bool)> = runs
        .iter()
        .map(|r| {
            let lateral = r["passes"]
                .as_array()
                .unwrap()
                .iter()
                .any(|p| p["name"] == "transmitted" && p["ms"].as_f64().unwrap() > 0.0);
            (
                r["map_texel_mm"].as_f64(),
                r["map_downsample"].as_u64(),
                lateral,
            )
        })
        .collect();
    assert_eq!(got.len(), 2, "{got:?}");
    assert_eq!(got[0], (Some(0.0), Some(1), false));
    assert_eq!(got[1].0, Some(20.0));
    assert!(got[1].1.is_some_and(|d| d > 1), "{got:?}");
    assert!(got[1].2, "no map pass timed: {got:?}");
}

/// The few-sample mode's quality against more fixed taps, and the byte model beside the
/// measured time with the ratio to the bandwidth bound.
#[test]
fn bench_reports_flip_and_memory_bound() {
    let args = small_bench("--sss separable --samples 7 --jitter --flip-vs 33 --bandwidth 10");
    let Some(v) = bench_json("bench-bound", &args) else {
        return;
    };
    assert_eq!(v["bandwidth_gbps"], 10.0);
    assert_eq!(v["flip_vs"], 33);
    let r = &v["runs"][0];
    assert_eq!(
        (r["samples"].as_u64(), r["jitter"].as_bool()),
        (Some(7), Some(true))
    );
    let flip = r["flip_vs_fixed"].as_f64().unwrap();
    assert!((0.0..0.1).contains(&flip), "{r}");
    let traffic = r["traffic"].as_array().unwrap();
    let sss = traffic.iter().find(|t| t["name"] == "sss").unwrap();
    // The workgroup fetch (the default). On a GPU the horizontal pass reads colour, depth and
    // SSS data (20 B) and writes one 16 B packed texel, which the vertical pass reads before
    // it writes the 8 B colour. On a CPU adapter (lavapipe) a pack step does the packing
    // first (20 in, 16 out) and the horizontal pass reads its 16 B.
    let cpu = v["adapter"].as_str().unwrap().contains("Cpu");
    let (read, write) = if cpu {
        (20 + 16 + 16, 16 + 16 + 8)
    } else {
        (20 + 16, 16 + 8)
    };
    assert_eq!(sss["read_bytes"], 64 * 48 * read, "{}", v["adapter"]);
    assert_eq!(sss["write_bytes"], 64 * 48 * write);
    let bound = sss["bound_ms"].as_f64().unwrap();
    let bytes = f64::from(read + write);
    assert!((bound - 64.0 * 48.0 * bytes / 1e7).abs() < 1e-9, "{sss}");
    let ratio = sss["over_bound"].as_f64().unwrap();
    assert!(
        (ratio - sss["ms"].as_f64().unwrap() / bound).abs() < 1e-9,
        "{sss}"
    );
    assert!(traffic.iter().any(|t| t["name"] == "copy"));
}

/// A scene's path through `shared/assets/` is looked up in `SUBSURFACE_ASSETS` where that is
/// set: the head's scene, copied where its relative paths lead nowhere, renders with the
/// variable and fails naming the missing file without it.
#[test]
fn asset_paths_follow_subsurface_assets() {
    let assets = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/assets");
    let assets = std::env::var_os("SUBSURFACE_ASSETS").map_or(assets, std::path::PathBuf::from);
    if !assets.join("LeePerrySmith/LeePerrySmith.glb").is_file() {
        eprintln!("skipping: no head model");
        return;
    }
    let dir = tempdir("assets");
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/head.toml");
    std::fs::copy(scene, dir.join("head.toml")).unwrap();
    let run = |with: bool| {
        let mut c = std::process::Command::new(common::bin());
        c.args([
            "render",
            "head.toml",
            "--width",
            "64",
            "--height",
            "48",
            "--out",
            "h.png",
        ])
        .current_dir(&dir);
        if with {
            c.env("SUBSURFACE_ASSETS", &assets);
        } else {
            c.env_remove("SUBSURFACE_ASSETS");
        }
        c.output().unwrap()
    };
    let without = run(false);
    assert!(!without.status.success());
    assert!(stderr_line(&without).contains("LeePerrySmith"));
    if !common::gpu_available(&dir) {
        return;
    }
    let with = run(true);
    assert!(
        with.status.success(),
        "{}",
        String::from_utf8_lossy(&with.stderr)
    );
    assert!(dir.join("h.png").is_file());
}
