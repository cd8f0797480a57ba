//! Texture-space diffusion (d'Eon, Luebke and Enderton 2007).
//!
//! Per skin object: (1) the lighting pass's lights, shadows, ambient and transmittance are
//! evaluated with the mesh laid out by its texture coordinates, into an irradiance map
//! (`Rgba16Float`, alpha = covered) and a stretch map (`Rg32Float`: profile millimetres per
//! texel along u and v, from the derivatives of the world position) ([`irradiance`]); (2) the
//! profile's Gaussians are applied as separable 7-tap blurs, each Gaussian made from the
//! previous one by its variance increment, converted from millimetres to texels through the
//! stretch map, and summed with the profile's per-channel weights (normalised, so that the
//! albedo carries the reflectance, as in the screen-space passes); (3) the UV islands are
//! padded by a few texels ([`blur`]; CPU mirror in `subsurface_profile::oracle::texture`);
//! (4) the lighting pass reads the sum at the fragment's uv instead of its own irradiance,
//! through the group-2 bind group this pass makes per object ([`crate::passes::maps`]).
//!
//! Albedo: `SssConfig::texture_albedo_pre` is the exponent of the albedo applied before the
//! blur; the rest is applied after it (0 = post-scatter, 0.5 = d'Eon's pre- and post-scatter,
//! the default, 1 = all before, as the screen-space passes do).
//!
//! Seams: taps that land outside every island are replaced by the centre texel, exactly as the
//! screen-space passes treat background pixels; near a seam the blur is narrower but never
//! darker. Scattering across a seam (to the other island) is not modelled.
//!
//! Translucent shadow maps, which read the widest blurred Gaussian, are their own pass
//! ([`crate::passes::tsm`]); [`TsmPass`] is re-exported here.

pub mod blur;
pub mod irradiance;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::gpu::object::GpuObject;
use crate::passes::lighting::LightingPass;
use crate::passes::maps::{self, map_texture};
use crate::passes::transmittance::MaterialCache;

pub use crate::passes::maps::{
    MAP_FORMAT, STRETCH_FORMAT, TSM_FORMAT, default_maps_bind_group, dummy_tsm_view, maps_layout,
};
pub use crate::passes::tsm::TsmPass;
pub use blur::{BlurTargets, TextureBlur};
pub use irradiance::IrradiancePass;
pub use subsurface_profile::oracle::texture::{
    BlurKernel, BlurStep, G7, MAX_SIGMA_TEXELS, cpu_blur, cpu_dilate,
};

/// What the texture-space maps are for in a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSpaceSettings {
    /// The blurred maps replace the lighting pass's diffuse irradiance (`--sss texture`).
    pub diffuse: bool,
    /// Translucent shadow maps read the widest blurred map (`--transmittance tsm`).
    pub tsm: bool,
    /// Map size in texels per side.
    pub size: u32,
    /// Padding of the UV islands in texels.
    pub padding: u32,
    /// Exponent of the albedo applied before the blur.
    pub albedo_pre: f32,
}

