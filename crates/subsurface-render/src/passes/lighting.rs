//! The lighting pass: Lambert diffuse with albedo, the rough boundary's specular (Cook-Torrance
//! with Beckmann facets and Smith masking, `subsurface_profile::specular`), normal
//! maps, spot falloff, inverse-square attenuation and shadows filtered by percentage-closer
//! gathers on the shadow maps' z-buffer (linear light distance stays for thickness). A depth
//! pre-pass first keeps the nearest surface, so the shader runs once per pixel. It writes
//! diffuse and specular apart (only diffuse is blurred by subsurface scattering), linear depth
//! and the per-pixel SSS strength.
//!
//! With `diffusion` and lateral taps, a lateral pass runs first: the meshes' front faces again
//! at a reduced resolution ([`LateralTargets`], the reduction from
//! `gpu_scene::lateral_downsample`), where `diffusion`'s whole transmitted light is evaluated,
//! every light together, into a map the lighting pass then interpolates once per pixel
//! (transmittance.wgsl, `transmitted_from_map`); a lighting pipeline built for the map holds
//! no taps of its own ([`lateral_source`]). By default (`LateralPass::Compute`) that pass only
//! records each texel's surface and a compute shader evaluates it, once per object, as it does
//! the bounce (lateral.wgsl); otherwise its fragment shaders do.
//!
//! Group 0 (camera, lights, shadow maps, translucent shadow maps) is built by [`frame_layout`];
//! group 1 is the object's (`gpu_scene::object_layout`), group 2 the object's texture-space
//! maps ([`maps::maps_layout`]), group 3 the lateral map ([`screen_layout`]; the lateral pass
//! has no group 3). The texture-space pass draws its UV-space
//! irradiance with the same groups (`texture_space::irradiance`), group 3 being
//! [`LightingPass::no_lateral_map`].

use wgpu::util::DeviceExt;

use crate::TransmittanceMethod;
use crate::gpu::GpuContext;
use crate::gpu_scene::GpuObject;
use crate::passes::maps;
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{CameraUniform, LightsUniform, MAX_LIGHTS};

pub const SHADER: &str = concat!(
    include_str!("common.wgsl"),
    include_str!("lighting.wgsl"),
    include_str!("shadow_lookup.wgsl"),
    include_str!("transmittance.wgsl"),
    include_str!("bounce.wgsl"),
    include_str!("lateral.wgsl")
);
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// r = SSS strength, g = scene units per profile millimetre, b = profile index (exact in f16
/// up to 2048), a unused. Half floats keep the four targets within the 32 bytes per sample
/// every adapter allows.
pub const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// What the lighting pass writes, and what screen-space SSS reads.
pub struct LightingTargets {
    pub width: u32,
    pub height: u32,
    /// Diffuse radiance (irradiance x albedo), linear HDR: the image that is blurred.
    pub diffuse: wgpu::Texture,
    /// Specular radiance, linear HDR: added after the blur.
    pub specular: wgpu::Texture,
    /// Linear view depth in scene units (the camera's far plane where nothing was drawn).
    pub depth: wgpu::Texture,
    /// r = SSS strength (0 = not skin), g = scene units per profile millimetre.
    pub sss: wgpu::Texture,
    zbuffer: wgpu::TextureView,
    /// `diffusion`'s lateral light at reduced resolution, when the targets were made with a
    /// `lateral_downsample` above 1.
    pub lateral: Option<LateralTargets>,
    /// Group 3 of the lighting pass ([`screen_layout`]): the lateral map, or a 1x1 stand-in.
    screen: wgpu::BindGroup,
}

/// The lateral pass's targets, of `LATERAL_FORMAT` at `ceil(size / downsample)`: layers 0 and
/// 1 ([`TRANSMITTED_LAYERS`]) hold `diffusion`'s transmitted light at the texel's surface, every
/// light's radiance summed (0: the diffuse part, which joins the irradiance; 1: the unscattered
/// and singly scattered part, which joins the specular target), a = the texel's view depth
/// (0: nothing there); the bounce's layer comes after them (`bounce_layer`). And the z-buffer of
/// that resolution.
pub struct LateralTargets {
    pub downsample: u32,
    /// Layers of `map`.
    pub layer_count: u32,
    pub width: u32,
    pub height: u32,
    pub map: wgpu::Texture,
    layers: Vec<wgpu::TextureView>,
    zbuffer: wgpu::TextureView,
    /// Where the transmitted light and the bounce are evaluated in a compute shader
    /// ([`LateralShape::compute`] on an adapter that supports it): the texels' surfaces.
    surface: Option<LateralSurface>,
    /// What the shape asked for (an adapter without storage textures evaluates in the fragment
    /// shader all the same): compared with the next frame's shape.
    compute_asked: bool,
}

/// The lateral map's texels' surfaces (`fs_surface` in lateral.wgsl): world position and view
/// depth; the normal turned toward the camera and the object's index. `cs_transmitted`
/// evaluates the transmitted light there.
struct LateralSurface {
    targets: [wgpu::TextureView; 2],
    /// Group 2 of `cs_transmitted` ([`lateral_compute_layout`]): the surfaces, and the map
    /// written as storage.
    bind_group: wgpu::BindGroup,
}

/// Layout of group 2 of the lateral map's compute evaluation (`surface_position`,
/// `surface_normal` and `transmitted_out` in lateral.wgsl).
pub fn lateral_compute_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    let d2 = wgpu::TextureViewDimension::D2;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lateral compute"),
        entries: &[
            util::float_texture_entry(8, compute, false, d2),
            util::float_texture_entry(9, compute, false, d2),
            util::storage_texture_entry(
                10,
                compute,
                LATERAL_FORMAT,
                wgpu::TextureViewDimension::D2Array,
            ),
        ],
    })
}

/// Layout of group 3 of the lateral map's compute evaluation: `dispatch_origin` in
/// lateral.wgsl, one entry per object at a dynamic offset ([`ObjectRects`]).
fn dispatch_origin_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lateral dispatch origin"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 1,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: wgpu::BufferSize::new(16),
            },
            count: None,
        }],
    })
}

/// Each object's box on the lateral map, for its compute dispatch: texels `[x0, y0, x1, y1)`
/// (`None`: not in view, no dispatch), for a map of reduction `downsample`. The buffer holds
/// each box's first texel at a stride the device's dynamic offsets allow, and after them a
/// zero origin for objects without a box (the whole map).
struct ObjectRects {
    downsample: u32,
    rects: Vec<Option<[u32; 4]>>,
    stride: u32,
    bind_group: wgpu::BindGroup,
}

