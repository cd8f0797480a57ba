//! Transmittance through thin parts (Jimenez et al. 2010), computed per shadowed light inside
//! the lighting pass (see `transmittance.wgsl`): thickness from the standard linear-depth
//! shadow maps, T(s) from the material's own diffusion profile, stored in a small LUT.

use subsurface_profile::{SlabSolver, TransmittanceLut};

use crate::error::RenderError;
use crate::gpu::GpuContext;
pub use crate::material::{MaterialCache, MaterialOptics};
pub use crate::settings::{TransmittanceMethod, TransmittanceSettings};

/// The T(s) tables of a material as one Rgba16Float texture (filterable everywhere): row 0 the
/// sum-of-Gaussians T(s) of 000_* over the returned range in mm, then one row per exit direction
/// of the `Diffusion` method's T(s), exact transport of multiply scattered light through slabs
/// of the medium seen from that direction (`TransmittanceLut::transport_at`, exit cosines evenly
/// spaced from grazing to the normal), over `TransmittanceLut::DIFFUSION_S_MAX_MM`; then the
/// three rows of the lateral taps over the same range: `T_ms(s)`, `-T_ms'(r)` and the rise of
/// `T_ms` to its peak (`subsurface_profile::lateral`); last, what a slab of each thickness
/// reflects as a share of the half-space's albedo (`TransmittanceLut::thin_reflectance`). (The rough boundary's transmittance,
/// once a last row, is a polynomial in the object's uniform: `ObjectUniform::boundary_fit`.)
pub fn lut_texture(
    ctx: &GpuContext,
    optics: &MaterialOptics,
) -> Result<(wgpu::TextureView, f32), RenderError> {
    lut_texture_on(&ctx.device, &ctx.queue, optics)
}

/// [`lut_texture`] on a bare device and queue (an engine's, e.g. Bevy's render device).
pub fn lut_texture_on(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    optics: &MaterialOptics,
) -> Result<(wgpu::TextureView, f32), RenderError> {
    let res = TransmittanceLut::DEFAULT_RESOLUTION;
    let lut = TransmittanceLut::new(&optics.profile, res, TransmittanceLut::DEFAULT_S_MAX_MM)?;
    let mut rows = vec![lut.to_rgba()];
    for angle in 0..SlabSolver::EXIT_ANGLES {
        rows.push(TransmittanceLut::transport_at(&optics.transport, res, angle)?.to_rgba());
    }
    // The lateral taps' rows (subsurface_profile::lateral): the slab's T_ms(s), the kernel's
    // -T_ms'(r), and T_ms over its envelope.
    rows.push(TransmittanceLut::transport(&optics.transport, res)?.to_rgba());
    rows.push(TransmittanceLut::lateral_slope(&optics.transport, res)?.to_rgba());
    rows.push(TransmittanceLut::rise(&optics.transport, res)?.to_rgba());
    // What a part of each thickness reflects of the half-space's albedo (the lighting pass's
    // thin parts, `Terms::THIN_PARTS`).
    rows.push(TransmittanceLut::thin_reflectance(&optics.transport, res)?.to_rgba());
    let data: Vec<half::f16> = rows
        .iter()
        .flatten()
        .flatten()
        .map(|v| half::f16::from_f32(*v))
        .collect();
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("transmittance lut"),
        size: wgpu::Extent3d {
            width: res,
            height: rows.len() as u32,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        texture.as_image_copy(),
        bytemuck::cast_slice(&data),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(8 * res),
            rows_per_image: Some(rows.len() as u32),
        },
        texture.size(),
    );
    Ok((texture.create_view(&Default::default()), lut.s_max_mm))
}
