//! What the lighting pass reads from texture-space diffusion and translucent shadow maps: the
//! map formats, the per-object group-2 bind group (`TextureSpace`, `ts_result`, `ts_widest`,
//! `ts_sampler` in lighting.wgsl) and the stand-ins used when those passes are off.
//!
//! Shared by `lighting`, `texture_space` and `tsm`; it imports none of them, so the
//! dependency runs one way: texture_space and tsm -> maps <- lighting.

use wgpu::util::DeviceExt;

use crate::passes::util;
use crate::uniforms::TextureSpaceUniform;

/// Irradiance, blurred and accumulated maps.
pub const MAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Profile millimetres per texel along u and v.
pub const STRETCH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// Translucent shadow maps: (u, v) of the surface nearest the light.
pub const TSM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

/// A square render target of `size` texels per side for a texture-space map.
pub fn map_texture(
    device: &wgpu::Device,
    label: &str,
    size: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    util::render_target(device, label, size, size, format)
}

/// Layout of group 2 of the lighting pass (`TextureSpace`, `ts_result`, `ts_widest`,
/// `ts_sampler` in lighting.wgsl).
pub fn maps_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let tex = |binding| {
        util::float_texture_entry(binding, fragment, true, wgpu::TextureViewDimension::D2)
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("texture-space maps"),
        entries: &[
            util::uniform_entry(0, fragment),
            tex(1),
            tex(2),
            util::sampler_entry(3, fragment, wgpu::SamplerBindingType::Filtering),
        ],
    })
}

/// Group 2 of one object: `params` (x = the blurred maps replace the diffuse irradiance, y =
/// translucent shadow maps read `widest`, z = exponent of the albedo applied before the blur),
/// the padded sum of Gaussians and the padded widest Gaussian.
pub fn maps_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    params: [f32; 4],
    result: &wgpu::TextureView,
    widest: &wgpu::TextureView,
) -> wgpu::BindGroup {
    let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("texture-space object"),
        contents: bytemuck::bytes_of(&TextureSpaceUniform { params }),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("texture-space maps"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    util::bind_group(
        device,
        "texture-space maps",
        layout,
        [
            (0, uniform.as_entire_binding()),
            (1, wgpu::BindingResource::TextureView(result)),
            (2, wgpu::BindingResource::TextureView(widest)),
            (3, wgpu::BindingResource::Sampler(&sampler)),
        ],
    )
}

/// Group 2 for an object without texture-space maps (plain lighting).
pub fn default_maps_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::BindGroup {
    let dummy =
        map_texture(device, "texture-space dummy", 1, MAP_FORMAT).create_view(&Default::default());
    maps_bind_group(device, layout, [0.0; 4], &dummy, &dummy)
}

/// A 1x1x1 translucent-shadow-map array for the lighting pass when TSM is off.
pub fn dummy_tsm_view(device: &wgpu::Device) -> wgpu::TextureView {
    util::array_view(&util::texture_2d(
        device,
        "tsm dummy",
        1,
        1,
        1,
        TSM_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING,
    ))
}
