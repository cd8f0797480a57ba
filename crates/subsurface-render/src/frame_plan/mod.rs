//! The frame plan: what one frame is made of, decided once from the settings, the scene and
//! the adapter, before any uniform is written. The renderer builds its targets and pipelines
//! from it and encodes the passes it names; the uniforms carry only what shaders read.
//!
//! ```text
//! shadow maps ──► flux pyramid (bounce) ──┐
//!      │                                  ▼
//!      ├──────────────► transmitted map (transmitted light, bounce; 1/N resolution)
//!      ▼                                  ▼
//! depth prepass ──► lighting (diffuse, specular, depth, skin) ──► SSS blur ──► tone map
//! ```
//!
//! Every decision that used to be read back from `LightsUniform` lives here: the transmitted
//! map's reduction and layers, whether it holds `diffusion`'s transmitted light, whether and
//! where the bounce is gathered, each lighting pipeline's variant, which objects gather their
//! own lateral taps, and each object's box on screen.

use glam::{Mat4, Vec3};

use crate::gpu_scene::{camera_uniform, world_per_mm};
use crate::passes::overrides::{Terms, bounce, lateral};
use crate::scene::{LightKind, Scene};
use crate::settings::{
    MapEvaluation, OutlineChords, RenderSettings, SssMethod, TransmittanceMethod,
};
use crate::uniforms::LightsUniform;

/// What the adapter can do that changes the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AdapterFeatures {
    /// Storage textures and workgroups large enough for the compute passes (the flux pyramid,
    /// the transmitted map's compute evaluation, the workgroup SSS fetch).
    pub compute_storage: bool,
    /// Its shaders run both sides of every branch for every invocation (a CPU rasteriser:
    /// llvmpipe masks rather than jumps), so a branch no pixel takes costs what its code costs.
    pub masked_branches: bool,
}

impl AdapterFeatures {
    /// Everything this renderer can use, on a GPU.
    pub const ALL: Self = Self {
        compute_storage: true,
        masked_branches: false,
    };

    /// What `device` supports.
    pub fn of(device: &wgpu::Device) -> Self {
        Self {
            compute_storage: crate::gpu::supports_compute_storage(device),
            masked_branches: device.adapter_info().device_type == wgpu::DeviceType::Cpu,
        }
    }
}

/// The layers of the transmitted map that hold `diffusion`'s transmitted light (0 diffuse, 1
/// unscattered and singly scattered); the bounce's layer, if any, follows them.
pub const TRANSMITTED_LAYERS: u32 = 2;

/// What a transmitted map is made of: its reduction (1: no map) and its layers (the transmitted
/// light's, and the bounce's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TransmittedMapShape {
    /// One map texel per `downsample` x `downsample` pixels; 1: no map.
    pub downsample: u32,
    /// Array layers: [`TRANSMITTED_LAYERS`] when the map holds the transmitted light, then one
    /// when it holds the bounce; 0: no map.
    pub layers: u32,
    /// The transmitted light and the bounce are evaluated by compute shaders on the texels'
    /// surfaces (`MapEvaluation::Compute` on an adapter that runs them) rather than in the
    /// map's fragment shaders.
    pub compute: bool,
}

impl TransmittedMapShape {
    /// No transmitted map.
    pub const NONE: Self = Self {
        downsample: 1,
        layers: 0,
        compute: false,
    };
}

