//! CPU mirrors of the uniform blocks declared in `passes/common.wgsl`.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

/// Lights a scene may have: the length of `Lights::lights` in common.wgsl.
pub const MAX_LIGHTS: usize = 8;

/// The camera (`Camera` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct CameraUniform {
    /// World -> clip (wgpu conventions), column-major.
    pub view_proj: [[f32; 4]; 4],
    /// Eye position, scene units.
    pub position: [f32; 3],
    /// Near plane distance, scene units.
    pub near: f32,
    /// Unit view direction: linear depth is measured along it.
    pub forward: [f32; 3],
    /// Far plane distance, scene units.
    pub far: f32,
    /// Focal length in pixels, 0.5 * height / tan(fov_y / 2): turns scene units at a linear
    /// depth into pixels.
    pub focal_px: f32,
    /// The frame's size in pixels.
    pub viewport: [f32; 2],
    /// Padding to the WGSL layout.
    pub _pad: f32,
}

/// One light (`Light` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct LightUniform {
    /// The shadow camera's origin for directional lights.
    pub position: [f32; 3],
    /// `KIND_POINT`, `KIND_SPOT` or `KIND_DIRECTIONAL` of common.wgsl.
    pub kind: f32,
    /// Unit, light -> target.
    pub direction: [f32; 3],
    /// First shadow-map layer, -1 = no shadow map.
    pub first_layer: f32,
    /// Colour x intensity, linear RGB.
    pub color: [f32; 3],
    /// Shadow depth bias, scene units.
    pub shadow_bias: f32,
    /// Spot cone: cosine of the outer half-angle, where the light reaches zero.
    pub cos_outer: f32,
    /// Spot cone: cosine of the inner half-angle, inside which the light is at full intensity.
    pub cos_inner: f32,
    /// This light's share of the atlas layer, in uv.
    pub shadow_uv_scale: f32,
    /// One atlas texel, in uv.
    pub atlas_texel: f32,
    /// World -> clip of each shadow layer (six cube faces for a point light, one otherwise).
    pub view_proj: [[[f32; 4]; 4]; 6],
}

/// The frame's lights and transmittance settings (`Lights` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct LightsUniform {
    /// Lights in use at the start of `lights`.
    pub count: u32,
    /// `TransmittanceMethod::code`.
    pub transmittance: u32,
    /// Texels per axis averaged for thickness.
    pub thickness_filter: u32,
    /// Padding (the thickness view is a pipeline constant, `THICKNESS_VIEW`).
    pub _pad1: u32,
    /// Uniform ambient radiance, linear RGB.
    pub ambient: [f32; 3],
    /// Scene units the shaded point moves inward before the shadow-map lookup.
    pub normal_shrink: f32,
    /// 1 when subsurface scattering runs (any method but `none`): the diffuse light's shadow
    /// is looked up where the refracted light feeds the diffusion source.
    pub sss_runs: u32,
    /// `diffusion`: shadow-map taps of the lit surface around the chord (0: the chord alone).
    pub lateral_taps: u32,
    /// 1: the lateral taps run per pixel; N > 1: the lighting pass reads them from the lateral
    /// map at 1/N resolution (`passes::transmitted_map::TransmittedMapTargets`).
    pub map_downsample: u32,
    /// The transmitted map's layer that holds the bounce gathered at its texels
    /// (`passes::bounce`).
    pub bounce_layer: u32,
    /// `BounceSettings::ring`: 0 = no bounce.
    pub bounce_ring: u32,
    /// `BounceSettings::cell_mm`: the finest cells read, profile millimetres.
    pub bounce_cell_mm: f32,
    /// Padding to the WGSL layout.
    pub _pad: [u32; 2],
    /// The lights; the first `count` are used.
    pub lights: [LightUniform; MAX_LIGHTS],
}