impl ObjectRects {
    /// `pixels`: each object's box in pixels of the frame (`gpu_scene::screen_rects`).
    fn new(device: &wgpu::Device, pixels: &[Option<[u32; 4]>], downsample: u32) -> Self {
        let d = downsample.max(1);
        // The rasteriser covers only texel centres inside the box's projection: one texel more
        // each way absorbs the rounding between it and the CPU's projection.
        let rects: Vec<_> = pixels
            .iter()
            .map(|r| {
                r.map(|[x0, y0, x1, y1]| {
                    [
                        (x0 / d).saturating_sub(1),
                        (y0 / d).saturating_sub(1),
                        x1.div_ceil(d) + 1,
                        y1.div_ceil(d) + 1,
                    ]
                })
            })
            .collect();
        let stride = device.limits().min_uniform_buffer_offset_alignment.max(16);
        let mut bytes = vec![0u8; (rects.len() + 1) * stride as usize];
        for (k, r) in rects.iter().enumerate() {
            if let Some([x0, y0, _, _]) = r {
                let at = k * stride as usize;
                bytes[at..at + 4].copy_from_slice(&x0.to_le_bytes());
                bytes[at + 4..at + 8].copy_from_slice(&y0.to_le_bytes());
            }
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("lateral dispatch origins"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = util::bind_group(
            device,
            "lateral dispatch origins",
            &dispatch_origin_layout(device),
            [(
                1,
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(16),
                }),
            )],
        );
        Self {
            downsample: d,
            rects,
            stride,
            bind_group,
        }
    }

    /// The dynamic offset of the entry after the objects': origin (0, 0), for dispatches over
    /// the whole map.
    fn whole_offset(&self) -> u32 {
        self.rects.len() as u32 * self.stride
    }

    /// Object `k`'s dispatch on a `w` x `h` map of reduction `downsample`: the dynamic offset
    /// of its origin and its size in texels; the whole map where it has no box (or the boxes
    /// were made for another reduction), `None` where it is out of view.
    fn dispatch(&self, k: usize, downsample: u32, w: u32, h: u32) -> Option<(u32, u32, u32)> {
        let whole = (self.whole_offset(), w, h);
        if downsample != self.downsample {
            return Some(whole);
        }
        match self.rects.get(k) {
            None => Some(whole),
            Some(None) => None,
            Some(Some([x0, y0, x1, y1])) => {
                let (x1, y1) = ((*x1).min(w), (*y1).min(h));
                (x1 > *x0 && y1 > *y0).then_some((k as u32 * self.stride, x1 - x0, y1 - y0))
            }
        }
    }
}

/// 32-bit depth beside the light: the lighting pass compares it with its own pixel's to the
/// fraction of a millimetre, at any distance. Read with loads (no filtering needed).
pub const LATERAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

impl LateralTargets {
    /// `compute`: with the surfaces the compute evaluations of the transmitted light and the
    /// bounce read (ignored where the adapter cannot run them, `util::supports_compute_storage`).
    pub fn new(
        ctx: &GpuContext,
        width: u32,
        height: u32,
        downsample: u32,
        layers: u32,
        compute: bool,
    ) -> Self {
        let device = &ctx.device;
        let downsample = downsample.max(1);
        // The transmitted light's two, and the bounce's after them.
        let layer_count = layers.clamp(1, TRANSMITTED_LAYERS + 1);
        let (w, h) = (width.div_ceil(downsample), height.div_ceil(downsample));
        let compute_asked = compute;
        let compute = compute && util::supports_compute_storage(device);
        let storage = if compute {
            wgpu::TextureUsages::STORAGE_BINDING
        } else {
            wgpu::TextureUsages::empty()
        };
        let map = util::texture_2d(
            device,
            "lateral map",
            w,
            h,
            layer_count,
            LATERAL_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | storage,
        );
        let layers = (0..layer_count)
            .map(|layer| {
                map.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("lateral map layer"),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let surface = compute.then(|| {
            let target = |label| {
                util::texture_2d(
                    device,
                    label,
                    w,
                    h,
                    1,
                    LATERAL_FORMAT,
                    wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                )
                .create_view(&Default::default())
            };
            let targets = [
                target("lateral surface position"),
                target("lateral surface normal"),
            ];
            let map_view = util::array_view(&map);
            let bind_group = util::bind_group(
                device,
                "lateral compute",
                &lateral_compute_layout(device),
                [
                    (8, wgpu::BindingResource::TextureView(&targets[0])),
                    (9, wgpu::BindingResource::TextureView(&targets[1])),
                    (10, wgpu::BindingResource::TextureView(&map_view)),
                ],
            );
            LateralSurface {
                targets,
                bind_group,
            }
        });
        Self {
            downsample,
            layer_count,
            width: w,
            height: h,
            map,
            layers,
            zbuffer: util::depth_buffer(device, "lateral z-buffer", w, h),
            surface,
            compute_asked,
        }
    }

    /// Whether compute shaders evaluate the map on the texels' surfaces.
    pub fn computed(&self) -> bool {
        self.surface.is_some()
    }
}

/// Layout of group 3 of the lighting pass (`lateral_map` in lighting.wgsl). Pipelines built on
/// the lighting shader that do not read the map (the texture-space irradiance) take the same
/// layout and bind [`LightingPass::no_lateral_map`].
pub fn screen_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lighting screen"),
        entries: &[util::float_texture_entry(
            0,
            wgpu::ShaderStages::FRAGMENT,
            false,
            wgpu::TextureViewDimension::D2Array,
        )],
    })
}

fn screen_bind_group(device: &wgpu::Device, map: &wgpu::Texture) -> wgpu::BindGroup {
    let view = map.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    util::bind_group(
        device,
        "lighting screen",
        &screen_layout(device),
        [(0, wgpu::BindingResource::TextureView(&view))],
    )
}

fn dummy_lateral_map(device: &wgpu::Device) -> wgpu::Texture {
    util::texture_2d(
        device,
        "no lateral map",
        1,
        1,
        1,
        LATERAL_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING,
    )
}

impl LightingTargets {
    /// Without a lateral map: `diffusion` runs its lateral taps at every pixel.
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Self {
        Self::with_lateral(ctx, width, height, LateralShape::NONE)
    }

