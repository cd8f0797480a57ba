//! Output destinations that are not plain files (symbolic links, FIFOs, devices, stdout), no
//! partial files after errors or Ctrl-C, and one `error:` line with exit status 1 for every bad
//! input, including what the argument parser rejects.
//!
//! `export-mitsuba` writes files without a GPU, so it stands in for `render` wherever the
//! destination matters more than the content: `--out DIR` writes `DIR/meshes/*.ply` through
//! temporary files and then `DIR/scene.xml`, which the tests make a link, FIFO or device.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::{assert_success, assert_whole_png, bin, error_line, skip, subsurface, tempdir, text};

fn partial_files(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial-"))
        .collect()
}

fn assert_no_partial_files(dirs: &[&Path]) {
    for d in dirs {
        let p = partial_files(d);
        assert!(p.is_empty(), "{}: {p:?} left behind", d.display());
    }
}

/// What the `export-mitsuba` tests run in their directory.
const EXPORT: [&str; 3] = ["export-mitsuba", "--out", "out"];

/// A scratch directory `name` with an empty folder `out`, and the path of `out/scene.xml`,
/// which the test makes a link, FIFO or device before it runs [`EXPORT`].
fn export_dir(name: &str) -> (PathBuf, PathBuf) {
    let dir = tempdir(name);
    std::fs::create_dir_all(dir.join("out")).unwrap();
    let xml = dir.join("out/scene.xml");
    (dir, xml)
}

/// Asserts that an export into `dir/out` left no partial files there, in `out/meshes` or in
/// `more`, then removes `dir`.
fn assert_clean_export(dir: &Path, more: &[&Path]) {
    assert_no_partial_files(&[&dir.join("out"), &dir.join("out/meshes")]);
    assert_no_partial_files(more);
    std::fs::remove_dir_all(dir).unwrap();
}

/// [`export_dir`] with `out/scene.xml` a symbolic link to `target`, and [`EXPORT`] run there.
#[cfg(unix)]
fn export_through_link(name: &str, target: &str) -> (PathBuf, PathBuf, Output) {
    let (dir, scene_xml) = export_dir(name);
    std::os::unix::fs::symlink(target, &scene_xml).unwrap();
    let out = subsurface(&EXPORT, &dir);
    (dir, scene_xml, out)
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "mkfifo {} failed", path.display());
}

