//! How many bytes an image pass must move at a given size: the memory bound that `bench`
//! holds each measured time against (time / (bytes / bandwidth) says how far a pass is from
//! the limit the memory sets).
//!
//! Two models, both from the textures' formats and the passes' taps:
//! * **compulsory**: every texel a step reads is read once and every texel it writes is
//!   written once; a perfect cache could not do with less, so it is the bound to compare with.
//! * **per tap**: every texel every tap touches is read from memory (no cache at all): 1-D taps
//!   bilinearly filter 2 texels, 2-D taps 4, each loading colour, depth and SSS data (direct
//!   fetch) or one packed texel (packed fetch, after a pack step). The gap between the two is
//!   what the texture cache has to save.
//!
//! Every pixel is counted as skin (the passes read only the centre of the others), and the
//! six-Gaussian removal of sub-pixel Gaussians is ignored: the per-tap model is an upper
//! bound, the compulsory one a lower bound.

use crate::passes::{lighting, sss};
use crate::settings::{SssFetch, SssMethod, SssSettings};

/// Bytes per texel of `format` (the formats these passes use are all uncompressed).
fn texel_bytes(format: wgpu::TextureFormat) -> u64 {
    u64::from(format.block_copy_size(None).unwrap_or(0))
}

/// Bytes one step moves per pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct PerPixel {
    read: u64,
    write: u64,
    /// Reads of the per-tap model.
    read_taps: u64,
}

impl std::ops::Add for PerPixel {
    type Output = PerPixel;
    fn add(self, o: PerPixel) -> PerPixel {
        PerPixel {
            read: self.read + o.read,
            write: self.write + o.write,
            read_taps: self.read_taps + o.read_taps,
        }
    }
}

/// The bytes one pass (all its steps) moves at one size.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PassTraffic {
    /// The pass's name in the timings (`sss`, `copy`).
    pub name: &'static str,
    /// Compulsory model: bytes read.
    pub read_bytes: u64,
    /// Compulsory model: bytes written.
    pub write_bytes: u64,
    /// Per-tap model: bytes read (writes as in the compulsory model).
    pub read_bytes_per_tap: u64,
}

impl PassTraffic {
    /// Compulsory bytes moved, read and write.
    pub fn bytes(&self) -> u64 {
        self.read_bytes + self.write_bytes
    }

    /// The time the compulsory bytes take at `gbps` (10^9 bytes per second), in ms.
    pub fn bound_ms(&self, gbps: f64) -> f64 {
        self.bytes() as f64 / (gbps * 1e6)
    }

    fn from(name: &'static str, p: PerPixel, pixels: u64) -> Self {
        Self {
            name,
            read_bytes: p.read * pixels,
            write_bytes: p.write * pixels,
            read_bytes_per_tap: p.read_taps * pixels,
        }
    }
}

/// The bytes a tap reads per texel and a blur step writes per pixel when its output feeds
/// another blur step (`between`) or is the result (`last`).
struct Texels {
    tap: u64,
    between: u64,
    last: u64,
}

fn texels(fetch: SssFetch) -> Texels {
    let colour = texel_bytes(sss::FORMAT);
    match fetch {
        SssFetch::Direct => Texels {
            tap: colour + texel_bytes(lighting::DEPTH_FORMAT) + texel_bytes(lighting::SSS_FORMAT),
            between: colour,
            last: colour,
        },
        SssFetch::Packed | SssFetch::Workgroup => {
            let packed = texel_bytes(sss::PACKED_FORMAT);
            Texels {
                tap: packed,
                between: packed,
                last: colour,
            }
        }
    }
}

/// One blur step of `taps` taps besides the centre, each filtering `texels` texels of `tap`
/// bytes: reads the centre and every texel of every tap, writes `write` bytes.
fn blur_step(tap: u64, write: u64, taps: u64, texels: u64) -> PerPixel {
    PerPixel {
        read: tap,
        write,
        read_taps: tap * (1 + taps * texels),
    }
}

/// A step that reads `read` bytes per pixel once and writes `write` (no taps).
fn plain_step(read: u64, write: u64) -> PerPixel {
    PerPixel {
        read,
        write,
        read_taps: read,
    }
}

