//! Ground truth: the Mitsuba export and the regression guard against the committed path-traced
//! references (docs/lab/fidelity.md).
//!
//! - The export test path-traces a 32x32, 16 spp image; it is skipped only when Python cannot
//!   import mitsuba (CI installs it, and sets SUBSURFACE_REQUIRE_MITSUBA=1 to fail instead).
//! - The regression guard renders each canonical scene with the default method (`separable` +
//!   `diffusion`) at `--quality high` and checks that its errors stay within the recorded ones
//!   (references/fidelity.json) plus a margin, the knife edge's width too, and below those of
//!   `--sss none --transmittance off`; the other presets within their own targets.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::tempdir;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `subsurface`, run from the repository root (where the scenes and references are).
fn bin() -> Command {
    let mut c = Command::new(common::bin());
    c.current_dir(root());
    c
}

fn env_is_1(k: &str) -> bool {
    std::env::var(k).is_ok_and(|v| v == "1")
}

fn mitsuba_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import mitsuba"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok && env_is_1("SUBSURFACE_REQUIRE_MITSUBA") {
        panic!("SUBSURFACE_REQUIRE_MITSUBA=1 but python3 cannot import mitsuba");
    }
    ok
}

/// A scratch directory `name` for a test that renders, or None (the test is skipped) where no
/// GPU adapter exists; SUBSURFACE_REQUIRE_GPU=1 turns a missing adapter into a failure, as in
/// the renderer's tests.
fn gpu_tempdir(name: &str) -> Option<PathBuf> {
    match subsurface_render::GpuContext::new_headless() {
        Ok(_) => Some(tempdir(name)),
        Err(e) if env_is_1("SUBSURFACE_REQUIRE_GPU") => panic!("SUBSURFACE_REQUIRE_GPU=1 but {e}"),
        Err(e) => {
            eprintln!("skipping: no GPU adapter: {e}");
            None
        }
    }
}