/// What one lighting pipeline is built for: the lights' transmittance method
/// (`TransmittanceMethod::code`), where its pixels take the bounce from and where its
/// `diffusion` takes the lateral light from. A pipeline per variant, so that the shader
/// compiler drops the other variants' code (lighting.wgsl `BOUNCE_SOURCE`, transmittance.wgsl
/// `TRANSMITTANCE_METHOD` and `LATERAL_SOURCE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightingVariant {
    /// The transmittance method's code (`TransmittanceMethod::code`).
    pub method: u32,
    /// 0 no bounce, 1 the transmitted map's bounce layer, 2 a gather per pixel (no map).
    pub bounce: u32,
    /// 0 no lateral light (another method, or no taps), 1 the transmitted map (the lights' chords
    /// per pixel only where the map has no texel of the pixel's surface), 2 the taps per pixel
    /// (no map; with a map, the variant [`FramePlan::taps_objects`] are drawn with).
    pub lateral: u32,
    /// The optional terms it evaluates.
    pub terms: Terms,
    /// Where `lateral` is the map: each light's chord at the pixels the map misses runs in the
    /// outline pass after the lighting pass (lighting.wgsl `OUTLINE_PASS`), not in this
    /// pipeline.
    pub outline_pass: bool,
    /// The thickness debug view: the pipeline writes the thickness instead of the diffuse
    /// light (lighting.wgsl `THICKNESS_VIEW`). Not a setting: [`FramePlan::new`] leaves it off
    /// and the renderer sets it from its `DebugView`.
    pub thickness_view: bool,
}

/// One frame's structure. Made by [`FramePlan::new`]; compared with the last frame's to
/// decide what must be rebuilt.
#[derive(Clone, Debug, PartialEq)]
pub struct FramePlan {
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// The transmitted map's reduction: one texel per `N` x `N` pixels (1: the taps run per pixel).
    pub map_downsample: u32,
    /// The transmitted map holds `diffusion`'s transmitted light, every light summed, in its first
    /// [`TRANSMITTED_LAYERS`] layers.
    pub map_holds_transmitted: bool,
    /// `BounceSettings::ring` where the bounce runs (0: it does not).
    pub bounce_ring: u32,
    /// The transmitted map's layer the bounce is gathered into, if it is gathered on the map.
    pub bounce_layer: Option<u32>,
    /// The transmitted map's shape ([`TransmittedMapShape::NONE`]: no map).
    pub map: TransmittedMapShape,
    /// The lighting pipeline most pixels are drawn with.
    pub lighting: LightingVariant,
    /// For each uploaded object (those with triangles, in the scene's order): it evaluates
    /// `diffusion` itself (with its lateral taps, if any) although the frame has a transmitted
    /// map.
    pub taps_objects: Vec<bool>,
    /// The `lateral` source of the pipeline those objects are drawn with: the taps per pixel,
    /// or none where `diffusion` runs no taps.
    pub taps_objects_lateral: u32,
    /// Each uploaded object's box on screen, for the transmitted map's compute dispatches.
    pub object_rects: Vec<Option<[u32; 4]>>,
    /// For each uploaded object: the outline pass draws it (translucent skin in view that reads
    /// the map, where [`LightingVariant::outline_pass`]).
    pub outline_objects: Vec<bool>,
}