/// The screen-space SSS passes with `settings` at `width` x `height` (the timed `sss`
/// passes; the copy of the input that Hable's pass starts from is outside them), or None for
/// methods that are not screen space. `pack_on_load`: the workgroup fetch's first pass packs
/// its texels itself into workgroup memory (`SssPass::pack_on_load`, the choice on GPUs)
/// rather than after a pack step, after which its taps read the packed texture as the packed
/// fetch's do.
pub fn sss_traffic(
    settings: &SssSettings,
    pack_on_load: bool,
    width: u32,
    height: u32,
) -> Option<PassTraffic> {
    let colour = texel_bytes(sss::FORMAT);
    let mask = texel_bytes(lighting::SSS_FORMAT);
    let t = texels(settings.fetch);
    let packed = settings.fetch != SssFetch::Direct;
    // The packed fetch starts with the pack step: colour, depth and SSS data in, one packed
    // texel out. The workgroup fetch's separable passes have none: the first packs its
    // texels as it loads them.
    let input = texels(SssFetch::Direct).tap;
    let packs_as_it_loads = pack_on_load
        && settings.fetch == SssFetch::Workgroup
        && settings.method == SssMethod::Separable;
    let pack = if packed && !packs_as_it_loads {
        plain_step(input, t.tap)
    } else {
        PerPixel::default()
    };
    let per_pixel = match settings.method {
        SssMethod::None | SssMethod::Texture => return None,
        // One horizontal and one vertical pass of samples - 1 bilinear 1-D taps.
        SssMethod::Separable => {
            let taps = u64::from(settings.samples) - 1;
            let mut h = blur_step(t.tap, t.between, taps, 2);
            let mut v = blur_step(t.tap, t.last, taps, 2);
            if packs_as_it_loads {
                // Each workgroup loads its stretch and both aprons once (taps past the apron,
                // which read the texture, are left out).
                let span = u64::from(sss::WORKGROUP_SPAN) / u64::from(sss::WORKGROUP_TILE);
                h.read = input;
                h.read_taps = h.read * span;
                v.read_taps = t.tap * span;
            }
            pack + h + v
        }
        // One 2-D pass of 12 bilinear 2-D taps.
        SssMethod::Hable13 => pack + blur_step(t.tap, t.last, 12, 4),
        SssMethod::Gaussian6 => {
            // The narrowest Gaussian starts the accumulation: the colour and the profile row
            // in (one packed texel, or colour and SSS data), the weighted colour out.
            let start_read = if packed { t.tap } else { colour + mask };
            let mut total = pack + plain_step(start_read, colour);
            for _ in settings.gaussians.iter().filter(|g| **g) {
                // H: a 7-tap 1-D blur. V: the same, and its weighted result blended into the
                // accumulation target (the blend reads and writes it).
                let blur = blur_step(t.tap, t.between, 6, 2);
                total = total + blur + blur + plain_step(colour, colour);
            }
            // The accumulation written back on skin pixels (which pixels are skin, from the
            // packed input or the SSS data, and the accumulation in).
            let skin = if packed { t.tap } else { mask };
            total + plain_step(skin + colour, colour)
        }
    };
    Some(PassTraffic::from(
        "sss",
        per_pixel,
        u64::from(width) * u64::from(height),
    ))
}

