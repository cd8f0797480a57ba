//! Helpers the integration tests share: running the binary, scratch directories, and the
//! GPU check that skips (or, with SUBSURFACE_REQUIRE_GPU=1, fails) tests that need an adapter.
#![allow(dead_code)] // each test binary uses its own part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_subsurface")
}

/// Runs `subsurface ARGS` in `dir`.
pub fn subsurface(args: &[&str], dir: &Path) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// An empty scratch directory, unique to this test binary, process and `name`.
pub fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "subsurface-{}-{name}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn require_gpu() -> bool {
    std::env::var("SUBSURFACE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// Skips a test (returns false) for `why`, or fails it when SUBSURFACE_REQUIRE_GPU=1.
pub fn skip(why: &str) -> bool {
    assert!(!require_gpu(), "SUBSURFACE_REQUIRE_GPU=1 but {why}");
    eprintln!("skipped: {why}");
    false
}

/// stdout and stderr, for messages.
pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The single line on stderr of a command that failed with exit status 1, which must start
/// with `error: `.
pub fn error_line(out: &Output) -> String {
    let s = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{s}");
    // lavapipe itself prints "error: XDG_RUNTIME_DIR is invalid" without a display; not ours.
    let lines: Vec<&str> = s
        .lines()
        .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
        .collect();
    assert_eq!(lines.len(), 1, "expected one line on stderr, got: {s}");
    assert!(lines[0].starts_with("error: "), "{s}");
    assert!(lines[0].len() > "error: ".len() + 5, "{s}");
    lines[0].to_string()
}

/// Asserts that the command succeeded, showing its stderr if not.
pub fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Whether GPU-dependent commands can be checked: a tiny `render` into `dir` succeeds. Without
/// an adapter the test is skipped, or fails when SUBSURFACE_REQUIRE_GPU=1.
pub fn gpu_available(dir: &Path) -> bool {
    let out = subsurface(
        &[
            "render",
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            "probe.png",
        ],
        dir,
    );
    out.status.success() || skip(&format!("no GPU adapter: {}", text(&out)))
}

/// A scratch directory (see [`tempdir`]) for a test that needs a GPU adapter; None when the
/// test is skipped (see [`gpu_available`]).
pub fn gpu_tempdir(name: &str) -> Option<PathBuf> {
    let dir = tempdir(name);
    gpu_available(&dir).then_some(dir)
}

/// Runs `subsurface ARGS` in `dir`, which must fail with one error line (see [`error_line`])
/// and leave no `output` behind; returns that line.
pub fn refused(args: &[&str], dir: &Path, output: &str) -> String {
    let e = error_line(&subsurface(args, dir));
    assert!(!dir.join(output).exists(), "{e}: {output} written");
    e
}

/// A grey RGB float EXR of `w` x `h` pixels, `f(x, y)` in every channel.
pub fn write_exr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> f32) {
    image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb([f(x, y); 3]))
        .save(path)
        .unwrap();
}

/// A 32x24 scene: the camera 0.2 in front of (0.025, 0.025, 0), a spot light beside it aimed
/// at the origin with the `key = value` lines of `light` added, and one object given by the
/// lines of `object` (its `mesh = ...` first).
pub fn scene_toml(light: &str, object: &str) -> String {
    format!(
        r#"[camera]
position = [0.025, 0.025, 0.2]
target = [0.025, 0.025, 0.0]
[render]
width = 32
height = 24
[[lights]]
kind = "spot"
position = [0.0, 0.0, 0.2]
shadow_map_size = 64
{light}
[[objects]]
{object}
"#
    )
}

/// Asserts that `bytes` are one whole PNG and nothing else: the signature first, the IEND
/// chunk last (a summary line printed to the same stream would break either).
pub fn assert_whole_png(bytes: &[u8]) {
    let head = &bytes[..bytes.len().min(16)];
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "{head:?}");
    let tail = &bytes[bytes.len().saturating_sub(16)..];
    assert!(bytes.ends_with(b"IEND\xae\x42\x60\x82"), "{tail:?}");
}

/// Runs `subsurface ARGS` in a scratch directory `name` and asserts that it succeeded; None
/// when the test is skipped for want of a GPU adapter (see [`gpu_available`]).
pub fn run_with_gpu(name: &str, args: &[&str]) -> Option<(PathBuf, Output)> {
    let dir = tempdir(name);
    if !gpu_available(&dir) {
        return None;
    }
    let out = subsurface(args, &dir);
    assert_success(&out);
    Some((dir, out))
}

/// A GLB file of `json` (padded to 4 bytes here) and the binary chunk `bin`.
#[allow(dead_code)]
pub fn glb(mut json: Vec<u8>, bin: &[u8]) -> Vec<u8> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    for (kind, data) in [(b"JSON", json.as_slice()), (b"BIN\0", bin)] {
        glb.extend_from_slice(&(data.len() as u32).to_le_bytes());
        glb.extend_from_slice(kind);
        glb.extend_from_slice(data);
    }
    glb
}
