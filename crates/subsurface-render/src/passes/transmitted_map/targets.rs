//! The transmitted map's targets: the map itself (`diffusion`'s transmitted light and the bounce at
//! a reduced resolution), its z-buffer, the texels' surfaces that the compute evaluation reads,
//! and each object's box for its dispatch.

use wgpu::util::DeviceExt;

use crate::frame_plan::{TRANSMITTED_LAYERS, TransmittedMapShape};
use crate::gpu::GpuContext;
use crate::passes::util;

/// 32-bit depth beside the light: the lighting pass compares it with its own pixel's to the
/// fraction of a millimetre, at any distance. Read with loads (no filtering needed).
pub const TRANSMITTED_MAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// The transmitted map pass's targets, of `TRANSMITTED_MAP_FORMAT` at `ceil(size / downsample)`: layers 0 and
/// 1 ([`TRANSMITTED_LAYERS`]) hold `diffusion`'s transmitted light at the texel's surface, every
/// light's radiance summed (0: the diffuse part, which joins the irradiance; 1: the unscattered
/// and singly scattered part, which joins the specular target), a = the texel's view depth
/// (0: nothing there); the bounce's layer comes after them (`bounce_layer`). And the z-buffer of
/// that resolution.
pub struct TransmittedMapTargets {
    /// Pixels per texel along each axis.
    pub downsample: u32,
    /// Layers of `map`.
    pub layer_count: u32,
    /// Width in texels, `ceil(frame width / downsample)`.
    pub width: u32,
    /// Height in texels, `ceil(frame height / downsample)`.
    pub height: u32,
    /// The array texture of all layers.
    pub map: wgpu::Texture,
    pub(super) layers: Vec<wgpu::TextureView>,
    pub(super) zbuffer: wgpu::TextureView,
    /// Where the transmitted light and the bounce are evaluated in a compute shader
    /// ([`TransmittedMapShape::compute`]): the texels' surfaces.
    pub(super) surface: Option<MapSurface>,
}

/// The transmitted map's texels' surfaces (`fs_surface` in transmitted_map.wgsl): world position and view
/// depth; the normal turned toward the camera and the object's index. `cs_transmitted`
/// evaluates the transmitted light there.
pub(super) struct MapSurface {
    pub(super) targets: [wgpu::TextureView; 2],
    /// Group 2 of `cs_transmitted` ([`map_compute_layout`]): the surfaces, and the map
    /// written as storage.
    pub(super) bind_group: wgpu::BindGroup,
}

/// Layout of group 2 of the transmitted map's compute evaluation (`surface_position`,
/// `surface_normal` and `transmitted_out` in transmitted_map.wgsl).
pub(super) fn map_compute_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    let d2 = wgpu::TextureViewDimension::D2;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("transmitted map compute"),
        entries: &[
            util::float_texture_entry(8, compute, false, d2),
            util::float_texture_entry(9, compute, false, d2),
            util::storage_texture_entry(
                10,
                compute,
                TRANSMITTED_MAP_FORMAT,
                wgpu::TextureViewDimension::D2Array,
            ),
        ],
    })
}

/// Layout of group 3 of the transmitted map's compute evaluation: `dispatch_origin` in
/// transmitted_map.wgsl, one entry per object at a dynamic offset ([`ObjectRects`]).
pub(super) fn dispatch_origin_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("transmitted map dispatch origin"),
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

/// Each object's box on the transmitted map, for its compute dispatch: texels `[x0, y0, x1, y1)`
/// (`None`: not in view, no dispatch), for a map of reduction `downsample`. The buffer holds
/// each box's first texel at a stride the device's dynamic offsets allow, and after them a
/// zero origin for objects without a box (the whole map).
pub(super) struct ObjectRects {
    downsample: u32,
    rects: Vec<Option<[u32; 4]>>,
    stride: u32,
    pub(super) bind_group: wgpu::BindGroup,
}

impl ObjectRects {
    /// `pixels`: each object's box in pixels of the frame (`FramePlan::object_rects`).
    pub(super) fn new(device: &wgpu::Device, pixels: &[Option<[u32; 4]>], downsample: u32) -> Self {
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
            label: Some("transmitted map dispatch origins"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = util::bind_group(
            device,
            "transmitted map dispatch origins",
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
    pub(super) fn whole_offset(&self) -> u32 {
        self.rects.len() as u32 * self.stride
    }

    /// Object `k`'s dispatch on a `w` x `h` map of reduction `downsample`: the dynamic offset
    /// of its origin and its size in texels; the whole map where it has no box (or the boxes
    /// were made for another reduction), `None` where it is out of view.
    pub(super) fn dispatch(
        &self,
        k: usize,
        downsample: u32,
        w: u32,
        h: u32,
    ) -> Option<(u32, u32, u32)> {
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

impl TransmittedMapTargets {
    /// The map of `shape` for a `width` x `height` frame; with `shape.compute`, the surfaces
    /// the compute evaluations of the transmitted light and the bounce read.
    pub fn new(ctx: &GpuContext, width: u32, height: u32, shape: TransmittedMapShape) -> Self {
        let device = &ctx.device;
        let downsample = shape.downsample.max(1);
        // The transmitted light's two, and the bounce's after them.
        let layer_count = shape.layers.clamp(1, TRANSMITTED_LAYERS + 1);
        let (w, h) = (width.div_ceil(downsample), height.div_ceil(downsample));
        let compute = shape.compute;
        let storage = if compute {
            wgpu::TextureUsages::STORAGE_BINDING
        } else {
            wgpu::TextureUsages::empty()
        };
        let map = util::texture_2d(
            device,
            "transmitted map",
            w,
            h,
            layer_count,
            TRANSMITTED_MAP_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | storage,
        );
        let layers = (0..layer_count)
            .map(|layer| {
                map.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("transmitted map layer"),
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
                    TRANSMITTED_MAP_FORMAT,
                    wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                )
                .create_view(&Default::default())
            };
            let targets = [
                target("transmitted map surface position"),
                target("transmitted map surface normal"),
            ];
            let map_view = util::array_view(&map);
            let bind_group = util::bind_group(
                device,
                "transmitted map compute",
                &map_compute_layout(device),
                [
                    (8, wgpu::BindingResource::TextureView(&targets[0])),
                    (9, wgpu::BindingResource::TextureView(&targets[1])),
                    (10, wgpu::BindingResource::TextureView(&map_view)),
                ],
            );
            MapSurface {
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
            zbuffer: util::depth_buffer(
                device,
                "transmitted map z-buffer",
                w,
                h,
                util::ZBUFFER_FORMAT,
            ),
            surface,
        }
    }

    /// Whether compute shaders evaluate the map on the texels' surfaces.
    pub fn computed(&self) -> bool {
        self.surface.is_some()
    }

    /// The shape these targets were made for.
    pub fn shape(&self) -> TransmittedMapShape {
        TransmittedMapShape {
            downsample: self.downsample,
            layers: self.layer_count,
            compute: self.computed(),
        }
    }
}