/// One object's transform and material (`Object` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ObjectUniform {
    /// Object -> world.
    pub model: [[f32; 4]; 4],
    /// Inverse transpose of `model`, for normals.
    pub normal_matrix: [[f32; 4]; 4],
    /// Linear albedo (the material's times the medium's diffuse albedo).
    pub albedo: [f32; 3],
    /// Beckmann roughness m.
    pub roughness: f32,
    /// Specular intensity rho_s (1: the boundary's own reflection).
    pub specular: f32,
    /// 0 = not skin, 1 = full subsurface scattering.
    pub sss_strength: f32,
    /// Scene units per profile millimetre.
    pub world_per_mm: f32,
    /// Scale on the thickness transmittance sees.
    pub translucency: f32,
    /// 1: the object has an albedo texture; 0: a 1x1 white stand-in is bound.
    pub has_albedo_map: u32,
    /// 1: the object has a normal map; 0: a 1x1 white stand-in is bound.
    pub has_normal_map: u32,
    /// 1: the object has a specular map; 0: a 1x1 white stand-in is bound.
    pub has_specular_map: u32,
    /// Row of the screen-space SSS profile table.
    pub profile: u32,
    /// Beer-Lambert extinction sigma_t per mm.
    pub extinction: [f32; 3],
    /// Thickness range of the T(s) LUT in mm.
    pub lut_range_mm: f32,
    /// Relative index of refraction of the medium's boundary (the ballistic transmission lobe).
    pub eta: f32,
    /// The medium's slowest decay rate per mm, which spreads the lateral taps
    /// (`subsurface_profile::TransportTable::lateral_decay_per_mm`).
    pub lateral_decay: f32,
    /// The object's index in the frame's draw list: the transmitted map's surface targets record
    /// it, and each object's compute dispatch evaluates only its own texels.
    pub index: u32,
    /// Padding to the WGSL layout.
    pub _pad: f32,
    /// Reduced scattering coefficient sigma_s' per mm (single scattering, isotropic phase).
    pub reduced_scattering: [f32; 3],
    /// Padding to the WGSL layout.
    pub _pad2: f32,
    /// The rough boundary's transmittance against the cosine, as a degree-7 polynomial:
    /// coefficients 0..4, 4..8 (`subsurface_profile::specular::rough_transmittance_fit`).
    pub boundary_fit: [[f32; 4]; 2],
    /// The diffusion approximation's effective transport coefficient sigma_tr per mm
    /// (`subsurface_profile::DiffusionChannel::sigma_tr`): how fast diffuse light decays.
    pub transport_decay: [f32; 3],
    /// Padding to the WGSL layout.
    pub _pad3: f32,
    /// Height of the extrapolated boundary z_b = 2 A D in mm
    /// (`subsurface_profile::DiffusionChannel::z_b`), where a side wall's image source sits.
    pub extrapolation_mm: [f32; 3],
    /// Padding to the WGSL layout.
    pub _pad4: f32,
}

/// One shadow-map layer's camera (`ShadowView` in shadow.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ShadowViewUniform {
    /// World -> clip of the layer.
    pub view_proj: [[f32; 4]; 4],
    /// xyz: where the stored light distance is measured from; w: the light's kind.
    pub light_position: [f32; 4],
    /// xyz: the light's unit direction; w unused.
    pub light_direction: [f32; 4],
    /// Padding: the block is 256 bytes.
    pub _pad: [[f32; 4]; 10],
}

/// A matrix as WGSL's column-major `mat4x4<f32>`.
pub fn mat(m: Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

/// `v` and `w` as a WGSL `vec4<f32>`.
pub fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// Group 2 of the lighting pass (`TextureSpace` in lighting.wgsl), one per object.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TextureSpaceUniform {
    /// blurred map is the diffuse (0/1), translucent shadow maps on (0/1), albedo share
    /// applied before the blur, unused
    pub params: [f32; 4],
}

/// One pass of the texture-space blur (`BlurUniform` in texture_space.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct BlurUniform {
    /// xy = texel axis, z = sigma in profile mm, w unused
    pub dir: [f32; 4],
    /// rgb weight of the Gaussian, a unused
    pub weight: [f32; 4],
    /// padding radius in texels, largest sigma in texels, unused, unused
    pub params: [f32; 4],
}