/// Every skin object must have a UV layout when the texture-space maps are on: without
/// `TEXCOORD_0` every vertex sits at uv (0, 0), the irradiance pass rasterises nothing, and
/// the object renders black with no other sign of why. Less than one texel of coverage is
/// treated the same way, and so is a mesh where only some glTF primitives lack UVs (the
/// others cover UV space, but those triangles would still render black). Checked before anything is allocated, by `Renderer::new` and on
/// every `Renderer::update` (the viewer can switch the method on).
pub fn check_uvs(scene: &crate::Scene, settings: &TextureSpaceSettings) -> Result<(), RenderError> {
    if !(settings.diffuse || settings.tsm) {
        return Ok(());
    }
    let one_texel = 1.0 / (f64::from(settings.size) * f64::from(settings.size));
    let bad = scene.objects.iter().enumerate().find_map(|(i, o)| {
        if o.material.sss_strength <= 0.0 || o.mesh.indices.is_empty() {
            return None;
        }
        let of = o.mesh.triangle_count();
        if let Some(m) = o.mesh.missing_uvs.as_ref().filter(|m| m.triangles < of) {
            return Some((
                i,
                o,
                format!(
                    "{} of its {of} triangles have no texture coordinates ({} has no TEXCOORD_0)",
                    m.triangles, m.first_primitive
                ),
            ));
        }
        let none = o.mesh.missing_uvs.is_some() || !o.mesh.uv_area_at_least(one_texel);
        none.then(|| {
            let why = "has no texture coordinates (no TEXCOORD_0, or its UVs cover less than \
                       one texel)";
            (i, o, why.to_string())
        })
    });
    let Some((i, o, why)) = bad else {
        return Ok(());
    };
    let (field, source) = match scene.desc.objects.get(i).map(|d| &d.mesh) {
        Some(crate::scene::MeshDesc::Gltf { path }) => (
            format!("objects[{i}].mesh.gltf"),
            format!("{path} ({})", o.name),
        ),
        _ => (format!("objects[{i}].mesh"), o.name.clone()),
    };
    let (method, instead) = if settings.diffuse {
        (
            "sss.method \"texture\"",
            "a screen-space method (e.g. --sss separable)",
        )
    } else {
        (
            "transmittance.method \"tsm\"",
            "another method (e.g. --transmittance paper)",
        )
    };
    Err(RenderError::invalid(
        field,
        format!(
            "{source} {why}: {method} lays the skin out in UV space and would render those \
             triangles black; use {instead} or give the mesh UVs"
        ),
    ))
}

/// The maps of one skin object.
struct ObjectMaps {
    irradiance: wgpu::Texture,
    stretch: wgpu::Texture,
    /// Views of `irradiance` and `stretch`: the targets of the irradiance pass.
    views: [wgpu::TextureView; 2],
    blur: BlurTargets,
}

/// The pipelines, built when the pass is active.
struct Pipelines {
    irradiance: IrradiancePass,
    blur: TextureBlur,
}

/// Per-object UV-space maps of skin objects (`sss_strength` > 0 and a mesh), their blur, and
/// the group-2 bind group the lighting pass uses for each `GpuObject`.
///
/// Shape: [`Self::new`] allocates the maps and writes every uniform (none changes from frame
/// to frame, so there is no `prepare`; the maps follow the settings, not the window, so there
/// is no `resize`: the renderer makes a new pass when the settings change); [`Self::encode`]
/// records the irradiance, blurs and padding.
pub struct TextureSpacePass {
    settings: TextureSpaceSettings,
    /// None when neither the diffuse nor TSM is on.
    pipelines: Option<Pipelines>,
    /// One per GpuObject: Some for skin objects when the pass is active.
    maps: Vec<Option<ObjectMaps>>,
    bind_groups: Vec<wgpu::BindGroup>,
}