fn head_available() -> bool {
    let dir = std::env::var_os("SUBSURFACE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("../shared/assets"));
    dir.join("LeePerrySmith/LeePerrySmith.glb").is_file()
}

fn read_exr_mean(path: &Path) -> (u32, u32, f64, bool) {
    let img = image::open(path).unwrap().to_rgb32f();
    let (w, h) = img.dimensions();
    let v: Vec<f32> = img.into_raw();
    let finite = v.iter().all(|x| x.is_finite());
    (
        w,
        h,
        v.iter().map(|x| f64::from(*x)).sum::<f64>() / v.len() as f64,
        finite,
    )
}

#[test]
fn export_writes_the_medium_in_scene_units() {
    let out = tempdir("export");
    let o = bin()
        .args([
            "export-mitsuba",
            "scenes/canonical/wedge-backlit.toml",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The canonical scenes name the path tracer's medium: exported as it is, no substitution.
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("no single medium"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    // skin1: sigma_t = 0.48 + 1.01 = 1.49 /mm in blue, the largest; metres: x 1000.
    assert!(
        xml.contains("<float name=\"scale\" value=\"1490\""),
        "{xml}"
    );
    assert!(xml.contains("roughdielectric") && xml.contains("int_ior\" value=\"1.3\""));
    assert!(xml.contains("fov_axis\" value=\"y\""));
    // Emitters are pi times our intensity (2.0 x colour 1.0).
    assert!(xml.contains("6.283185"), "{xml}");
    let ply = std::fs::read(out.join("meshes/00-wedge.ply")).unwrap();
    assert!(ply.starts_with(b"ply\nformat binary_little_endian 1.0\n"));

    // A medium given by its coefficients is written exactly (eta included); d'Eon's "skin"
    // Gaussians are no single medium: exported as skin1, and the exporter says so.
    let wedge =
        std::fs::read_to_string(root().join("scenes/canonical/wedge-backlit.toml")).unwrap();
    for (medium, want_xml, want_stderr) in [
        (
            "medium = { sigma_a = [0.01, 0.02, 0.03], sigma_s = [2.0, 2.5, 3.0], eta = 1.4 }",
            [
                "int_ior\" value=\"1.4\"",
                "<float name=\"scale\" value=\"3030\"",
            ],
            None,
        ),
        (
            "medium = \"skin\"",
            [
                "int_ior\" value=\"1.3\"",
                "<float name=\"scale\" value=\"1490\"",
            ],
            Some("exported as Jensen 2001 \"skin1\""),
        ),
    ] {
        let scene = out.join("medium.toml");
        std::fs::write(&scene, wedge.replace("medium = \"skin1\"", medium)).unwrap();
        let dir = out.join("medium");
        let o = bin()
            .arg("export-mitsuba")
            .arg(&scene)
            .arg("--out")
            .arg(&dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{stderr}");
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        for w in want_xml {
            assert!(xml.contains(w), "{medium}: no {w} in {xml}");
        }
        assert_eq!(
            stderr.contains("no single medium"),
            want_stderr.is_some(),
            "{stderr}"
        );
        if let Some(w) = want_stderr {
            assert!(stderr.contains(w), "{stderr}");
        }
    }
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn export_loads_in_mitsuba_and_is_not_black() {
    if !mitsuba_available() {
        eprintln!(
            "skipping: python3 cannot import mitsuba (python3 -m pip install mitsuba==3.9.1)"
        );
        return;
    }
    let out = tempdir("mitsuba");
    for scene in ["sphere-frontlit", "wedge-backlit"] {
        let dir = out.join(scene);
        let o = bin()
            .args([
                "export-mitsuba",
                &format!("scenes/canonical/{scene}.toml"),
                "--out",
            ])
            .arg(&dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let exr = out.join(format!("{scene}.exr"));
        let o = Command::new("python3")
            .arg(root().join("tools/reference/render_reference.py"))
            .arg(dir.join("scene.xml"))
            .arg("--out")
            .arg(&exr)
            .args(["--width", "32", "--height", "32", "--spp", "16", "--quiet"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{scene}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let (w, h, mean, finite) = read_exr_mean(&exr);
        eprintln!("{scene}: 32x32 16 spp mean radiance {mean}");
        assert_eq!((w, h), (32, 32));
        assert!(finite, "{scene}: non-finite pixels");
        // Not black: a smooth dielectric with a spot light, or a wrong sigma_t scale, gives 0.
        assert!(mean > 1e-3, "{scene}: mean radiance {mean}");
        // Beside it, the standard error of each pixel (two passes of 8 spp): finite, >= 0,
        // and not zero everywhere (a path tracer is never noise-free at 16 spp).
        let se = out.join(format!("{scene}.stderr.exr"));
        let (sw, sh, se_mean, se_finite) = read_exr_mean(&se);
        assert_eq!((sw, sh), (32, 32));
        assert!(
            se_finite && se_mean > 0.0,
            "{scene}: standard error mean {se_mean}"
        );
    }
    std::fs::remove_dir_all(&out).ok();
}

fn compare_json(
    reference: &Path,
    scene: &Path,
    sss: &str,
    transmittance: &str,
    out: &Path,
) -> serde_json::Value {
    compare_json_with(
        reference,
        scene,
        &["--sss", sss, "--transmittance", transmittance],
        out,
    )
}

/// `subsurface compare --json` of `scene` against `reference` with the flags `args`.
fn compare_json_with(
    reference: &Path,
    scene: &Path,
    args: &[&str],
    out: &Path,
) -> serde_json::Value {
    // The records are `high`'s, every term of the renderer; the presets are checked apart.
    let quality: &[&str] = if args.contains(&"--quality") {
        &[]
    } else {
        &["--quality", "high"]
    };
    let o = bin()
        .arg("compare")
        .arg(reference)
        .arg(scene)
        .args(quality)
        .args(args)
        .args(["--json", "--out"])
        .arg(out)
        .env(
            "WGPU_BACKEND",
            std::env::var("WGPU_BACKEND").unwrap_or_else(|_| "vulkan".into()),
        )
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn f(v: &serde_json::Value, k: &str) -> f64 {
    v[k].as_f64()
        .unwrap_or_else(|| panic!("{k} missing in {v}"))
}

/// Per channel `c`: `(c, recorded, got)`, the three entries of the array `field` of a record
/// and of a fresh result.
fn per_channel<'a>(
    recorded: &'a serde_json::Value,
    got: &'a serde_json::Value,
    field: &'a str,
) -> impl Iterator<Item = (usize, f64, f64)> + 'a {
    (0..3).map(move |c| {
        let v = |r: &serde_json::Value| r[field][c].as_f64().unwrap();
        (c, v(recorded), v(got))
    })
}

/// The default method (`subsurface render` with no flags): what the guard holds to its record.
const DEFAULT: (&str, &str) = ("separable", "diffusion");

/// Issue 13's target: every region mean within this of the path tracer. (The hand's fingers
/// were the last to reach it, at -21 % without the bounce: light one part of the hand sends
/// another across the air, finding 11 and `the_bounce_is_the_light_between_parts`.)
const REGION_TARGET: f64 = 0.20;

#[test]
fn regression_guard_against_committed_references() {
    let recorded: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("references/fidelity.json")).unwrap(),
    )
    .unwrap();
    let Some(out) = gpu_tempdir("guard") else {
        return;
    };
    let mut checked = 0;
    for (name, rec) in recorded["scenes"].as_object().unwrap() {
        let reference = root().join(format!("references/{name}.exr"));
        let scene = root().join(format!("scenes/canonical/{name}.toml"));
        if name.starts_with("head") && !head_available() {
            eprintln!("{name}: skipped, no head model");
            continue;
        }
        assert!(reference.is_file(), "{}: missing", reference.display());
        let good = compare_json(&reference, &scene, DEFAULT.0, DEFAULT.1, &out.join("a.png"));
        let base = compare_json(&reference, &scene, "none", "off", &out.join("b.png"));
        let rec = &rec[format!("{}+{}", DEFAULT.0, DEFAULT.1)];
        eprintln!(
            "{name}: {DEFAULT:?} noise-corrected RMSE {:.4} (recorded {:.4}, none+off {:.4}), FLIP {:.4} (recorded {:.4}, none+off {:.4})",
            f(&good, "rmse_debiased"),
            f(rec, "rmse_debiased"),
            f(&base, "rmse_debiased"),
            f(&good, "flip_mean"),
            f(rec, "flip_mean"),
            f(&base, "flip_mean")
        );
        // Margins: lavapipe and GPUs differ in the last bits of the shading and in
        // rasterisation ties; 5 % relative covers that without hiding a real regression.
        // RMSE is taken with the reference's own noise removed (compare.rs): raw RMSE is
        // mostly the path tracer's noise and would hide a change of the image.
        for k in ["rmse_debiased", "flip_mean"] {
            assert!(
                f(&good, k) <= f(rec, k) * 1.05 + 1e-4,
                "{name}: {DEFAULT:?} {k} {} above the recorded {} + 5 %",
                f(&good, k),
                f(rec, k)
            );
        }
        // Region means (skin, fingers, ear, rim...): a regression that darkens or brightens
        // a region moves its error; 3 percentage points is far above what another adapter
        // changes and below any visible change of the skin.
        let regions: std::collections::HashMap<String, f64> = good["regions"]
            .as_array()
            .unwrap()
            .iter()
            .map(|g| (g["name"].as_str().unwrap().to_string(), f(g, "rel_error")))
            .collect();
        for (region, want) in rec["regions"].as_object().unwrap() {
            let want = want.as_f64().unwrap();
            let got = regions[region];
            assert!(
                (got - want).abs() <= 0.03,
                "{name}: region {region} mean error {got:+.3} vs recorded {want:+.3}"
            );
        }
        for (region, got) in &regions {
            assert!(
                got.abs() <= REGION_TARGET,
                "{name}: region {region} mean error {got:+.3} outside the +-20 % target"
            );
        }
        // Better than no scattering and no transmittance: worse on neither measure, better
        // on at least one. (Where the reference's noise exceeds every method's error, as on
        // the front-lit head at 256 spp, the noise-corrected RMSE is 0 for all of them and
        // FLIP decides; on the spheres FLIP ties and the RMSE decides. A FLIP mean within
        // 5e-4 is a tie: the front-lit sphere's 0.0780 against 0.0778 is the blur softening a
        // noisy reference's grain, while its shadow side goes from -11.6 % to +3.0 %.)
        let (rg, rb) = (f(&good, "rmse_debiased"), f(&base, "rmse_debiased"));
        let (fg, fb) = (f(&good, "flip_mean"), f(&base, "flip_mean"));
        assert!(
            rg <= rb && fg <= fb + 5e-4 && (rg < rb || fg < fb),
            "{name}: {DEFAULT:?} (noise-corrected RMSE {rg}, FLIP {fg}) not better than none+off ({rb}, {fb})"
        );
        // The knife edge: the blur's width across a shadow edge, per channel, within 5 % of
        // the recorded width (a kernel of another width moves it by far more).
        if let Some(e) = rec.get("edge") {
            for (c, want, got) in per_channel(e, &good["edge"], "edge_width_mm") {
                assert!(
                    (got - want).abs() <= 0.05 * want + 0.05,
                    "{name}: edge width channel {c} {got:.3} mm vs recorded {want:.3} mm"
                );
            }
            // The target: the blur's red rise within 15 % of the path tracer's.
            let red = good["edge"]["edge_width_mm"][0].as_f64().unwrap();
            let red_ref = good["edge"]["edge_width_mm_reference"][0].as_f64().unwrap();
            assert!(
                (red - red_ref).abs() <= 0.15 * red_ref,
                "{name}: red edge width {red:.2} mm vs the reference's {red_ref:.2} mm"
            );
        }
        // The wedge's light against thickness: the worst significant 1 mm bin per channel
        // within 3 points of its record (a T(s) of another decay moves it by tens).
        if let Some(t) = rec.get("thickness") {
            for (c, want, got) in per_channel(t, &good["thickness"], "max_abs_rel_error") {
                assert!(
                    (got - want).abs() <= 0.03,
                    "{name}: worst bin against thickness, channel {c}, {got:.3} vs recorded {want:.3}"
                );
            }
        }
        // What FLIP sees is what `subsurface render` writes (CPU tone map = GPU tone map).
        assert!(
            good["tonemap_check_max_diff"].as_u64().unwrap() <= 1,
            "{good}"
        );
        checked += 1;
    }
    assert!(checked >= 4, "only {checked} references checked");
    std::fs::remove_dir_all(&out).ok();
}

/// Issue 38's targets for the cheaper presets: every region of every canonical scene within
/// ±25 % of the path tracer at `medium` (the default) and ±40 % at `low`, and each better than
/// no scattering and no transmittance, on FLIP or on every region.
#[test]
fn presets_meet_their_region_targets() {
    let Some(out) = gpu_tempdir("presets") else {
        return;
    };
    let mut checked = 0;
    for entry in std::fs::read_dir(root().join("scenes/canonical")).unwrap() {
        let scene = entry.unwrap().path();
        if scene.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let name = scene.file_stem().unwrap().to_string_lossy().to_string();
        let reference = root().join(format!("references/{name}.exr"));
        if !reference.is_file() || (name.starts_with("head") && !head_available()) {
            continue;
        }
        let base = compare_json(&reference, &scene, "none", "off", &out.join("b.png"));
        let regions = |v: &serde_json::Value| -> Vec<(String, f64)> {
            v["regions"]
                .as_array()
                .unwrap()
                .iter()
                .map(|g| (g["name"].as_str().unwrap().to_string(), f(g, "rel_error")))
                .collect()
        };
        let bare = regions(&base);
        for (preset, target) in [("medium", 0.25), ("low", 0.40)] {
            let v = compare_json_with(
                &reference,
                &scene,
                &["--quality", preset],
                &out.join("p.png"),
            );
            let got = regions(&v);
            for (region, e) in &got {
                assert!(
                    e.abs() <= target,
                    "{name} at {preset}: region {region} {e:+.3} outside ±{target}"
                );
            }
            let flip_better = f(&v, "flip_mean") <= f(&base, "flip_mean") + 5e-4;
            let regions_better = got
                .iter()
                .zip(&bare)
                .all(|((_, e), (_, b))| e.abs() <= b.abs() + 1e-3);
            assert!(
                flip_better || regions_better,
                "{name} at {preset}: not better than none+off on FLIP ({} vs {}) or on every region ({got:?} vs {bare:?})",
                f(&v, "flip_mean"),
                f(&base, "flip_mean")
            );
        }
        checked += 1;
    }
    assert!(checked >= 4, "only {checked} scenes checked");
    std::fs::remove_dir_all(&out).ok();
}

/// The light between parts, measured on both sides. The path tracer with that light taken
/// out (`render_reference.py --no-bounce`: a path ends where it reaches a surface through the
/// air after a surface event; references/no-bounce/, on the scenes where one part faces
/// another) renders what the default method computes without its bounce: against it that is
/// within the target on every region, as recorded. The bounce (passes::bounce) adds to ours a
/// share of the full reference's light within 2 points of its record on every region, and on
/// the hand's fingers, where the references differ most (the full one holds about 1.3x the
/// light), a real part of that difference and not more than all of it (docs/lab/fidelity.md,
/// findings 9 and 11).
#[test]
fn the_bounce_is_the_light_between_parts() {
    let recorded: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("references/fidelity.json")).unwrap(),
    )
    .unwrap();
    let recorded = recorded["no_bounce"].as_object().unwrap();
    assert!(
        recorded.contains_key("hand-backlit"),
        "fidelity.json records no hand without light between parts"
    );
    let Some(out) = gpu_tempdir("no-bounce") else {
        return;
    };
    let region = |v: &serde_json::Value, name: &str| {
        v["regions"]
            .as_array()
            .unwrap()
            .iter()
            .find(|g| g["name"] == name)
            .map(|g| f(g, "rel_error"))
            .unwrap_or_else(|| panic!("no region {name} in {v}"))
    };
    let (sss, tr) = DEFAULT;
    let with = ["--sss", sss, "--transmittance", tr];
    let without = ["--sss", sss, "--transmittance", tr, "--bounce-ring", "0"];
    for (name, rec) in recorded {
        if name.starts_with("head") && !head_available() {
            eprintln!("{name}: skipped, no head model");
            continue;
        }
        let scene = root().join(format!("scenes/canonical/{name}.toml"));
        let no_bounce = root().join(format!("references/no-bounce/{name}.exr"));
        let full = root().join(format!("references/{name}.exr"));
        let direct = compare_json_with(&no_bounce, &scene, &without, &out.join("a.png"));
        let off_full = compare_json_with(&full, &scene, &without, &out.join("b.png"));
        let on_full = compare_json_with(&full, &scene, &with, &out.join("c.png"));
        for (region_name, want) in rec["regions"].as_object().unwrap() {
            let want = want.as_f64().unwrap();
            let got = region(&direct, region_name);
            let share = region(&on_full, region_name) - region(&off_full, region_name);
            let share_want = rec["bounce_share"][region_name].as_f64().unwrap();
            let traced = 1.0 - (1.0 + region(&off_full, region_name)) / (1.0 + got);
            eprintln!(
                "{name} {region_name}: without the bounce {got:+.3} against the reference without light between parts (recorded {want:+.3}); the bounce adds {share:.3} of the full reference (recorded {share_want:.3}), the path tracer's light between parts {traced:.3}"
            );
            // As the guard above: 3 points from the record, and the target.
            assert!(
                (got - want).abs() <= 0.03,
                "{name}: {region_name} {got:+.3} without the bounce against the reference without light between parts, recorded {want:+.3}"
            );
            assert!(
                got.abs() <= REGION_TARGET,
                "{name}: {region_name} {got:+.3} outside the target"
            );
            assert!(
                (share - share_want).abs() <= 0.02,
                "{name}: {region_name}: the bounce adds {share:+.3}, recorded {share_want:+.3}"
            );
            if name == "hand-backlit" && region_name == "fingers" {
                assert!(
                    traced > 0.15,
                    "the full reference's fingers hold only {traced:.3} light between parts"
                );
                assert!(
                    share > 0.05 && share <= traced,
                    "the bounce adds {share:.3} to the fingers, the path tracer's light between parts is {traced:.3}"
                );
            }
        }
    }
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn compare_flip_agrees_with_nv_flip() {
    let Some(out) = gpu_tempdir("flip") else {
        return;
    };
    let png = out.join("side.png");
    let r = compare_json(
        &root().join("references/sphere-frontlit.exr"),
        &root().join("scenes/canonical/sphere-frontlit.toml"),
        "separable",
        "paper",
        &png,
    );
    let side = image::open(&png).unwrap().to_rgb8();
    let (w, h) = (side.width() / 3, side.height());
    assert_eq!((w, h), (256, 256));
    let crop = |x0: u32| {
        image::imageops::crop_imm(&side, x0, 0, w, h)
            .to_image()
            .into_raw()
    };
    let ours = nv_flip::FlipImageRgb8::with_data(w, h, &crop(0));
    let reference = nv_flip::FlipImageRgb8::with_data(w, h, &crop(w));
    let err = nv_flip::flip(reference, ours, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let nv = nv_flip::FlipPool::from_image(&err).mean();
    let mine = f(&r, "flip_mean") as f32;
    eprintln!("FLIP: compare {mine:.4}, nv-flip {nv:.4}");
    assert!(
        (mine - nv).abs() < 0.01 + 0.03 * nv,
        "compare {mine} vs nv-flip {nv}"
    );
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn compare_bad_input_is_one_line_and_leaves_nothing() {
    let out = tempdir("bad");
    let png = out.join("x.png");
    let run = |args: &[&str]| {
        let o = bin()
            .arg("compare")
            .args(args)
            .arg("--out")
            .arg(&png)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).trim().to_string();
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.starts_with("error: ") && !err.contains('\n'), "{err}");
        assert!(!png.exists(), "partial output left behind");
        assert_eq!(
            std::fs::read_dir(&out).unwrap().count(),
            0,
            "temporary file left behind"
        );
        err
    };
    let e = run(&[
        "references/missing.exr",
        "scenes/canonical/wedge-backlit.toml",
    ]);
    assert!(e.contains("missing.exr"), "{e}");
    // A 32x32 EXR against a 256x256 scene.
    let small = std::env::temp_dir().join(format!("subsurface-small-{}.exr", std::process::id()));
    image::Rgb32FImage::from_pixel(32, 32, image::Rgb([0.5, 0.5, 0.5]))
        .save(&small)
        .unwrap();
    let e = run(&[
        small.to_str().unwrap(),
        "scenes/canonical/wedge-backlit.toml",
    ]);
    assert!(e.contains("32x32") && e.contains("256x256"), "{e}");
    std::fs::remove_file(&small).ok();
    // Not an image at all.
    let e = run(&[
        "scenes/canonical/wedge-backlit.toml",
        "scenes/canonical/wedge-backlit.toml",
    ]);
    assert!(e.contains("cannot read the reference"), "{e}");
    std::fs::remove_dir_all(&out).ok();
}