    /// With `diffusion`'s lateral map of `lateral`'s shape (none for a reduction of 1).
    pub fn with_lateral(ctx: &GpuContext, width: u32, height: u32, lateral: LateralShape) -> Self {
        let device = &ctx.device;
        let (lateral, screen) = lateral_targets(ctx, width, height, lateral);
        let target = |label, format| util::render_target(device, label, width, height, format);
        Self {
            width,
            height,
            // Storage too where the adapter can: the workgroup fetch's vertical SSS pass
            // writes it from a compute shader.
            diffuse: util::render_target_with(
                device,
                "diffuse",
                width,
                height,
                RADIANCE_FORMAT,
                if util::supports_compute_storage(device) {
                    wgpu::TextureUsages::STORAGE_BINDING
                } else {
                    wgpu::TextureUsages::empty()
                },
            ),
            specular: target("specular", RADIANCE_FORMAT),
            depth: target("linear depth", DEPTH_FORMAT),
            sss: target("sss strength", SSS_FORMAT),
            zbuffer: util::depth_buffer(device, "z-buffer", width, height),
            lateral,
            screen,
        }
    }

    /// The lateral map's reduction (1 without one).
    pub fn lateral_downsample(&self) -> u32 {
        self.lateral.as_ref().map_or(1, |l| l.downsample)
    }

    /// Where the lateral map holds the transmitted light: whether a compute shader evaluates
    /// it (`LateralPass::Compute` on an adapter that runs it) rather than the map's fragment
    /// shader. None without such a map.
    pub fn lateral_computed(&self) -> Option<bool> {
        self.lateral
            .as_ref()
            .filter(|l| l.layer_count >= TRANSMITTED_LAYERS)
            .map(LateralTargets::computed)
    }

    /// The shape of the lateral map these targets hold.
    pub fn lateral_shape(&self) -> LateralShape {
        self.lateral
            .as_ref()
            .map_or(LateralShape::NONE, |l| LateralShape {
                downsample: l.downsample,
                layers: l.layer_count,
                compute: l.compute_asked,
            })
    }

    /// A new lateral map of `lateral`'s shape, the other targets kept: the reduction follows
    /// the skin's size on screen, so a camera moving nearer changes it without a new frame
    /// size, and a light added to the scene may need a layer more.
    pub fn set_lateral(&mut self, ctx: &GpuContext, lateral: LateralShape) {
        (self.lateral, self.screen) = lateral_targets(ctx, self.width, self.height, lateral);
    }
}

/// What a lateral map is made of: its reduction (1: no map) and its layers (the transmitted
/// light's, and the bounce's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LateralShape {
    pub downsample: u32,
    pub layers: u32,
    /// The transmitted light and the bounce are evaluated by compute shaders on the texels'
    /// surfaces (`LateralPass::Compute`) rather than in the map's fragment shaders.
    pub compute: bool,
}

impl LateralShape {
    pub const NONE: Self = Self {
        downsample: 1,
        layers: 0,
        compute: false,
    };

    /// For `lights` ([`transmitted_map`]; their uniform's `lateral_downsample`): none where
    /// neither the transmitted light nor the bounce needs one.
    pub fn for_lights(lights: &LightsUniform) -> Self {
        let layers = match bounce_layer(lights) {
            Some(layer) => layer + 1,
            None if transmitted_map(lights) => TRANSMITTED_LAYERS,
            None => 0,
        };
        if layers == 0 {
            return Self::NONE;
        }
        Self {
            downsample: lights.lateral_downsample,
            layers,
            compute: lights.lateral_compute != 0,
        }
    }
}

/// The lateral map of a `width` x `height` frame of `shape` (none for a reduction of 1) and
/// the lighting pass's group 3 that reads it (a 1x1 stand-in without one).
fn lateral_targets(
    ctx: &GpuContext,
    width: u32,
    height: u32,
    shape: LateralShape,
) -> (Option<LateralTargets>, wgpu::BindGroup) {
    let device = &ctx.device;
    let lateral = (shape.downsample > 1 && shape.layers > 0).then(|| {
        LateralTargets::new(
            ctx,
            width,
            height,
            shape.downsample,
            shape.layers,
            shape.compute,
        )
    });
    let screen = match &lateral {
        Some(l) => screen_bind_group(device, &l.map),
        None => screen_bind_group(device, &dummy_lateral_map(device)),
    };
    (lateral, screen)
}

/// The layers of the lateral map that hold `diffusion`'s transmitted light (0 diffuse, 1
/// unscattered and singly scattered); the bounce's layer, if any, follows them.
pub const TRANSMITTED_LAYERS: u32 = 2;

/// Whether the lateral pass evaluates `diffusion`'s transmitted light for `lights` into the
/// lateral map: `diffusion` with taps and a map, and a light with a shadow map (the others
/// transmit nothing).
pub fn transmitted_map(lights: &LightsUniform) -> bool {
    let diffusion = crate::settings::TransmittanceMethod::Diffusion.code();
    lights.transmittance == diffusion
        && lights.lateral_taps > 0
        && lights.lateral_downsample > 1
        && (0..lights.count.min(MAX_LIGHTS as u32))
            .any(|i| lights.lights[i as usize].first_layer >= 0.0)
}

/// The lateral map's layer that the bounce pass fills for `lights` (`bounce_layer`, after the
/// transmitted light's layers), if the bounce is gathered on the map.
pub fn bounce_layer(lights: &LightsUniform) -> Option<u32> {
    (lights.bounce_ring > 0 && lights.lateral_downsample > 1).then_some(lights.bounce_layer)
}

/// Layout of group 0 of the lighting pass (`camera`, `lights`, `shadow_atlas`, `tsm_atlas`,
/// `shadow_depth` and `shadow_compare` in lighting.wgsl, `flux_position`, `flux_normal` and
/// `flux_spread` in bounce.wgsl). Equal layouts are interchangeable,
/// so other pipelines built on the lighting shader (the texture-space irradiance) may bind
/// [`LightingPass::frame_bind_group`].
pub fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Compute too: the lateral map's evaluation (lateral.wgsl, `cs_transmitted`) reads the
    // camera, the lights and the shadow maps.
    let stages = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let uniform = |binding| util::uniform_entry(binding, wgpu::ShaderStages::VERTEX | stages);
    // Shadow and translucent shadow map arrays: 32-bit floats, so not filterable.
    let atlas = |binding| {
        util::float_texture_entry(binding, stages, false, wgpu::TextureViewDimension::D2Array)
    };
    // The shadow maps' z-buffer, read through a comparison sampler: each gather tests a 2x2
    // block of texels in the texture unit (hardware PCF).
    let depth = wgpu::BindGroupLayoutEntry {
        binding: 4,
        visibility: stages,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lighting frame"),
        entries: &[
            uniform(0),
            uniform(1),
            atlas(2),
            atlas(3),
            depth,
            // The flux pyramid (passes::bounce), also 32-bit floats.
            atlas(6),
            atlas(7),
            atlas(8),
            util::sampler_entry(5, stages, wgpu::SamplerBindingType::Comparison),
        ],
    })
}

