//! The lighting pass's targets (what it writes and screen-space SSS reads) and its group 3:
//! the transmitted map it reads, or a stand-in.

use crate::frame_plan::{TRANSMITTED_LAYERS, TransmittedMapShape};
use crate::gpu::GpuContext;
use crate::passes::transmitted_map::{TRANSMITTED_MAP_FORMAT, TransmittedMapTargets};
use crate::passes::util;

/// Texel format of the diffuse and specular radiance targets: linear HDR.
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Texel format of the linear depth target, scene units.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// The back faces' target: r = linear view depth of the nearest back face, scene units (0:
/// none), g = its outward normal (`encode_normal` in common.wgsl). Read with `textureLoad`.
pub const BACK_FACES_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// r = SSS strength, g = scene units per profile millimetre, b = profile index (exact in f16
/// up to 2048), a unused. Half floats keep the four targets within the 32 bytes per sample
/// every adapter allows.
pub const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// What the lighting pass writes, and what screen-space SSS reads.
pub struct LightingTargets {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Diffuse radiance (irradiance x albedo), linear HDR: the image that is blurred.
    pub diffuse: wgpu::Texture,
    /// Specular radiance, linear HDR: added after the blur.
    pub specular: wgpu::Texture,
    /// Linear view depth in scene units (the camera's far plane where nothing was drawn).
    pub depth: wgpu::Texture,
    /// r = SSS strength (0 = not skin), g = scene units per profile millimetre, b = the
    /// profile's row, a = 1 where the outline pass adds the lights' chords.
    pub sss: wgpu::Texture,
    pub(super) zbuffer: wgpu::TextureView,
    /// The nearest back face per pixel ([`BACK_FACES_FORMAT`]), where the thin parts' term
    /// runs (see [`Self::set_back_faces`]; 1x1 and empty where it does not): how thick the
    /// part is that the pixel's surface lies on.
    pub back_faces: wgpu::Texture,
    /// The back faces' own z-buffer, the size of `back_faces`.
    pub(super) back_zbuffer: wgpu::TextureView,
    /// `diffusion`'s transmitted light and the bounce at reduced resolution, when the targets were made with a
    /// `map_downsample` above 1.
    pub map: Option<TransmittedMapTargets>,
    /// Group 3 of the lighting pass ([`screen_layout`]): the transmitted map, or a 1x1 stand-in.
    pub(super) screen: wgpu::BindGroup,
    /// The outline pass's mark reads `sss` through it (`outline::mark_layout`).
    pub(super) outline_mark: wgpu::BindGroup,
}

/// Layout of group 3 of the lighting pass (`transmitted_map` and `back_faces` in
/// lighting.wgsl). Pipelines built on the lighting shader that do not read them (the
/// texture-space irradiance) take the same layout and bind `LightingPass::no_transmitted_map`.
pub fn screen_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lighting screen"),
        entries: &[
            util::float_texture_entry(
                0,
                wgpu::ShaderStages::FRAGMENT,
                false,
                wgpu::TextureViewDimension::D2Array,
            ),
            util::float_texture_entry(
                1,
                wgpu::ShaderStages::FRAGMENT,
                false,
                wgpu::TextureViewDimension::D2,
            ),
        ],
    })
}

pub(super) fn screen_bind_group(
    device: &wgpu::Device,
    map: &wgpu::Texture,
    back_faces: &wgpu::Texture,
) -> wgpu::BindGroup {
    let view = map.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let back = back_faces.create_view(&Default::default());
    util::bind_group(
        device,
        "lighting screen",
        &screen_layout(device),
        [
            (0, wgpu::BindingResource::TextureView(&view)),
            (1, wgpu::BindingResource::TextureView(&back)),
        ],
    )
}

/// A 1x1 back-faces target holding no back face (r = 0): pipelines that never read it.
pub(super) fn no_back_faces(device: &wgpu::Device) -> wgpu::Texture {
    util::texture_2d(
        device,
        "no back faces",
        1,
        1,
        1,
        BACK_FACES_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING,
    )
}

pub(super) fn dummy_transmitted_map(device: &wgpu::Device) -> wgpu::Texture {
    util::texture_2d(
        device,
        "no transmitted map",
        1,
        1,
        1,
        TRANSMITTED_MAP_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING,
    )
}

impl LightingTargets {
    /// Without a transmitted map: `diffusion` runs its lateral taps at every pixel.
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Self {
        Self::with_map(ctx, width, height, TransmittedMapShape::NONE)
    }