impl FramePlan {
    /// The plan for `scene` drawn at `settings.width` x `settings.height` on an adapter with
    /// `features`.
    pub fn new(scene: &Scene, settings: &RenderSettings, features: AdapterFeatures) -> Self {
        let (width, height) = (settings.width, settings.height);
        let t = &settings.transmittance;
        let lights = &scene.desc.lights;
        let map_downsample = map_downsample(scene, settings, width, height);
        let shadowed = lights.iter().any(|l| l.shadow_map_size > 0);
        let diffusion = t.method == TransmittanceMethod::Diffusion;
        let per_pixel = if t.lateral_taps > 0 {
            lateral::TAPS
        } else {
            lateral::NONE
        };
        // Lights without a shadow map transmit nothing.
        let map_holds_transmitted = diffusion && map_downsample > 1 && shadowed;
        // Point lights' six faces are not gathered (bounce.wgsl): only the others count.
        let bounced = lights
            .iter()
            .any(|l| l.shadow_map_size > 0 && l.kind != LightKind::Point);
        let mut bounce_ring = 0;
        if settings.bounce.enabled() && bounced && settings.sss.method != SssMethod::Texture {
            if features.compute_storage {
                bounce_ring = settings.bounce.ring;
            } else {
                log::warn!(
                    "bounce: this adapter has no compute storage textures; rendering without it"
                );
            }
        }
        let bounce_layer =
            (bounce_ring > 0 && map_downsample > 1).then_some(if map_holds_transmitted {
                TRANSMITTED_LAYERS
            } else {
                0
            });
        let layers = match bounce_layer {
            Some(layer) => layer + 1,
            None if map_holds_transmitted => TRANSMITTED_LAYERS,
            None => 0,
        };
        let map = if layers == 0 {
            TransmittedMapShape::NONE
        } else {
            TransmittedMapShape {
                downsample: map_downsample,
                layers,
                compute: features.compute_storage
                    && match settings.transmitted_map.pass {
                        MapEvaluation::Auto => !features.masked_branches,
                        MapEvaluation::Compute => true,
                        MapEvaluation::Fragment => false,
                    },
            }
        };
        let source = match (diffusion, map_downsample > 1) {
            (false, _) => lateral::NONE,
            (true, true) => lateral::MAP,
            (true, false) => per_pixel,
        };
        let lighting = LightingVariant {
            method: t.method.code(),
            bounce: match (bounce_ring, bounce_layer) {
                (0, _) => bounce::NONE,
                (_, Some(_)) => bounce::MAP,
                (_, None) => bounce::GATHER,
            },
            lateral: source,
            terms: Terms::of(settings),
            outline_pass: source == lateral::MAP
                && match settings.transmitted_map.outlines {
                    OutlineChords::Auto => features.masked_branches,
                    OutlineChords::Lighting => false,
                    OutlineChords::Pass => true,
                },
            thickness_view: false,
        };
        let taps_objects = lateral_taps_objects(scene, settings, width, height, map_downsample);
        let outline_objects = skin_pixel_mm(scene, width, height)
            .into_iter()
            .zip(&scene.objects)
            .filter(|(_, o)| !o.mesh.indices.is_empty())
            .zip(&taps_objects)
            .map(|((mm, _), taps)| lighting.outline_pass && mm.is_some() && !taps)
            .collect();
        Self {
            width,
            height,
            map_downsample,
            map_holds_transmitted,
            bounce_ring,
            bounce_layer,
            map,
            lighting,
            taps_objects,
            taps_objects_lateral: per_pixel,
            object_rects: screen_rects(scene, width, height),
            outline_objects,
        }
    }

    /// Whether the lighting pass reads the back faces (the thin parts' term): the targets then
    /// hold them at the frame's size (`LightingTargets::set_back_faces`).
    pub fn thin_parts(&self) -> bool {
        self.lighting.terms.0 & crate::passes::overrides::Terms::THIN_PARTS != 0
    }

    /// Writes what the shaders read of the plan into the lights' uniform: the transmitted map's
    /// reduction, the bounce's ring and layer.
    pub fn write_lights(&self, lights: &mut LightsUniform) {
        lights.map_downsample = self.map_downsample;
        lights.bounce_ring = self.bounce_ring;
        lights.bounce_layer = if self.map_holds_transmitted {
            TRANSMITTED_LAYERS
        } else {
            0
        };
    }
}

/// The transmitted map's reduction for `scene` at `width` x `height` with `settings`
/// ([`crate::settings::map_downsample`]): from the pixel's size in profile millimetres on
/// the translucent object in view nearest in those terms (`skin_pixel_mm`), so that the
/// map's texels are the same millimetres at any resolution and zoom (a farther object whose
/// texels come out too coarse gathers its own taps, [`lateral_taps_objects`]). 1 (no
/// map) unless `diffusion` runs on the screen (texture-space diffusion takes its transmitted
/// light from its UV-space pass). Without lateral taps the map still pays: the chord's slab,
/// the ballistic lobe and single scattering change over millimetres too, and on a GPU whose
/// fragment shading is slow for its size (the H200) evaluating them once per texel costs less
/// than once per pixel (docs/lab/performance.md, session 28).
pub fn map_downsample(scene: &Scene, settings: &RenderSettings, width: u32, height: u32) -> u32 {
    let diffusion = settings.transmittance.method == TransmittanceMethod::Diffusion;
    // The bounce is gathered on the same map (passes::bounce): it too changes over
    // millimetres.
    if !(diffusion || settings.bounce.enabled()) || settings.sss.method == SssMethod::Texture {
        return 1;
    }
    let pixel_mm = skin_pixel_mm(scene, width, height)
        .into_iter()
        .flatten()
        .fold(f32::INFINITY, f32::min);
    crate::settings::map_downsample(settings.transmitted_map.texel_mm, pixel_mm)
}