impl TextureSpacePass {
    /// One group-2 bind group per `GpuObject` (the scene's objects with a mesh); maps for skin
    /// objects. Nothing is allocated when neither the diffuse nor TSM is on.
    pub fn new(
        ctx: &GpuContext,
        scene: &crate::Scene,
        settings: &TextureSpaceSettings,
        maps_layout: &wgpu::BindGroupLayout,
    ) -> Result<Self, RenderError> {
        let device = &ctx.device;
        let active = settings.diffuse || settings.tsm;
        if active {
            ctx.check_size("sss.texture_size", settings.size, settings.size)?;
        }
        let pipelines = active.then(|| Pipelines {
            irradiance: IrradiancePass::new(device, maps_layout),
            blur: TextureBlur::new(device),
        });
        let mut cache = MaterialCache::default();
        let mut maps = Vec::new();
        let mut bind_groups = Vec::new();
        let albedo_pre = if settings.diffuse {
            settings.albedo_pre
        } else {
            0.0
        };
        for (i, o) in scene.objects.iter().enumerate() {
            if o.mesh.indices.is_empty() {
                continue;
            }
            let pipelines = match &pipelines {
                Some(p) if o.material.sss_strength > 0.0 => p,
                _ => {
                    maps.push(None);
                    bind_groups.push(default_maps_bind_group(device, maps_layout));
                    continue;
                }
            };
            let optics = cache.get(&o.material.medium, &format!("objects[{i}].material.medium"))?;
            let kernel = BlurKernel::from_profile(&optics.profile);
            let irradiance = map_texture(
                device,
                "texture-space irradiance",
                settings.size,
                MAP_FORMAT,
            );
            let stretch = map_texture(
                device,
                "texture-space stretch",
                settings.size,
                STRETCH_FORMAT,
            );
            let targets =
                pipelines
                    .blur
                    .bind(device, &irradiance, &stretch, &kernel, settings.padding);
            let params = [
                settings.diffuse as u32 as f32,
                settings.tsm as u32 as f32,
                albedo_pre,
                0.0,
            ];
            bind_groups.push(maps::maps_bind_group(
                device,
                maps_layout,
                params,
                targets.result_view(),
                targets.widest_view(),
            ));
            let views = [
                irradiance.create_view(&Default::default()),
                stretch.create_view(&Default::default()),
            ];
            maps.push(Some(ObjectMaps {
                irradiance,
                stretch,
                views,
                blur: targets,
            }));
        }
        Ok(Self {
            settings: settings.clone(),
            pipelines,
            maps,
            bind_groups,
        })
    }

    /// The settings the maps were made for.
    pub fn settings(&self) -> &TextureSpaceSettings {
        &self.settings
    }

    /// Whether any object has maps to render.
    pub fn is_active(&self) -> bool {
        self.maps.iter().any(Option::is_some)
    }

    /// Group 2 of the lighting pass, one per `GpuObject`.
    pub fn bind_groups(&self) -> &[wgpu::BindGroup] {
        &self.bind_groups
    }

    /// The irradiance map (`Rgba16Float`) and stretch map (`Rg32Float`) of the `index`th
    /// `GpuObject`, and its blurred maps; None for objects without maps.
    pub fn object_maps(
        &self,
        index: usize,
    ) -> Option<(&wgpu::Texture, &wgpu::Texture, &BlurTargets)> {
        self.maps
            .get(index)?
            .as_ref()
            .map(|m| (&m.irradiance, &m.stretch, &m.blur))
    }

    /// Records, per skin object, the irradiance in UV space (with the lighting pass's frame
    /// bindings: camera, lights, shadow maps), the blurs and the padding. All timed "texture".
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        lighting: &LightingPass,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let Some(pipelines) = &self.pipelines else {
            return;
        };
        for ((m, o), bg) in self.maps.iter().zip(objects).zip(&self.bind_groups) {
            let Some(m) = m else { continue };
            pipelines
                .irradiance
                .encode(encoder, lighting, o, bg, &m.views, profiler);
            pipelines.blur.encode(encoder, &m.blur, profiler);
        }
    }
}

#[cfg(test)]
mod tests {
    use subsurface_profile::oracle::texture::f16_round;

    /// The CPU mirror rounds intermediate maps as `Rgba16Float` targets store them: the same
    /// as the `half` crate's conversion, over every exponent and both signs.
    #[test]
    fn oracle_f16_rounding_matches_half() {
        let mut bits = 0u32;
        while bits < u32::MAX - 65_521 {
            let v = f32::from_bits(bits);
            let expected = half::f16::from_f32(v).to_f32();
            let got = f16_round(v);
            assert!(
                got.to_bits() == expected.to_bits() || (got.is_nan() && expected.is_nan()),
                "{v:e} ({bits:#x}): {got:e} vs {expected:e}"
            );
            bits += 65_521;
        }
        // Every tie between neighbouring halves, and the floats either side of it.
        for h in 0..0x7bffu16 {
            let a = half::f16::from_bits(h).to_f32();
            let b = half::f16::from_bits(h + 1).to_f32();
            let mid = (a + b) / 2.0;
            for v in [mid, -mid, mid.next_up(), mid.next_down()] {
                assert_eq!(f16_round(v), half::f16::from_f32(v).to_f32(), "{v:e}");
            }
        }
    }
}