/// View of one translucent-shadow-map layer (`TsmView` in texture_space.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TsmViewUniform {
    /// World -> clip of the layer.
    pub view_proj: [[f32; 4]; 4],
}

/// Every uniform block the shaders declare is laid out in WGSL as its mirror here is in Rust:
/// each named member at the same offset and the same size in all, read from the compiled
/// shader by naga, so a field added on one side only fails here rather than on a GPU.
#[cfg(test)]
mod layout_tests {
    use std::mem::{offset_of, size_of};

    use super::*;

    /// `(member, offset)` of a WGSL struct of the lighting shader, and its span.
    fn wgsl_struct(name: &str) -> (Vec<(String, usize)>, usize) {
        let module = naga::front::wgsl::parse_str(crate::passes::lighting::SHADER).unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no struct {name} in the lighting shader"));
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{name} is not a struct");
        };
        let _ = handle;
        let members = members
            .iter()
            .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
            .collect();
        (members, *span as usize)
    }

    /// Asserts that WGSL's `name` matches `rust` (`(field, offset)` of every named field of the
    /// Rust struct, `size` its size); members whose names start with `_` are padding.
    fn assert_same(name: &str, rust: &[(&str, usize)], size: usize) {
        let (wgsl, span) = wgsl_struct(name);
        assert_eq!(span, size, "{name}: WGSL span {span}, Rust size {size}");
        let named: Vec<_> = wgsl.iter().filter(|(m, _)| !m.starts_with('_')).collect();
        for (member, offset) in &named {
            let want = rust.iter().find(|(f, _)| f == member).map(|(_, o)| *o);
            assert_eq!(
                want,
                Some(*offset),
                "{name}.{member}: WGSL offset {offset}, Rust {want:?}"
            );
        }
        for (field, _) in rust {
            assert!(
                named.iter().any(|(m, _)| m == field),
                "{name}: Rust field {field} has no WGSL member"
            );
        }
    }

    macro_rules! fields {
        ($ty:ty { $($f:ident),* $(,)? }) => {
            &[$((stringify!($f), offset_of!($ty, $f))),*]
        };
    }

    /// [`assert_same`] for WGSL's `$name` and the Rust struct `$ty`, whose named fields are all
    /// it has.
    macro_rules! assert_layout {
        ($name:literal, $ty:ident { $($f:ident),* $(,)? }) => {
            assert_same($name, fields!($ty { $($f),* }), size_of::<$ty>())
        };
    }

    #[test]
    fn uniform_blocks_match_their_wgsl_declarations() {
        let viewport = offset_of!(CameraUniform, viewport);
        let camera: &[(&str, usize)] = fields!(CameraUniform {
            view_proj,
            position,
            near,
            forward,
            far,
            focal_px
        });
        // WGSL takes the viewport as two scalars (a vec2 would be aligned to 8 bytes).
        let camera = [
            camera,
            &[("viewport_x", viewport), ("viewport_y", viewport + 4)],
        ]
        .concat();
        assert_same("Camera", &camera, size_of::<CameraUniform>());
        assert_layout!(
            "Light",
            LightUniform {
                position,
                kind,
                direction,
                first_layer,
                color,
                shadow_bias,
                cos_outer,
                cos_inner,
                shadow_uv_scale,
                atlas_texel,
                view_proj,
            }
        );
        assert_layout!(
            "Lights",
            LightsUniform {
                count,
                transmittance,
                thickness_filter,
                ambient,
                normal_shrink,
                sss_runs,
                lateral_taps,
                map_downsample,
                bounce_layer,
                bounce_ring,
                bounce_cell_mm,
                lights,
            }
        );
        assert_layout!(
            "Object",
            ObjectUniform {
                model,
                normal_matrix,
                albedo,
                roughness,
                specular,
                sss_strength,
                world_per_mm,
                translucency,
                has_albedo_map,
                has_normal_map,
                has_specular_map,
                profile,
                extinction,
                lut_range_mm,
                eta,
                lateral_decay,
                index,
                reduced_scattering,
                boundary_fit,
                transport_decay,
                extrapolation_mm,
            }
        );
    }
}