/// The shadow maps the lighting pass reads ([`crate::passes::shadow::ShadowPass::maps`]).
#[derive(Clone, Copy)]
pub struct ShadowMaps<'a> {
    /// Linear light distance and entry normal per texel (`Rg32Float` array): thickness.
    pub atlas: &'a wgpu::TextureView,
    /// The same layers' z-buffer (`Depth32Float` array): percentage-closer filtering through
    /// a comparison sampler.
    pub depth: &'a wgpu::TextureView,
    /// The flux pyramid's position and normal sums (`bounce::FluxPyramid`), where the
    /// bounce is gathered.
    pub flux: Option<[&'a wgpu::TextureView; 3]>,
}

/// One raster pass at the lateral map's resolution: `pipeline` into `targets` (layers of the
/// map, or the texels' surfaces), timed as `timed`, the first of a frame clearing the map's
/// z-buffer (the later ones shade only the surfaces it kept).
struct MapPass<'a> {
    timed: &'static str,
    targets: Vec<&'a wgpu::TextureView>,
    first: bool,
    pipeline: &'a wgpu::RenderPipeline,
}

/// One compute pass of [`LightingPass::encode_compute`]: `pipeline` (spread over lanes, a
/// workgroup per [`SPREAD_BLOCK`]) once per object, after `clear` over the whole map where
/// given.
struct Compute<'a> {
    timed: &'a str,
    clear: Option<&'a wgpu::ComputePipeline>,
    pipeline: &'a wgpu::ComputePipeline,
}

/// The WGSL override that fixes a pipeline's transmittance method (transmittance.wgsl).
const METHOD_CONSTANT: &str = "TRANSMITTANCE_METHOD";

/// The lateral pass's overrides: `diffusion`, the lateral taps included (LATERAL_SOURCE 2).
const DIFFUSION_WHOLE: [(&str, f64); 2] = [
    (
        METHOD_CONSTANT,
        TransmittanceMethod::Diffusion.code() as f64,
    ),
    (LATERAL_CONSTANT, 2.0),
];

/// `cs_transmitted`'s overrides: as [`DIFFUSION_WHOLE`], with the taps' sum gathered over the
/// texel's invocations before `transmittance` (LATERAL_SOURCE 3).
const DIFFUSION_SPREAD: [(&str, f64); 2] = [
    (
        METHOD_CONSTANT,
        TransmittanceMethod::Diffusion.code() as f64,
    ),
    (LATERAL_CONSTANT, 3.0),
];

/// `cs_transmitted`'s and `cs_bounce`'s invocations per texel (lateral.wgsl, `TEXEL_LANES`),
/// and the block of texels (across, down) a workgroup of 64 takes. On an H200, eight lanes
/// took the default scene's transmitted light (two lights) in half the time of one (1280x720:
/// 0.051 ms against 0.106) and the head's (three lights, a larger map) in two thirds; sixteen
/// gained 0.002 ms on the first and lost 0.013 on the second. The bounce's gather went from
/// 0.43 to 0.12 ms (docs/performance.md).
const TEXEL_LANES: u32 = 8;
const SPREAD_BLOCK: [u32; 2] = [4, 2];
// Each light needs a lane of its own for its entry and the rest of its transmittance.
const _: () = assert!(TEXEL_LANES as usize >= crate::uniforms::MAX_LIGHTS);
/// Texels per workgroup of `cs_clear`, across and down: 8 x 8, one invocation each.
const TEXEL_BLOCK: u32 = 8;

/// `base` with the overrides that spread a texel over lanes (`cs_transmitted`, `cs_bounce`).
fn spread_constants(base: &[(&'static str, f64)]) -> Vec<(&'static str, f64)> {
    let [width, height] = SPREAD_BLOCK;
    [
        base,
        &[
            ("TEXEL_LANES", f64::from(TEXEL_LANES)),
            ("BLOCK_WIDTH", f64::from(width)),
            ("BLOCK_HEIGHT", f64::from(height)),
        ],
    ]
    .concat()
}

/// The WGSL override that fixes where a pipeline's pixels take the bounce from (lighting.wgsl,
/// `BOUNCE_SOURCE`).
const BOUNCE_CONSTANT: &str = "BOUNCE_SOURCE";

/// Where the lighting pass takes the bounce from for `lights`: 0 nowhere, 1 the lateral map's
/// bounce layer, 2 a gather per pixel (no map). A pipeline per source, so that the compiler
/// drops the gather where the map serves.
pub fn bounce_source(lights: &LightsUniform) -> u32 {
    match (lights.bounce_ring, bounce_layer(lights)) {
        (0, _) => 0,
        (_, Some(_)) => 1,
        (_, None) => 2,
    }
}

/// The WGSL override that fixes where a pipeline's `diffusion` takes its lateral light from
/// (transmittance.wgsl, `LATERAL_SOURCE`).
const LATERAL_CONSTANT: &str = "LATERAL_SOURCE";

/// Where the lighting pass takes `diffusion` from for `lights`: 0 per pixel without lateral
/// light (another method, or no taps), 1 the transmitted map (every light's transmitted light
/// in one read; the lights' chords per pixel only where the map has no texel of the pixel's
/// surface), 2 per pixel with the taps (no map; with a map, the variant
/// [`LightingPass::set_taps_objects`] draws skin too far for it with). A pipeline per source,
/// so that the map's holds no tap loop.
pub fn lateral_source(lights: &LightsUniform) -> u32 {
    let diffusion = crate::settings::TransmittanceMethod::Diffusion.code();
    if lights.transmittance != diffusion || lights.lateral_taps == 0 {
        0
    } else if lights.lateral_downsample > 1 {
        1
    } else {
        2
    }
}

/// What one lighting pipeline is built for: the lights' transmittance method
/// (`TransmittanceMethod::code`), its bounce source ([`bounce_source`]) and its lateral
/// light's source ([`lateral_source`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightingVariant {
    pub method: u32,
    pub bounce: u32,
    pub lateral: u32,
}

impl LightingVariant {
    /// The variant `lights` asks for.
    pub fn for_lights(lights: &LightsUniform) -> Self {
        Self {
            method: lights.transmittance,
            bounce: bounce_source(lights),
            lateral: lateral_source(lights),
        }
    }
}

/// The lighting pass's `fs_main` built for `variant`.
fn lighting_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    variant: LightingVariant,
) -> wgpu::RenderPipeline {
    util::MeshPipeline {
        label: "lighting",
        layout,
        module,
        vertex: "vs_main",
        fragment: "fs_main",
        targets: &[RADIANCE_FORMAT, RADIANCE_FORMAT, DEPTH_FORMAT, SSS_FORMAT],
        // Not culled: glTF skin meshes are often open (wrists, necks) and the shader flips
        // the normal of back faces.
        cull_mode: None,
        depth: util::DepthTest::Prepassed,
        constants: &[
            (METHOD_CONSTANT, f64::from(variant.method)),
            (BOUNCE_CONSTANT, f64::from(variant.bounce)),
            (LATERAL_CONSTANT, f64::from(variant.lateral)),
        ],
    }
    .create(device)
}

