//! One module per pass, each with its WGSL beside it.

pub mod bounce;
pub mod copy;
pub mod fullscreen;
pub mod lateral_map;
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
pub mod tsm;
pub mod util;

/// Every WGSL program of the crate as compiled (name, full source). The naga unit test
/// validates each of them without a GPU.
pub const ALL_SHADERS: &[(&str, &str)] = &[
    ("shadow.wgsl", shadow::SHADER),
    ("bounce_build.wgsl", bounce::SHADER),
    ("lighting.wgsl", lighting::SHADER),
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
