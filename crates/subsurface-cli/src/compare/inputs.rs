//! What `compare` reads: the reference (and its standard-error image) and the regions file,
//! each checked before the render.

use std::path::{Path, PathBuf};

use anyhow::Result;

use super::{CompareArgs, RegionsFile};

/// Reads a linear-radiance EXR (or any float image the `image` crate reads) as RGB: a regular
/// file (a FIFO blocked forever), every value finite and >= 0 (radiance is never negative: a
/// negative reference was taken for a black one).
pub fn read_reference(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let cannot = |e: String| {
        anyhow::anyhow!(
            "{}: cannot read the reference: {}",
            path.display(),
            crate_one_line(&e)
        )
    };
    let bytes =
        subsurface_render::input::read_regular(path, subsurface_render::input::MAX_IMAGE_BYTES)
            .map_err(cannot)?;
    let img = image::load_from_memory(&bytes)
        .map_err(|e| cannot(e.to_string()))?
        .to_rgb32f();
    let (w, h) = img.dimensions();
    let px: Vec<[f32; 3]> = img.pixels().map(|p| p.0).collect();
    if let Some(i) = px
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite() && *v >= 0.0))
    {
        anyhow::bail!(
            "{}: pixel ({}, {}) is {:?}: the reference must be finite and >= 0",
            path.display(),
            i % w as usize,
            i / w as usize,
            px[i]
        );
    }
    Ok((w, h, px))
}

/// The standard-error image `tools/reference/render_reference.py` writes beside a reference
/// (REF.stderr.exr for REF.exr), if there is one.
pub fn stderr_path(reference: &Path) -> PathBuf {
    let name = reference
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let stem = name
        .strip_suffix(".exr")
        .or_else(|| name.strip_suffix(".EXR"))
        .unwrap_or(&name);
    reference.with_file_name(format!("{stem}.stderr.exr"))
}

pub(super) fn read_stderr(reference: &Path, w: u32, h: u32) -> Result<Option<Vec<[f32; 3]>>> {
    let path = stderr_path(reference);
    if !path.is_file() {
        return Ok(None);
    }
    let (sw, sh, se) = read_reference(&path)?;
    anyhow::ensure!(
        (sw, sh) == (w, h),
        "{}: {sw}x{sh}, but the reference is {w}x{h}",
        path.display()
    );
    Ok(Some(se))
}

fn crate_one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// The regions file and its path (None without one).
pub(super) fn load_regions(args: &CompareArgs) -> Result<(Option<PathBuf>, RegionsFile)> {
    let path = match (&args.regions, &args.scene) {
        (Some(p), _) => p.clone(),
        (None, Some(s)) => {
            let p = s.with_extension("regions.json");
            if !p.is_file() {
                return Ok((None, RegionsFile::default()));
            }
            p
        }
        (None, None) => return Ok((None, RegionsFile::default())),
    };
    let text = subsurface_render::input::read_regular_text(
        &path,
        subsurface_render::input::MAX_TEXT_BYTES,
    )
    .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
    let f: RegionsFile =
        serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let rects = f
        .regions
        .iter()
        .enumerate()
        .map(|(i, r)| (format!("regions[{i}]"), r.rect));
    if let Some(t) = &f.thickness {
        anyhow::ensure!(
            t.bin_mm > 0.0 && t.max_mm > t.bin_mm && t.max_mm / t.bin_mm <= 10_000.0,
            "{}: thickness: bin_mm must be > 0 and max_mm above it (at most 10000 bins)",
            path.display()
        );
    }
    let rects = rects
        .chain(f.edge.iter().map(|e| ("edge".into(), e.rect)))
        .chain(f.thickness.iter().map(|t| ("thickness".into(), t.rect)));
    for (name, [x0, y0, x1, y1]) in rects {
        anyhow::ensure!(
            [x0, y0, x1, y1].iter().all(|v| (0.0..=1.0).contains(v)) && x0 < x1 && y0 < y1,
            "{}: {name}.rect: must be [x0, y0, x1, y1] in 0..=1 with x0 < x1, y0 < y1",
            path.display()
        );
    }
    Ok((Some(path), f))
}