pub struct LightingPass {
    /// Depth only, the lighting shader's vertex stage: the nearest surface per pixel.
    prepass: wgpu::RenderPipeline,
    /// `fs_main` built per [`LightingVariant`], each kept once built: switching methods back
    /// and forth in the viewer compiles each once. See [`Self::specialize`].
    pipelines: Vec<(LightingVariant, wgpu::RenderPipeline)>,
    /// The index in `pipelines` of the variant the lights uniform asks for.
    current: usize,
    /// Where `current` reads the lateral map: the index in `pipelines` of its variant that
    /// gathers the taps at each pixel instead, for the objects `taps_objects` marks (skin too
    /// far for the map's texels, [`Self::set_taps_objects`]).
    taps: Option<usize>,
    taps_objects: Vec<bool>,
    module: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    /// `fs_transmitted` into the transmitted light's two layers of the lateral map, keeping
    /// the nearest surface in the map's z-buffer (the bounce pass after it shades only that).
    lateral: wgpu::RenderPipeline,
    /// `fs_surface` into the texels' surfaces, keeping the nearest surface as `lateral` does;
    /// `cs_transmitted` and `cs_bounce` then evaluate the transmitted light and the bounce
    /// there, once per object (each built the first time a frame asks for it,
    /// [`Self::prepare`]).
    surface: wgpu::RenderPipeline,
    transmitted_compute: Option<wgpu::ComputePipeline>,
    bounce_compute: Option<wgpu::ComputePipeline>,
    /// `cs_clear`: every layer of the map to nothing, first in the frame's first compute pass.
    clear_compute: Option<wgpu::ComputePipeline>,
    /// `cs_transmitted`'s layout: the frame's group, the object's, [`lateral_compute_layout`],
    /// [`dispatch_origin_layout`].
    compute_layout: wgpu::PipelineLayout,
    /// Each object's box for its dispatch ([`Self::set_object_rects`]; none: the whole map).
    object_rects: ObjectRects,
    /// `[first pass, later passes]`: `fs_bounce` into the map's bounce layer.
    bounce: [wgpu::RenderPipeline; 2],
    /// The lateral map's layer the bounce is gathered into ([`bounce_layer`]), if any.
    bounce_layer: Option<u32>,
    /// Group 3 for pipelines that take the screen layout but never read the map.
    no_lateral_map: wgpu::BindGroup,
    frame_bind_group: wgpu::BindGroup,
    /// Group 2 for objects without texture-space maps.
    default_maps: wgpu::BindGroup,
    /// Written only through [`Self::prepare`], which keeps the pipeline's transmittance
    /// method the lights uniform's.
    camera: wgpu::Buffer,
    lights: wgpu::Buffer,
}