/// For each object of `scene` seen at `width` x `height`: the size of a pixel in its profile
/// millimetres at the depth of its bounds' centre (at least the near plane), where it is
/// translucent and may lie in view; `None` elsewhere.
fn skin_pixel_mm(scene: &Scene, width: u32, height: u32) -> Vec<Option<f32>> {
    let camera = camera_uniform(scene, width, height);
    let (position, forward) = (Vec3::from(camera.position), Vec3::from(camera.forward));
    let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
    scene
        .objects
        .iter()
        .map(|o| {
            if !(o.material.translucency > 0.0 && in_view(view_proj, o.world_bounds())) {
                return None;
            }
            let (lo, hi) = o.world_bounds();
            let depth = ((lo + hi) * 0.5 - position).dot(forward).max(camera.near);
            let mm = depth / camera.focal_px / (world_per_mm(o) * o.material.translucency);
            (mm.is_finite() && mm > 0.0).then_some(mm)
        })
        .collect()
}

/// Which of the uploaded objects (those with triangles, in the scene's order, as
/// [`upload_objects`] makes them) gather `diffusion`'s lateral taps at each pixel although the
/// frame has a transmitted map of reduction `downsample`: skin so much farther than the nearest
/// that its texels would span more than [`crate::settings::MAX_TEXEL_FACTOR`] times
/// `transmitted_map.texel_mm`. The lighting pass draws them with a pipeline that holds the taps
/// ([`LightingVariant::lateral`]); every other pixel reads the map with one that does not.
///
/// [`upload_objects`]: crate::gpu_scene::upload_objects
pub fn lateral_taps_objects(
    scene: &Scene,
    settings: &RenderSettings,
    width: u32,
    height: u32,
    downsample: u32,
) -> Vec<bool> {
    let limit = crate::settings::MAX_TEXEL_FACTOR * settings.transmitted_map.texel_mm;
    let coarse = |mm: Option<f32>| mm.is_some_and(|mm| downsample as f32 * mm > limit);
    scene
        .objects
        .iter()
        .zip(skin_pixel_mm(scene, width, height))
        .filter(|(o, _)| !o.mesh.indices.is_empty())
        .map(|(_, mm)| downsample > 1 && coarse(mm))
        .collect()
}

/// Each uploaded object's box on a `width` x `height` frame (those with triangles, in the
/// scene's order, as [`upload_objects`] makes them): the pixels `[x0, y0, x1, y1)` its world
/// bounds project to, the whole frame where the bounds reach behind the camera's eye, `None`
/// where they lie outside the view. The transmitted map's compute evaluation dispatches over each
/// object's box alone ([`FramePlan::object_rects`]).
///
/// [`upload_objects`]: crate::gpu_scene::upload_objects
pub fn screen_rects(scene: &Scene, width: u32, height: u32) -> Vec<Option<[u32; 4]>> {
    let camera = camera_uniform(scene, width, height);
    let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
    let (w, h) = (width as f32, height as f32);
    scene
        .objects
        .iter()
        .filter(|o| !o.mesh.indices.is_empty())
        .map(|o| {
            let bounds = o.world_bounds();
            if !in_view(view_proj, bounds) {
                return None;
            }
            let (lo, hi) = bounds;
            let mut min = glam::Vec2::splat(f32::INFINITY);
            let mut max = glam::Vec2::splat(f32::NEG_INFINITY);
            for c in crate::scene::box_corners(lo, hi) {
                let clip = view_proj * c.extend(1.0);
                // A corner at or behind the eye projects nowhere useful: the whole frame.
                if !clip.w.is_finite() || clip.w <= 1e-6 {
                    return Some([0, 0, width, height]);
                }
                let px = glam::Vec2::new(
                    (clip.x / clip.w * 0.5 + 0.5) * w,
                    (0.5 - clip.y / clip.w * 0.5) * h,
                );
                (min, max) = (min.min(px), max.max(px));
            }
            let x0 = min.x.floor().clamp(0.0, w) as u32;
            let y0 = min.y.floor().clamp(0.0, h) as u32;
            let x1 = max.x.ceil().clamp(0.0, w) as u32;
            let y1 = max.y.ceil().clamp(0.0, h) as u32;
            (x1 > x0 && y1 > y0).then_some([x0, y0, x1, y1])
        })
        .collect()
}

