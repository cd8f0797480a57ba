//! What a frame will allocate on the GPU, estimated from the settings before anything is
//! created, so that a size the device cannot hold is a one-line error naming the setting
//! rather than an out-of-memory abort halfway through.

use crate::error::RenderError;
use crate::scene::Scene;
use crate::settings::{RenderSettings, SssMethod, TransmittanceMethod};

/// Default limit on the estimate, in bytes; `SUBSURFACE_GPU_MEMORY_LIMIT_GB` overrides it.
pub const DEFAULT_LIMIT_BYTES: u64 = 8 << 30;

/// Bytes per pixel of the frame's targets: diffuse and specular (Rgba16Float), linear depth
/// (R32Float), SSS (Rgba16Float), z-buffer (Depth32Float), output (Rgba8), and up to four
/// Rgba16Float intermediates of the six-Gaussian blur.
const FRAME_BYTES_PER_PIXEL: u64 = 8 + 8 + 4 + 8 + 4 + 4 + 4 * 8;
/// Bytes per texel of one object's texture-space maps: irradiance (Rgba16Float), stretch
/// (Rg32Float), and the blur's temporary, ping, pong, accumulation, result and widest
/// Gaussian (Rgba16Float each).
const TEXTURE_SPACE_BYTES_PER_TEXEL: u64 = 8 + 8 + 6 * 8;
/// Bytes per texel of a shadow-map layer: distance and entry normal (Rg32Float), the depth
/// buffer it is drawn with (Depth32Float), translucent shadow maps' (u, v) (Rg32Float).
const SHADOW_BYTES_PER_TEXEL: u64 = 8 + 4 + 8;

/// The limit in force.
pub fn limit_bytes() -> u64 {
    std::env::var("SUBSURFACE_GPU_MEMORY_LIMIT_GB")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|gb| gb.is_finite() && *gb > 0.0)
        .map_or(DEFAULT_LIMIT_BYTES, |gb| (gb * (1u64 << 30) as f64) as u64)
}

fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

/// The largest allocations of a frame, each checked against the limit, with the setting that
/// drives it named in the error.
pub fn check(scene: &Scene, s: &RenderSettings) -> Result<(), RenderError> {
    let limit = limit_bytes();
    let pixels = s.width as u64 * s.height as u64;
    let frame = pixels * FRAME_BYTES_PER_PIXEL;
    let over = |field: &str, what: String, bytes: u64| {
        RenderError::invalid(
            field,
            format!(
                "{what} needs about {} of GPU memory, over the limit of {} (set SUBSURFACE_GPU_MEMORY_LIMIT_GB to raise it)",
                gib(bytes),
                gib(limit)
            ),
        )
    };
    if frame > limit {
        return Err(over(
            "width",
            format!("a {}x{} frame", s.width, s.height),
            frame,
        ));
    }
    let texture_space =
        s.sss.method == SssMethod::Texture || s.transmittance.method == TransmittanceMethod::Tsm;
    if texture_space {
        let skin = scene
            .objects
            .iter()
            .filter(|o| o.material.sss_strength > 0.0 && !o.mesh.indices.is_empty())
            .count() as u64;
        let side = s.sss.texture_size as u64;
        let maps = skin * side * side * TEXTURE_SPACE_BYTES_PER_TEXEL;
        if frame + maps > limit {
            return Err(over(
                "sss.texture_size",
                format!("texture-space maps of {side}x{side} for {skin} skin objects"),
                frame + maps,
            ));
        }
    }
    let shadow: u64 = scene
        .desc
        .lights
        .iter()
        .map(|l| {
            let layers = if l.kind == crate::scene::LightKind::Point {
                6
            } else {
                1
            };
            l.shadow_map_size as u64 * l.shadow_map_size as u64 * layers * SHADOW_BYTES_PER_TEXEL
        })
        .sum();
    if frame + shadow > limit {
        return Err(over(
            "lights",
            "the shadow maps".to_string(),
            frame + shadow,
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_past_the_limit_are_errors_naming_the_setting() {
        let scene = Scene::default_scene();
        let mut o = scene.desc.render.clone();
        assert!(check(&scene, &o).is_ok());
        (o.width, o.height) = (16384, 16384);
        let e = check(&scene, &o).unwrap_err().to_string();
        assert!(
            e.starts_with("width: a 16384x16384 frame needs about"),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let mut o = scene.desc.render.clone();
        o.sss.method = SssMethod::Texture;
        o.sss.texture_size = 16384;
        let e = check(&scene, &o).unwrap_err().to_string();
        assert!(e.starts_with("sss.texture_size: texture-space maps"), "{e}");
        o.sss.texture_size = 1024;
        assert!(check(&scene, &o).is_ok());
    }
}