impl LightingPass {
    /// Without texture-space maps or translucent shadow maps.
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        camera: &CameraUniform,
        lights: &LightsUniform,
        shadow: ShadowMaps<'_>,
    ) -> Self {
        let maps_layout = maps::maps_layout(&ctx.device);
        let tsm = maps::dummy_tsm_view(&ctx.device);
        Self::with_maps(
            ctx,
            object_layout,
            &maps_layout,
            camera,
            lights,
            shadow,
            &tsm,
        )
    }

    /// `maps_layout` is [`maps::maps_layout`] (group 2, per object); `tsm_atlas` the
    /// translucent shadow maps (`Rg32Float` array, same layers as the shadow maps).
    pub fn with_maps(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        maps_layout: &wgpu::BindGroupLayout,
        camera: &CameraUniform,
        lights: &LightsUniform,
        shadow: ShadowMaps<'_>,
        tsm_atlas: &wgpu::TextureView,
    ) -> Self {
        let device = &ctx.device;
        let shadow_compare = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow compare"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            // Lit where the receiver's biased depth is at most the occluder's.
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let bounce_layer = bounce_layer(lights);
        let key = LightingVariant::for_lights(lights);
        let asked = *lights;
        let no_flux = crate::passes::bounce::dummy_views(device);
        let flux = shadow
            .flux
            .unwrap_or([&no_flux[0], &no_flux[1], &no_flux[2]]);
        let module = util::wgsl_module(device, "lighting.wgsl", SHADER);
        let frame_layout = frame_layout(device);
        let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::bytes_of(camera),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let lights = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("lights"),
            contents: bytemuck::bytes_of(lights),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("lighting frame"),
            layout: &frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: lights.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(shadow.atlas),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(tsm_atlas),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(shadow.depth),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::Sampler(&shadow_compare),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(flux[0]),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::TextureView(flux[1]),
                },
                wgpu::BindGroupEntry {
                    binding: 8,
                    resource: wgpu::BindingResource::TextureView(flux[2]),
                },
            ],
        });
        let prepass_layout = util::pipeline_layout(
            device,
            "depth prepass",
            &[&frame_layout, object_layout, maps_layout],
        );
        let layout = util::pipeline_layout(
            device,
            "lighting",
            &[
                &frame_layout,
                object_layout,
                maps_layout,
                &screen_layout(device),
            ],
        );
        let lateral_pipeline_layout = util::pipeline_layout(
            device,
            "lateral",
            &[&frame_layout, object_layout, maps_layout],
        );
        // Back faces culled, so no depth pre-pass is needed to run the taps about once a texel
        // (the lighting pass draws both sides, for open meshes: a pixel whose back face shows
        // finds no texel of its surface and takes the chord's slab alone; mesh transforms
        // keep mirrored objects' winding, `Mesh::transform`).
        // Against a pre-pass and both sides, interleaved at 1280x720: the pass 17 ms instead
        // of 22, the lighting pass unchanged (docs/performance.md).
        // Only `diffusion` reads the lateral map.
        // Each texel evaluates `diffusion` whole, the lateral taps included (LATERAL_SOURCE 2).
        let diffusion = DIFFUSION_WHOLE;
        let lateral_pipeline = |fragment, targets, depth| {
            util::MeshPipeline {
                label: "lateral",
                layout: &lateral_pipeline_layout,
                module: &module,
                vertex: "vs_main",
                fragment,
                targets,
                cull_mode: Some(wgpu::Face::Back),
                depth,
                constants: &diffusion,
            }
            .create(device)
        };
        let pair: &[wgpu::TextureFormat] = &[LATERAL_FORMAT, LATERAL_FORMAT];
        let lateral = lateral_pipeline("fs_transmitted", pair, util::DepthTest::Nearest);
        let surface = lateral_pipeline("fs_surface", pair, util::DepthTest::Nearest);
        let compute_layout = util::pipeline_layout(
            device,
            "lateral compute",
            &[
                &frame_layout,
                object_layout,
                &lateral_compute_layout(device),
                &dispatch_origin_layout(device),
            ],
        );
        let bounce = [util::DepthTest::Nearest, util::DepthTest::Prepassed]
            .map(|depth| lateral_pipeline("fs_bounce", &[LATERAL_FORMAT], depth));
        let pipeline = lighting_pipeline(device, &layout, &module, key);
        // Meshes drawn without culling in any order would shade every surface a pixel covers
        // that lands before the nearest one (the back of a head, the far side of a hand): a
        // depth-only pass first leaves the lighting shader one fragment per pixel.
        let prepass = util::depth_prepass_pipeline(device, &prepass_layout, &module, "vs_main");
        let default_maps = maps::default_maps_bind_group(device, maps_layout);
        let mut pass = Self {
            prepass,
            pipelines: vec![(key, pipeline)],
            taps: None,
            taps_objects: Vec::new(),
            current: 0,
            module,
            layout,
            lateral,
            surface,
            transmitted_compute: None,
            bounce_compute: None,
            clear_compute: None,
            compute_layout,
            object_rects: ObjectRects::new(device, &[], 1),
            bounce,
            bounce_layer,
            no_lateral_map: screen_bind_group(device, &dummy_lateral_map(device)),
            default_maps,
            frame_bind_group,
            camera,
            lights,
        };
        pass.build_computes(device, &asked);
        pass
    }

    /// Group 0 (see [`frame_layout`]): camera, lights, shadow maps, translucent shadow maps.
    pub fn frame_bind_group(&self) -> &wgpu::BindGroup {
        &self.frame_bind_group
    }

    /// Group 3 (see [`screen_layout`]) without a lateral map, for pipelines on the lighting
    /// shader that never read it.
    pub fn no_lateral_map(&self) -> &wgpu::BindGroup {
        &self.no_lateral_map
    }

    /// Writes the per-frame uniforms (the camera and the lights), and builds the lighting
    /// pipeline again if `lights` asks for another transmittance method.
    pub fn prepare(&mut self, ctx: &GpuContext, camera: &CameraUniform, lights: &LightsUniform) {
        ctx.queue
            .write_buffer(&self.camera, 0, bytemuck::bytes_of(camera));
        ctx.queue
            .write_buffer(&self.lights, 0, bytemuck::bytes_of(lights));
        self.bounce_layer = bounce_layer(lights);
        self.specialize(&ctx.device, LightingVariant::for_lights(lights));
        self.build_computes(&ctx.device, lights);
    }

    /// Builds the compute evaluations of the lateral map that `lights` ask for and the pass
    /// does not hold yet.
    fn build_computes(&mut self, device: &wgpu::Device, lights: &LightsUniform) {
        if !(LateralShape::for_lights(lights).compute && util::supports_compute_storage(device)) {
            return;
        }
        if transmitted_map(lights) && self.transmitted_compute.is_none() {
            let constants = spread_constants(&DIFFUSION_SPREAD);
            self.transmitted_compute =
                Some(self.build_compute(device, "cs_transmitted", &constants));
        }
        if bounce_layer(lights).is_some() && self.bounce_compute.is_none() {
            let constants = spread_constants(&DIFFUSION_WHOLE);
            self.bounce_compute = Some(self.build_compute(device, "cs_bounce", &constants));
        }
        if self.clear_compute.is_none()
            && (self.transmitted_compute.is_some() || self.bounce_compute.is_some())
        {
            self.clear_compute = Some(self.build_compute(device, "cs_clear", &DIFFUSION_WHOLE));
        }
    }

    /// The compute evaluation `entry` of lateral.wgsl with the overrides `constants`:
    /// `diffusion` whole, the lateral taps included, as the lateral pass's fragment shader
    /// evaluates it (LATERAL_SOURCE 2, or 3 where the taps are spread over lanes).
    fn build_compute(
        &self,
        device: &wgpu::Device,
        entry: &str,
        constants: &[(&str, f64)],
    ) -> wgpu::ComputePipeline {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&self.compute_layout),
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            cache: None,
        })
    }

    /// Makes the lighting pipeline the one built for `key`, building it the first time it is
    /// asked for. Each variant has its own pipeline so that the shader compiler drops the
    /// others' code (transmittance.wgsl, `TRANSMITTANCE_METHOD` and `LATERAL_SOURCE`;
    /// lighting.wgsl, `BOUNCE_SOURCE`).
    ///
    /// Which objects gather the taps themselves is forgotten: call [`Self::set_taps_objects`]
    /// after it.
    pub fn specialize(&mut self, device: &wgpu::Device, key: LightingVariant) {
        self.current = self.pipeline_index(device, key);
        self.taps = None;
        self.taps_objects.clear();
    }

    /// The index in `pipelines` of `key`'s pipeline, built the first time it is asked for.
    fn pipeline_index(&mut self, device: &wgpu::Device, key: LightingVariant) -> usize {
        match self.pipelines.iter().position(|(k, _)| *k == key) {
            Some(i) => i,
            None => {
                let pipeline = lighting_pipeline(device, &self.layout, &self.module, key);
                self.pipelines.push((key, pipeline));
                self.pipelines.len() - 1
            }
        }
    }

    /// Marks the objects (`objects[i]` of [`Self::encode`]) that gather `diffusion`'s lateral
    /// taps at each pixel although the frame reads them from the lateral map
    /// (`gpu_scene::lateral_taps_objects`: skin whose texels would be too coarse), and builds
    /// their pipeline the first time. Ignored where the current variant reads no map.
    pub fn set_taps_objects(&mut self, device: &wgpu::Device, objects: Vec<bool>) {
        let key = self.pipelines[self.current].0;
        self.taps = (key.lateral == 1 && objects.contains(&true))
            .then(|| self.pipeline_index(device, LightingVariant { lateral: 2, ..key }));
        self.taps_objects = objects;
    }

    /// Limits each object's compute dispatch over the lateral map to its box on screen:
    /// `pixels[i]` for `objects[i]` of [`Self::encode`], in pixels of the frame `[x0, y0, x1,
    /// y1)` (`gpu_scene::screen_rects`), `None` for an object out of view (no dispatch), for a
    /// map of reduction `downsample`. Without it (or for another reduction, or objects past
    /// `pixels`) each dispatch covers the whole map: the same map, at a cost that grows with
    /// the number of objects times the map (llvmpipe runs a shader's loops once even where no
    /// invocation enters them: 16 characters' 32 objects took 260 ms against the fragment
    /// shader's 66 at 640x360).
    pub fn set_object_rects(
        &mut self,
        device: &wgpu::Device,
        pixels: &[Option<[u32; 4]>],
        downsample: u32,
    ) {
        self.object_rects = ObjectRects::new(device, pixels, downsample);
    }

    /// Draws every object with `pipeline` and the pass's groups (the depth pre-pass and the
    /// lighting pass bind the same ones).
    fn draw_objects(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipeline: &wgpu::RenderPipeline,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
    ) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        for (i, o) in objects.iter().enumerate() {
            pass.set_bind_group(2, maps.get(i).unwrap_or(&self.default_maps), &[]);
            o.draw(pass);
        }
    }

    /// The lighting pass's draws: each object with the current pipeline, or its variant that
    /// gathers the taps itself where [`Self::set_taps_objects`] marked the object.
    fn draw_lit_objects(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
    ) {
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        let mut bound = None;
        for (i, o) in objects.iter().enumerate() {
            let index = match self.taps {
                Some(taps) if self.taps_objects.get(i) == Some(&true) => taps,
                _ => self.current,
            };
            if bound != Some(index) {
                pass.set_pipeline(&self.pipelines[index].1);
                bound = Some(index);
            }
            pass.set_bind_group(2, maps.get(i).unwrap_or(&self.default_maps), &[]);
            o.draw(pass);
        }
    }

    /// `transmitted`: the lateral pass evaluates `diffusion`'s transmitted light into the
    /// lateral map first ([`transmitted_map`] of the uniform given to [`Self::prepare`]);
    /// ignored without a map.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        objects: &[GpuObject],
        transmitted: bool,
        background: [f32; 3],
        far: f32,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        self.encode_with_maps(
            encoder,
            targets,
            objects,
            &[],
            transmitted,
            background,
            far,
            profiler,
        );
    }

    /// The depth pre-pass into `zbuffer` (cleared), timed as `timed`: the nearest surface per
    /// pixel, for the [`util::DepthTest::Prepassed`] pipelines after it.
    fn encode_prepass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        zbuffer: &wgpu::TextureView,
        timed: &str,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, timed, encoder);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth prepass"),
                color_attachments: &[],
                depth_stencil_attachment: util::depth_attachment(
                    zbuffer,
                    wgpu::LoadOp::Clear(1.0),
                    wgpu::StoreOp::Store,
                ),
                timestamp_writes: timer.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.draw_objects(&mut pass, &self.prepass, objects, maps);
        }
        timer.end(profiler, encoder);
    }

    /// The lateral pass (timed "lateral"): the transmitted light into its layers where
    /// `transmitted`, writing the map's z-buffer; then the bounce pass (timed "bounce") into the
    /// bounce layer, testing against it. Where the targets hold the texels' surfaces (and the
    /// pipelines are built), the first raster pass records them (`fs_surface`) and compute
    /// dispatches evaluate both (`cs_transmitted`, `cs_bounce`); otherwise the fragment shaders
    /// do (`fs_transmitted`, `fs_bounce`).
    fn encode_lateral(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        lateral: &LateralTargets,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        transmitted: bool,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let transmitted = transmitted && lateral.layer_count >= TRANSMITTED_LAYERS;
        let bounce = self.bounce_layer.filter(|&l| l < lateral.layer_count);
        let transmitted_compute = self.transmitted_compute.as_ref().filter(|_| transmitted);
        let bounce_compute = self.bounce_compute.as_ref().filter(|_| bounce.is_some());
        let computed = lateral.surface.as_ref().filter(|_| {
            self.clear_compute.is_some()
                && (!transmitted || transmitted_compute.is_some())
                && (bounce.is_none() || bounce_compute.is_some())
        });
        if let Some(surface) = computed {
            // The surfaces' raster pass is timed with the first pass it serves.
            let pass = MapPass {
                timed: if transmitted { "lateral" } else { "bounce" },
                targets: surface.targets.iter().collect(),
                first: true,
                pipeline: &self.surface,
            };
            self.encode_map_pass(encoder, lateral, &pass, objects, maps, profiler);
            // Each object's dispatch writes only its own texels, within its box: the rest of
            // the map must read as nothing (depth 0), which the first compute pass clears.
            // Render passes that only cleared its layers took 0.02 ms more on an H200 at
            // 1920x1080 (docs/performance.md).
            let mut clear = self.clear_compute.as_ref();
            for (timed, pipeline) in [("lateral", transmitted_compute), ("bounce", bounce_compute)]
            {
                if let Some(pipeline) = pipeline {
                    let compute = Compute {
                        timed,
                        clear: clear.take(),
                        pipeline,
                    };
                    self.encode_compute(encoder, &compute, lateral, surface, objects, profiler);
                }
            }
            return;
        }
        let mut first = true;
        if transmitted {
            let pass = MapPass {
                timed: "lateral",
                targets: lateral.layers[..TRANSMITTED_LAYERS as usize]
                    .iter()
                    .collect(),
                first,
                pipeline: &self.lateral,
            };
            self.encode_map_pass(encoder, lateral, &pass, objects, maps, profiler);
            first = false;
        }
        if let Some(layer) = bounce {
            let pass = MapPass {
                timed: "bounce",
                targets: vec![&lateral.layers[layer as usize]],
                first,
                pipeline: &self.bounce[usize::from(!first)],
            };
            self.encode_map_pass(encoder, lateral, &pass, objects, maps, profiler);
        }
    }

    /// A compute evaluation of lateral.wgsl once per object (timed as `compute.timed`, summed
    /// with the surfaces' raster pass where that is timed alike): each dispatch covers its
    /// object's box and evaluates the texels whose surface is its object's.
    fn encode_compute(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        compute: &Compute<'_>,
        lateral: &LateralTargets,
        surface: &LateralSurface,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timed = compute.timed;
        let timer = TimedPass::begin(profiler, timed, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(timed),
                timestamp_writes: timer.compute_writes(),
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_bind_group(2, &surface.bind_group, &[]);
            if let (Some(clear), Some(o)) = (compute.clear, objects.first()) {
                pass.set_pipeline(clear);
                pass.set_bind_group(1, &o.bind_group, &[]);
                pass.set_bind_group(
                    3,
                    &self.object_rects.bind_group,
                    &[self.object_rects.whole_offset()],
                );
                pass.dispatch_workgroups(
                    lateral.width.div_ceil(TEXEL_BLOCK),
                    lateral.height.div_ceil(TEXEL_BLOCK),
                    1,
                );
            }
            pass.set_pipeline(compute.pipeline);
            for (k, o) in objects.iter().enumerate() {
                let Some((offset, w, h)) = self.object_rects.dispatch(
                    k,
                    lateral.downsample,
                    lateral.width,
                    lateral.height,
                ) else {
                    continue;
                };
                pass.set_bind_group(1, &o.bind_group, &[]);
                pass.set_bind_group(3, &self.object_rects.bind_group, &[offset]);
                pass.dispatch_workgroups(
                    w.div_ceil(SPREAD_BLOCK[0]),
                    h.div_ceil(SPREAD_BLOCK[1]),
                    1,
                );
            }
        }
        timer.end(profiler, encoder);
    }

    /// One pass of [`MapPass`] over the lateral map.
    fn encode_map_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        lateral: &LateralTargets,
        map_pass: &MapPass<'_>,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, map_pass.timed, encoder);
        {
            let attachments: Vec<_> = map_pass
                .targets
                .iter()
                .map(|view| {
                    util::color_attachment(view, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT))
                })
                .collect();
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(map_pass.timed),
                color_attachments: &attachments,
                // Kept: the next pass shades the surfaces this one found nearest.
                depth_stencil_attachment: util::depth_attachment(
                    &lateral.zbuffer,
                    if map_pass.first {
                        wgpu::LoadOp::Clear(1.0)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    wgpu::StoreOp::Store,
                ),
                timestamp_writes: timer.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.draw_objects(&mut pass, map_pass.pipeline, objects, maps);
        }
        timer.end(profiler, encoder);
    }

    /// As `encode`, with each object's texture-space bind group (`maps[i]` for `objects[i]`;
    /// objects beyond `maps` are lit plainly).
    #[allow(clippy::too_many_arguments)]
    pub fn encode_with_maps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        transmitted: bool,
        background: [f32; 3],
        far: f32,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        if let Some(lateral) = &targets.lateral
            && (transmitted || self.bounce_layer.is_some())
        {
            self.encode_lateral(encoder, lateral, objects, maps, transmitted, profiler);
        }
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (diffuse, specular, depth, sss) = (
            view(&targets.diffuse),
            view(&targets.specular),
            view(&targets.depth),
            view(&targets.sss),
        );
        let attach = |v, c| util::color_attachment(v, wgpu::LoadOp::Clear(c));
        let bg = wgpu::Color {
            r: background[0] as f64,
            g: background[1] as f64,
            b: background[2] as f64,
            a: 1.0,
        };
        self.encode_prepass(
            encoder,
            &targets.zbuffer,
            "depth prepass",
            objects,
            maps,
            profiler,
        );
        let timer = TimedPass::begin(profiler, "lighting", encoder);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("lighting"),
                color_attachments: &[
                    attach(&diffuse, bg),
                    attach(&specular, wgpu::Color::TRANSPARENT),
                    attach(
                        &depth,
                        wgpu::Color {
                            r: far as f64,
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        },
                    ),
                    attach(&sss, wgpu::Color::TRANSPARENT),
                ],
                depth_stencil_attachment: util::depth_attachment(
                    &targets.zbuffer,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Discard,
                ),
                timestamp_writes: timer.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(3, &targets.screen, &[]);
            self.draw_lit_objects(&mut pass, objects, maps);
        }
        timer.end(profiler, encoder);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `diffusion` with 12 taps and a map of one texel per 4x4 pixels, no lights.
    fn diffusion_with_a_map() -> LightsUniform {
        let mut lights: LightsUniform = bytemuck::Zeroable::zeroed();
        lights.transmittance = TransmittanceMethod::Diffusion.code();
        lights.lateral_taps = 12;
        lights.lateral_downsample = 4;
        lights
    }

    /// The frame's pipeline gathers the taps itself only without a map (objects too far for
    /// the map get that variant through `set_taps_objects`).
    #[test]
    fn the_lateral_light_comes_from_the_map_wherever_there_is_one() {
        let mut lights = diffusion_with_a_map();
        assert_eq!(lateral_source(&lights), 1);
        lights.lateral_downsample = 1;
        assert_eq!(lateral_source(&lights), 2);
        lights.lateral_taps = 0;
        assert_eq!(lateral_source(&lights), 0);
        lights.lateral_taps = 12;
        lights.transmittance = TransmittanceMethod::Paper.code();
        assert_eq!(lateral_source(&lights), 0);
    }

    /// The lateral pass evaluates the transmitted light only for `diffusion` with taps, a map
    /// and a shadowed light, into two layers before the bounce's.
    #[test]
    fn the_transmitted_light_takes_two_layers_before_the_bounce() {
        let mut lights = diffusion_with_a_map();
        lights.count = 2;
        lights.lights[0].first_layer = -1.0;
        lights.lights[1].first_layer = -1.0;
        assert!(!transmitted_map(&lights), "no light has a shadow map");
        assert_eq!(LateralShape::for_lights(&lights), LateralShape::NONE);
        lights.lights[1].first_layer = 0.0;
        assert!(transmitted_map(&lights));
        let shape = LateralShape::for_lights(&lights);
        assert_eq!((shape.downsample, shape.layers), (4, TRANSMITTED_LAYERS));
        lights.bounce_ring = 2;
        lights.bounce_layer = TRANSMITTED_LAYERS;
        assert_eq!(
            LateralShape::for_lights(&lights).layers,
            TRANSMITTED_LAYERS + 1
        );
        for off in [
            |l: &mut LightsUniform| l.lateral_taps = 0,
            |l: &mut LightsUniform| l.lateral_downsample = 1,
            |l: &mut LightsUniform| l.transmittance = TransmittanceMethod::Paper.code(),
        ] {
            let mut other = lights;
            off(&mut other);
            assert!(!transmitted_map(&other));
        }
    }
}