/// The baseline copy (`copy.wgsl`) of the diffuse radiance target: one texel in, one out per
/// pixel.
pub fn copy_traffic(width: u32, height: u32) -> PassTraffic {
    let c = texel_bytes(lighting::RADIANCE_FORMAT);
    PassTraffic::from(
        "copy",
        plain_step(c, c),
        u64::from(width) * u64::from(height),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(method: SssMethod, samples: u32) -> SssSettings {
        SssSettings {
            method,
            samples,
            fetch: SssFetch::Direct,
            ..Default::default()
        }
    }

    /// The models worked by hand: Rgba16Float colour (8 B), R32Float depth (4 B), Rgba16Float
    /// SSS data (8 B), so a texel of a tap is 20 B and a written pixel 8 B.
    #[test]
    fn byte_model_by_hand() {
        let px = 100 * 10;
        let sep = sss_traffic(&settings(SssMethod::Separable, 17), false, 100, 10).unwrap();
        assert_eq!(sep.read_bytes, 2 * px * 20);
        assert_eq!(sep.write_bytes, 2 * px * 8);
        // Per pass: the centre and 16 taps of 2 texels.
        assert_eq!(sep.read_bytes_per_tap, 2 * px * 20 * 33);
        // Jitter moves the taps, not their number.
        let mut jittered = settings(SssMethod::Separable, 7);
        jittered.jitter = true;
        let j = sss_traffic(&jittered, false, 100, 10).unwrap();
        assert_eq!(j.read_bytes_per_tap, 2 * px * 20 * 13);
        assert_eq!(j.bytes(), sep.bytes());

        let hable = sss_traffic(&settings(SssMethod::Hable13, 17), false, 100, 10).unwrap();
        assert_eq!((hable.read_bytes, hable.write_bytes), (px * 20, px * 8));
        assert_eq!(hable.read_bytes_per_tap, px * 20 * 49);

        // Start (16 in, 8 out), five Gaussians of H (20, 8) and V (20 + 8 blend, 8 + 8),
        // resolve (16, 8).
        let g = sss_traffic(&settings(SssMethod::Gaussian6, 17), false, 100, 10).unwrap();
        assert_eq!(g.read_bytes, px * (16 + 5 * 48 + 16));
        assert_eq!(g.write_bytes, px * (8 + 5 * 24 + 8));
        assert_eq!(g.read_bytes_per_tap, px * (16 + 5 * (2 * 20 * 13 + 8) + 16));
        let mut three = settings(SssMethod::Gaussian6, 17);
        three.gaussians = [true, false, true, false, true];
        let g3 = sss_traffic(&three, false, 100, 10).unwrap();
        assert_eq!(g3.read_bytes, px * (16 + 3 * 48 + 16));

        for m in [SssMethod::None, SssMethod::Texture] {
            assert_eq!(sss_traffic(&settings(m, 17), false, 100, 10), None);
        }
        // Packed: the pack step (20 in, 16 out), then 16 B per texel of a tap and between the
        // steps, the last step writing the 8 B colour.
        let packed = |m| SssSettings {
            fetch: SssFetch::Packed,
            ..settings(m, 17)
        };
        let sep = sss_traffic(&packed(SssMethod::Separable), false, 100, 10).unwrap();
        assert_eq!(sep.read_bytes, px * (20 + 16 + 16));
        assert_eq!(sep.write_bytes, px * (16 + 16 + 8));
        assert_eq!(sep.read_bytes_per_tap, px * (20 + 2 * 16 * 33));
        let hable = sss_traffic(&packed(SssMethod::Hable13), false, 100, 10).unwrap();
        assert_eq!((hable.read_bytes, hable.write_bytes), (px * 36, px * 24));
        assert_eq!(hable.read_bytes_per_tap, px * (20 + 16 * 49));
        // Pack (20, 16), start (16, 8), five Gaussians of H (16, 16) and V (16 + 8 blend,
        // 16 + 8), resolve (16 + 8, 8).
        let g = sss_traffic(&packed(SssMethod::Gaussian6), false, 100, 10).unwrap();
        assert_eq!(g.read_bytes, px * (20 + 16 + 5 * 40 + 24));
        // Workgroup memory: 256 texels loaded per 128 pixels of a line, per pass; the first
        // pass packs the inputs (20 B) as it loads them, so no pack step.
        let w = SssSettings {
            fetch: SssFetch::Workgroup,
            ..settings(SssMethod::Separable, 17)
        };
        let on_load = sss_traffic(&w, true, 100, 10).unwrap();
        assert_eq!(on_load.read_bytes, px * (20 + 16));
        assert_eq!(on_load.write_bytes, px * (16 + 8));
        assert_eq!(on_load.read_bytes_per_tap, px * (20 * 2 + 16 * 2));
        // With a pack step first (on CPU adapters) the taps read the packed texture: the
        // packed fetch's traffic.
        let stepped = sss_traffic(&w, false, 100, 10).unwrap();
        assert_eq!(stepped, sep);
        assert_eq!(g.write_bytes, px * (16 + 8 + 5 * 40 + 8));

        let copy = copy_traffic(1280, 720);
        assert_eq!(copy.bytes(), 1280 * 720 * 16);
        // 14.7 MB at 10 GB/s: 1.47 ms.
        assert!((copy.bound_ms(10.0) - 1.47456).abs() < 1e-9);
    }
}