    /// With `diffusion`'s transmitted map of `map`'s shape (none for a reduction of 1).
    pub fn with_map(ctx: &GpuContext, width: u32, height: u32, map: TransmittedMapShape) -> Self {
        let device = &ctx.device;
        let target = |label, format| util::render_target(device, label, width, height, format);
        let (back_faces, back_zbuffer) = back_face_targets(device, 1, 1);
        let (map, screen) = map_targets(ctx, width, height, map, &back_faces);
        let sss = target("sss strength", SSS_FORMAT);
        let outline_mark = util::bind_group(
            device,
            "outline mark",
            &super::outline::mark_layout(device),
            [(
                0,
                wgpu::BindingResource::TextureView(&sss.create_view(&Default::default())),
            )],
        );
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
            sss,
            zbuffer: util::depth_buffer(device, "z-buffer", width, height, zbuffer_format(device)),
            back_zbuffer,
            back_faces,
            map,
            screen,
            outline_mark,
        }
    }

    /// The transmitted map's reduction (1 without one).
    pub fn map_downsample(&self) -> u32 {
        self.map.as_ref().map_or(1, |l| l.downsample)
    }

    /// Where the transmitted map holds the transmitted light: whether a compute shader evaluates
    /// it (`MapEvaluation::Compute` on an adapter that runs it) rather than the map's fragment
    /// shader. None without such a map.
    pub fn map_computed(&self) -> Option<bool> {
        self.map
            .as_ref()
            .filter(|l| l.layer_count >= TRANSMITTED_LAYERS)
            .map(TransmittedMapTargets::computed)
    }

    /// The shape of the transmitted map these targets hold.
    pub fn map_shape(&self) -> TransmittedMapShape {
        self.map
            .as_ref()
            .map_or(TransmittedMapShape::NONE, TransmittedMapTargets::shape)
    }

    /// Whether the back faces' targets are the frame's size (the thin parts' term runs:
    /// `Terms::THIN_PARTS` in the plan's lighting variant) or a 1x1 stand-in holding no back
    /// face, 12 bytes a pixel saved.
    pub fn back_faces_on(&self) -> bool {
        self.back_faces.width() == self.width && self.back_faces.height() == self.height
    }

    /// Back faces' targets of the frame's size where `on`, else a 1x1 stand-in (see
    /// [`Self::back_faces_on`]); the transmitted map is kept.
    pub fn set_back_faces(&mut self, ctx: &GpuContext, on: bool) {
        if on == self.back_faces_on() {
            return;
        }
        let (w, h) = if on {
            (self.width, self.height)
        } else {
            (1, 1)
        };
        (self.back_faces, self.back_zbuffer) = back_face_targets(&ctx.device, w, h);
        self.screen = screen_of(&ctx.device, self.map.as_ref(), &self.back_faces);
    }

    /// A new transmitted map of `map`'s shape, the other targets kept: the reduction follows
    /// the skin's size on screen, so a camera moving nearer changes it without a new frame
    /// size, and a light added to the scene may need a layer more.
    pub fn set_map(&mut self, ctx: &GpuContext, map: TransmittedMapShape) {
        (self.map, self.screen) = map_targets(ctx, self.width, self.height, map, &self.back_faces);
    }
}

/// The back faces' target and z-buffer at `width` x `height`.
fn back_face_targets(
    device: &wgpu::Device,
    width: u32,
    height: u32,
) -> (wgpu::Texture, wgpu::TextureView) {
    (
        util::render_target(device, "back faces", width, height, BACK_FACES_FORMAT),
        util::depth_buffer(
            device,
            "back faces z-buffer",
            width,
            height,
            util::ZBUFFER_FORMAT,
        ),
    )
}

/// The transmitted map of a `width` x `height` frame of `shape` (none for a reduction of 1) and
/// the lighting pass's group 3 that reads it (a 1x1 stand-in without one).
fn map_targets(
    ctx: &GpuContext,
    width: u32,
    height: u32,
    shape: TransmittedMapShape,
    back_faces: &wgpu::Texture,
) -> (Option<TransmittedMapTargets>, wgpu::BindGroup) {
    let device = &ctx.device;
    let map = (shape.downsample > 1 && shape.layers > 0)
        .then(|| TransmittedMapTargets::new(ctx, width, height, shape));
    let screen = screen_of(device, map.as_ref(), back_faces);
    (map, screen)
}

/// Group 3 reading `map` (a 1x1 stand-in without one) and `back_faces`.
fn screen_of(
    device: &wgpu::Device,
    map: Option<&TransmittedMapTargets>,
    back_faces: &wgpu::Texture,
) -> wgpu::BindGroup {
    match map {
        Some(l) => screen_bind_group(device, &l.map, back_faces),
        None => screen_bind_group(device, &dummy_transmitted_map(device), back_faces),
    }
}

/// The lighting pass's z-buffer, shared by the depth pre-pass, the lighting pass and the
/// outline pass, whose stencil marks the pixels the outline pass shades: 32-bit float depth
/// where the device has it with a stencil, as the other passes' z-buffers
/// ([`util::ZBUFFER_FORMAT`]), else 24 bits.
pub fn zbuffer_format(device: &wgpu::Device) -> wgpu::TextureFormat {
    if device
        .features()
        .contains(wgpu::Features::DEPTH32FLOAT_STENCIL8)
    {
        wgpu::TextureFormat::Depth32FloatStencil8
    } else {
        wgpu::TextureFormat::Depth24PlusStencil8
    }
}