/// The pixels `[x0, y0, x1, y1)` the separable blur must cover on a `width` x `height` frame
/// ([`crate::passes::sss::SssPass::set_region`]): each skin object's box on screen
/// ([`screen_rects`]) grown by the farthest its taps reach there, a tap's offset in mm (plus
/// its jitter) times the pixels per mm at the box's nearest depth. Skin usually covers a part
/// of the frame, and the blur costs per pixel it runs on. `kernels` is the profile table and
/// `rows` each scene object's row in it; empty (`[0, 0, 0, 0]`) where no skin is in view.
pub fn sss_region(
    scene: &Scene,
    (width, height): (u32, u32),
    kernels: &[subsurface_profile::ScreenKernels],
    rows: &[u32],
    jitter: bool,
) -> [u32; 4] {
    let camera = camera_uniform(scene, width, height);
    let (position, forward) = (Vec3::from(camera.position), Vec3::from(camera.forward));
    let drawn = scene
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| !o.mesh.indices.is_empty());
    let mut region: Option<[u32; 4]> = None;
    for ((i, o), rect) in drawn.zip(screen_rects(scene, width, height)) {
        let (Some([x0, y0, x1, y1]), Some(kernel)) =
            (rect, rows.get(i).and_then(|&r| kernels.get(r as usize)))
        else {
            continue;
        };
        if o.material.sss_strength <= 0.0 {
            continue;
        }
        let taps = &kernel.separable;
        let widths = if jitter {
            subsurface_profile::separable_jitter_widths(taps)
        } else {
            vec![0.0; taps.len()]
        };
        let reach_mm = taps
            .iter()
            .zip(&widths)
            .map(|(t, w)| t[3].abs() + w)
            .fold(0.0f32, f32::max);
        let (lo, hi) = o.world_bounds();
        let nearest = crate::scene::box_corners(lo, hi)
            .iter()
            .map(|c| (*c - position).dot(forward))
            .fold(f32::INFINITY, f32::min)
            .max(camera.near);
        let px_per_mm = world_per_mm(o) * camera.focal_px / nearest * o.material.sss_strength;
        // Two more pixels: a tap reads the two texels around it (bilinear weights).
        let reach = (reach_mm * px_per_mm).ceil() + 2.0;
        let grow = if reach.is_finite() && reach < (width.max(height)) as f32 {
            reach as u32
        } else {
            width.max(height)
        };
        let rect = [
            x0.saturating_sub(grow),
            y0.saturating_sub(grow),
            x1.saturating_add(grow).min(width),
            y1.saturating_add(grow).min(height),
        ];
        region = Some(match region {
            None => rect,
            Some(r) => [
                r[0].min(rect[0]),
                r[1].min(rect[1]),
                r[2].max(rect[2]),
                r[3].max(rect[3]),
            ],
        });
    }
    region.unwrap_or([0; 4])
}

/// Whether any of the box `(lo, hi)` may lie in the view of `view_proj` (wgpu clip space): no
/// frustum plane has all eight corners outside it.
fn in_view(view_proj: Mat4, (lo, hi): (Vec3, Vec3)) -> bool {
    let corners = crate::scene::box_corners(lo, hi).map(|c| view_proj * c.extend(1.0));
    let outside = |f: &dyn Fn(&glam::Vec4) -> bool| corners.iter().all(f);
    !(outside(&|c| c.x < -c.w)
        || outside(&|c| c.x > c.w)
        || outside(&|c| c.y < -c.w)
        || outside(&|c| c.y > c.w)
        || outside(&|c| c.z < 0.0)
        || outside(&|c| c.z > c.w))
}

#[cfg(test)]
mod tests;