#[test]
fn parse_errors_exit_1_with_one_line() {
    let dir = tempdir("parse");
    let cases: &[(&[&str], &str)] = &[
        (&["kernel", "--bogus"], "--bogus"),
        (&["kernel", "--samples", "abc"], "abc"),
        (&["kernel", "--samples"], "--samples"),
        (&["export-mitsuba"], "--out"),
        (&["no-such-command"], "no-such-command"),
        (&[], "subcommand"),
    ];
    for (args, mentions) in cases {
        let line = error_line(&subsurface(args, &dir));
        assert!(line.contains(mentions), "{args:?}: {line}");
        assert!(
            !line.contains("Usage") && !line.contains("For more information"),
            "{args:?}: {line}"
        );
        assert!(!line.starts_with("error: error"), "{line}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn help_and_version_exit_0() {
    let dir = tempdir("help");
    for args in [&["--help"][..], &["kernel", "--help"], &["--version"]] {
        let out = subsurface(args, &dir);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        assert!(out.stderr.is_empty(), "{args:?}");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("subsurface"), "{args:?}: {stdout}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_error_that_prints_its_cause_is_not_repeated() {
    let dir = tempdir("repeat");
    std::fs::write(
        dir.join("s.toml"),
        "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [[objects]]\nmesh = { gltf = \"missing.glb\" }\n[objects.material]\n",
    )
    .unwrap();
    let line = error_line(&subsurface(
        &["export-mitsuba", "s.toml", "--out", "x"],
        &dir,
    ));
    assert_eq!(line.matches("missing.glb").count(), 1, "{line}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn a_symbolic_link_is_written_through_and_kept() {
    let (dir, scene_xml) = export_dir("symlink");
    std::fs::create_dir_all(dir.join("real")).unwrap();
    std::os::unix::fs::symlink("../real/target.xml", &scene_xml).unwrap();
    assert_success(&subsurface(&EXPORT, &dir));
    let link = std::fs::symlink_metadata(&scene_xml).unwrap();
    assert!(link.file_type().is_symlink(), "the link was replaced");
    let xml = std::fs::read_to_string(dir.join("real/target.xml")).unwrap();
    assert!(xml.contains("<scene"), "{xml}");
    assert_clean_export(&dir, &[&dir.join("real")]);
}

#[cfg(unix)]
#[test]
fn a_link_into_a_missing_directory_fails_and_leaves_nothing() {
    let (dir, _, out) = export_through_link("dangling", "../nowhere/target.xml");
    let line = error_line(&out);
    assert!(
        line.contains("scene.xml") && line.contains("nowhere") && line.contains("does not exist"),
        "{line}"
    );
    // The meshes were written to temporary files before scene.xml failed; they and the
    // meshes/ folder the export created are gone.
    assert!(!dir.join("out/meshes").exists());
    assert!(!dir.join("nowhere").exists());
    assert_clean_export(&dir, &[]);
}

#[test]
fn an_output_in_a_missing_directory_fails_before_rendering() {
    let dir = tempdir("missing");
    // `render` checks its output before it looks for a GPU, so this needs none.
    let line = error_line(&subsurface(&["render", "--out", "nodir/x.png"], &dir));
    assert!(line.contains("nodir/x.png"), "{line}");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn a_fifo_is_written_into() {
    use std::os::unix::fs::FileTypeExt as _;
    let (dir, fifo) = export_dir("fifo");
    mkfifo(&fifo);
    let (tx, rx) = std::sync::mpsc::channel();
    {
        let fifo = fifo.clone();
        // Left blocked (and ended with the test process) if the command never opens the FIFO.
        std::thread::spawn(move || tx.send(std::fs::read(fifo).unwrap()));
    }
    assert_success(&subsurface(&EXPORT, &dir));
    let xml = rx.recv_timeout(Duration::from_secs(60)).unwrap();
    assert!(String::from_utf8_lossy(&xml).contains("<scene"));
    let m = std::fs::symlink_metadata(&fifo).unwrap();
    assert!(m.file_type().is_fifo(), "the FIFO was replaced");
    assert_clean_export(&dir, &[]);
}

#[cfg(target_os = "linux")]
#[test]
fn a_full_device_fails_with_one_line_and_stays_a_device() {
    use std::os::unix::fs::FileTypeExt as _;
    let (dir, scene_xml, out) = export_through_link("full", "/dev/full");
    let line = error_line(&out);
    assert!(
        line.contains("scene.xml: write failed") && line.contains("No space left"),
        "{line}"
    );
    let m = std::fs::symlink_metadata("/dev/full").unwrap();
    assert!(m.file_type().is_char_device());
    let link = std::fs::symlink_metadata(&scene_xml).unwrap();
    assert!(link.file_type().is_symlink());
    assert_clean_export(&dir, &[]);
}

/// A FIFO nobody reads keeps `export-mitsuba` blocked in opening it, with the meshes' temporary
/// files on disk: a reliably long run to interrupt.
#[cfg(unix)]
#[test]
fn ctrl_c_removes_partial_files() {
    use std::os::unix::fs::FileTypeExt as _;
    let (dir, fifo) = export_dir("sigint");
    mkfifo(&fifo);
    let mut child = Command::new(bin())
        .args(EXPORT)
        .current_dir(&dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let meshes = dir.join("out/meshes");
    let start = Instant::now();
    while partial_files(&meshes).is_empty() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("exited early ({status}) without blocking on the FIFO");
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no partial files appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m = std::fs::symlink_metadata(&fifo).unwrap();
    assert!(m.file_type().is_fifo());
    assert_clean_export(&dir, &[]);
}

/// `render --out -`: the PNG alone on stdout, the summary line on stderr. `render` needs an
/// adapter; without one (and without SUBSURFACE_REQUIRE_GPU=1) this is skipped.
#[test]
fn dash_writes_the_png_to_stdout_and_the_summary_to_stderr() {
    let dir = tempdir("stdout");
    let out = subsurface(
        &["render", "--width", "8", "--height", "8", "--out", "-"],
        &dir,
    );
    if !out.status.success() {
        skip(&format!("no GPU adapter: {}", text(&out)));
        return;
    }
    assert_whole_png(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("- 8x8 on ") && stderr.contains("total"),
        "{stderr}"
    );
    assert!(!dir.join("-").exists());
    assert_no_partial_files(&[&dir]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `profile --plot -` (no GPU): the plot alone on stdout, the text on stderr.
#[test]
fn profile_plot_to_stdout_is_the_png_alone() {
    let dir = tempdir("plot-stdout");
    let out = subsurface(&["profile", "--material", "marble", "--plot", "-"], &dir);
    assert_success(&out);
    assert_whole_png(&out.stdout);
    let img = image::load_from_memory(&out.stdout).unwrap();
    assert_eq!((img.width(), img.height()), (1400, 560));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("material: marble") && stderr.contains("plot: -"),
        "{stderr}"
    );
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
