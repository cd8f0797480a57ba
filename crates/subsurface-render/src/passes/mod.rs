//! One module per pass, each with its WGSL beside it.

/// The lighting shader's WGSL files in order (ids, common declarations, groups 0 and 1, lighting,
/// shadow lookups, transmittance, its side walls, its lit side and its unscattered light,
/// bounce), then `$extra` (more WGSL, e.g. `include_str!` of a pass's entry points): the one
/// list every pass built on the lighting shader starts from.
macro_rules! lighting_shader {
    ($($extra:expr),* $(,)?) => {
        concat!(
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/ids.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/common.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/bindings/frame.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/bindings/object.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/lighting/lighting.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/shadow_lookup.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/transmittance.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/side_walls.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/lit_side.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/unscattered.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/map_read.wgsl")),
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/passes/bounce.wgsl")),
            $($extra),*
        )
    };
}

pub mod bounce;
pub mod copy;
pub mod fullscreen;
pub mod lighting;
pub mod maps;
pub mod overrides;
pub mod shadow;
pub mod shadow_entry;
pub mod sss;
pub mod texture_space;
pub mod tonemap;
pub mod traffic;
pub mod transmittance;
pub mod transmitted_light;
pub mod transmitted_map;
pub mod tsm;
pub mod util;

/// Every WGSL program of the crate as compiled (name, full source). The naga unit test
/// validates each of them without a GPU.
pub const ALL_SHADERS: &[(&str, &str)] = &[
    ("shadow.wgsl", shadow::SHADER),
    ("bounce_build.wgsl", bounce::SHADER),
    ("lighting.wgsl", lighting::SHADER),
    ("lighting/outline_mark.wgsl", lighting::OUTLINE_MARK_SHADER),
    ("tonemap.wgsl", tonemap::SHADER),
    ("sss.wgsl + sss_direct.wgsl", sss::SHADER),
    ("sss.wgsl + sss_packed.wgsl", sss::SHADER_PACKED),
    ("sss.wgsl + sss_workgroup.wgsl", sss::SHADER_WORKGROUP),
    ("copy.wgsl", copy::SHADER),
    (
        "texture_space/irradiance.wgsl",
        texture_space::irradiance::SHADER,
    ),
    ("texture_space/blur.wgsl", texture_space::blur::SHADER),
    ("tsm/tsm.wgsl", tsm::SHADER),
    ("shadow_entry/shadow_entry.wgsl", shadow_entry::SHADER),
    (
        "transmitted_light/transmitted_light.wgsl",
        transmitted_light::SHADER,
    ),
];
