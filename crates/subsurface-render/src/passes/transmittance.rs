//! Transmittance through thin parts (Jimenez et al. 2010), computed per shadowed light inside
//! the lighting pass (see `transmittance.wgsl`): thickness from the standard linear-depth
//! shadow maps, T(s) from the material's own diffusion profile, stored in a small LUT.

use std::collections::HashMap;

use subsurface_profile::{Material, SumOfGaussians, TransmittanceLut, material};

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
}

impl TransmittanceMethod {
    pub fn code(self) -> f32 {
        match self {
            TransmittanceMethod::Off => 0.0,
            TransmittanceMethod::Paper => 1.0,
            TransmittanceMethod::Beer => 2.0,
            TransmittanceMethod::SeedReport => 3.0,
            TransmittanceMethod::Tsm => 4.0,
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

/// A material's profile as Gaussians (fitted for measured materials) and its extinction
/// coefficient for Beer-Lambert, per millimetre.
#[derive(Clone, Debug)]
pub struct MaterialOptics {
    pub profile: SumOfGaussians,
    pub sigma_t: [f32; 3],
}

/// Jensen et al. 2001's skin1, the extinction used for the Gaussian skin preset.
const SKIN1_SIGMA_T: [f32; 3] = [0.74 + 0.032, 0.88 + 0.17, 1.01 + 0.48];

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
            Material::Gaussians { profile, .. } => MaterialOptics {
                profile: profile.clone(),
                sigma_t: SKIN1_SIGMA_T,
            },
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
                }
            }
        };
        self.cache.insert(name.to_string(), optics.clone());
        Ok(optics)
    }
}

/// T(s) of `profile` as an Rgba16Float texture (filterable everywhere), `s_max_mm` wide.
pub fn lut_texture(
    ctx: &GpuContext,
    profile: &SumOfGaussians,
) -> Result<(wgpu::TextureView, f32), RenderError> {
    let lut = TransmittanceLut::new(profile, 2048, 6.0)?;
    let data: Vec<half::f16> = lut
        .to_rgba()
        .iter()
        .flatten()
        .map(|v| half::f16::from_f32(*v))
        .collect();
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("transmittance lut"),
        size: wgpu::Extent3d {
            width: lut.resolution,
            height: 1,
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
            bytes_per_row: Some(8 * lut.resolution),
            rows_per_image: None,
        },
        texture.size(),
    );
    Ok((texture.create_view(&Default::default()), lut.s_max_mm))
}
