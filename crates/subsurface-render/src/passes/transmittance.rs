//! Transmittance through thin parts (Jimenez et al. 2010), computed per shadowed light inside
//! the lighting pass (see `transmittance.wgsl`): thickness from the standard linear-depth
//! shadow maps, T(s) from the material's own diffusion profile, stored in a small LUT.

use std::collections::HashMap;

use subsurface_profile::{Dipole, Material, SumOfGaussians, TransmittanceLut, material};

use crate::error::RenderError;
use crate::gpu::GpuContext;

/// How light through thin parts is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TransmittanceMethod {
    /// None.
    Off,
    /// Jimenez et al. 2010: T(s) of the sum-of-Gaussians profile (colour turns from yellow to
    /// red with thickness).
    #[default]
    Paper,
    /// Green 2004: Beer-Lambert exp(-sigma_t s) with the material's extinction.
    Beer,
    /// The ad-hoc s^-0.6 falloff of the screen/texture-space report (001_*), grey.
    SeedReport,
    /// Translucent shadow maps (d'Eon et al. 2007): the shadow maps also store the (u, v) of
    /// the surface nearest the light, whose irradiance, blurred in texture space, is
    /// attenuated by the same T(s) as `Paper` (see `passes::texture_space`).
    Tsm,
    /// Diffusion theory (our extension, see `docs/fidelity.md`): T(s) is the light a slab of
    /// the material's measured coefficients transmits (Donner and Jensen 2005's multipole),
    /// relative to what it reflects; it decays exponentially rather than like a Gaussian, so
    /// fingers and thick ears still glow red. The Gaussian skin preset uses skin1's
    /// coefficients.
    Diffusion,
}

impl TransmittanceMethod {
    pub fn code(self) -> f32 {
        match self {
            TransmittanceMethod::Off => 0.0,
            TransmittanceMethod::Paper => 1.0,
            TransmittanceMethod::Beer => 2.0,
            TransmittanceMethod::SeedReport => 3.0,
            TransmittanceMethod::Tsm => 4.0,
            TransmittanceMethod::Diffusion => 5.0,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct TransmittanceConfig {
    pub method: TransmittanceMethod,
    /// Distance the shaded point moves inward along the vertex normal before the shadow-map
    /// lookup, in scene units (000_* uses 0.005).
    pub normal_shrink: f32,
    /// Width in texels of the square over which the shadow-map distance is averaged (odd).
    pub thickness_filter: u32,
}

impl Default for TransmittanceConfig {
    fn default() -> Self {
        Self {
            method: TransmittanceMethod::Paper,
            normal_shrink: 0.005,
            thickness_filter: 3,
        }
    }
}

impl TransmittanceConfig {
    pub fn validate(&self) -> Result<(), RenderError> {
        if !(self.normal_shrink.is_finite() && self.normal_shrink >= 0.0) {
            return Err(RenderError::invalid(
                "normal_shrink",
                format!("must be finite and >= 0 (got {})", self.normal_shrink),
            ));
        }
        if self.thickness_filter == 0
            || self.thickness_filter > 15
            || self.thickness_filter.is_multiple_of(2)
        {
            return Err(RenderError::invalid(
                "thickness_filter",
                format!("must be odd and in 1..=15 (got {})", self.thickness_filter),
            ));
        }
        Ok(())
    }
}

/// A material's profile as Gaussians (fitted for measured materials), its extinction
/// coefficient for Beer-Lambert, per millimetre, and its measured coefficients for
/// diffusion-theory transmittance.
#[derive(Clone, Debug)]
pub struct MaterialOptics {
    pub profile: SumOfGaussians,
    pub sigma_t: [f32; 3],
    pub dipole: Dipole,
}

/// Jensen et al. 2001's skin1 (sigma_a, sigma_s' in 1/mm, eta), what the Gaussian skin preset
/// uses where measured coefficients are needed.
fn skin1() -> Dipole {
    match material("skin1") {
        Ok(Material::Dipole { dipole, .. }) => dipole,
        _ => unreachable!("skin1 is a measured preset"),
    }
}

/// Looks materials up by name and fits measured ones once.
#[derive(Default)]
pub struct MaterialCache {
    cache: HashMap<String, MaterialOptics>,
}

impl MaterialCache {
    pub fn get(&mut self, name: &str, field: &str) -> Result<MaterialOptics, RenderError> {
        if let Some(m) = self.cache.get(name) {
            return Ok(m.clone());
        }
        let m = material(name).map_err(|e| RenderError::invalid(field, e.to_string()))?;
        let optics = match &m {
            Material::Gaussians { profile, .. } => {
                let dipole = skin1();
                MaterialOptics {
                    profile: profile.clone(),
                    sigma_t: [0, 1, 2]
                        .map(|c| (dipole.sigma_a[c] + dipole.sigma_s_prime[c]) as f32),
                    dipole,
                }
            }
            Material::Dipole { dipole, .. }
            | Material::Multipole {
                multipole: subsurface_profile::Multipole { dipole, .. },
                ..
            } => {
                let fit = m
                    .fit(6)
                    .map_err(|e| RenderError::invalid(field, e.to_string()))?;
                let sigma_t =
                    [0, 1, 2].map(|c| (dipole.sigma_a[c] + dipole.sigma_s_prime[c]) as f32);
                MaterialOptics {
                    profile: fit.profile,
                    sigma_t,
                    dipole: *dipole,
                }
            }
        };
        self.cache.insert(name.to_string(), optics.clone());
        Ok(optics)
    }
}

/// The T(s) tables of a material as one Rgba16Float texture (filterable everywhere), two rows:
/// the sum-of-Gaussians T(s) of 000_* over the returned range in mm (row 0), and the
/// diffusion T(s) over `TransmittanceLut::DIFFUSION_S_MAX_MM` (row 1, `Diffusion`).
pub fn lut_texture(
    ctx: &GpuContext,
    optics: &MaterialOptics,
) -> Result<(wgpu::TextureView, f32), RenderError> {
    let res = TransmittanceLut::DEFAULT_RESOLUTION;
    let lut = TransmittanceLut::new(&optics.profile, res, TransmittanceLut::DEFAULT_S_MAX_MM)?;
    let diffusion =
        TransmittanceLut::diffusion(&optics.dipole, res, TransmittanceLut::DIFFUSION_S_MAX_MM)?;
    let data: Vec<half::f16> = lut
        .to_rgba()
        .iter()
        .chain(diffusion.to_rgba().iter())
        .flatten()
        .map(|v| half::f16::from_f32(*v))
        .collect();
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("transmittance lut"),
        size: wgpu::Extent3d {
            width: res,
            height: 2,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    ctx.queue.write_texture(
        texture.as_image_copy(),
        bytemuck::cast_slice(&data),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(8 * res),
            rows_per_image: Some(2),
        },
        texture.size(),
    );
    Ok((texture.create_view(&Default::default()), lut.s_max_mm))
}
