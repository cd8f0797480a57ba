//! Real-time subsurface scattering for human skin on wgpu.
//!
//! The frame flows one way: scene -> shadow maps (linear light distance) -> lighting (HDR
//! diffuse, specular, linear depth, SSS strength) -> composite and filmic tone map -> image.
//! Each pass lives in [`passes`] with its WGSL beside it and can be used on its own textures.

#![warn(missing_docs)]

pub mod budget;
pub mod error;
pub mod frame_plan;
pub mod gpu;
pub mod gpu_scene;
pub mod input;
pub mod lights;
pub mod material;
pub mod mesh;
pub mod passes;
pub mod readback;
pub mod renderer;
pub mod scene;
pub mod settings;
pub mod timing;
pub mod uniforms;

pub use error::RenderError;
pub use gpu::GpuContext;
pub use passes::tonemap::DebugView;
pub use renderer::{Frame, RenderOptions, Renderer};
pub use scene::Scene;
pub use settings::{
    BounceSettings, DEFAULT_MAP_TEXEL_MM, MAX_MAP_DOWNSAMPLE, MAX_TEXEL_FACTOR, MapEvaluation,
    OutlineChords, RenderSettings, SETTINGS, SettingDoc, SssFetch, SssMethod, SssSettings,
    TransmittanceMethod, TransmittanceSettings, TransmittedMapSettings,
};
pub use timing::PassTiming;

/// True when `SUBSURFACE_REQUIRE_GPU=1`: tests must fail, not skip, without an adapter.
pub fn gpu_required() -> bool {
    std::env::var("SUBSURFACE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

#[cfg(test)]
mod shader_tests {
    /// Every WGSL program parses and validates with naga; no GPU needed.
    #[test]
    fn all_wgsl_validates_with_naga() {
        for (name, source) in crate::passes::ALL_SHADERS {
            let module = naga::front::wgsl::parse_str(source)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        }
    }

    /// The lighting pass builds `fs_main` once per transmittance method by setting the WGSL
    /// override `TRANSMITTANCE_METHOD` (frame_plan.rs, `LightingVariant`): each value, and the default that
    /// follows the uniform, must survive override processing and SPIR-V output, as wgpu does
    /// it when the pipeline is created (an error there would only show on a GPU).
    #[test]
    fn every_transmittance_specialization_compiles() {
        let source = crate::passes::lighting::SHADER;
        let module = naga::front::wgsl::parse_str(source).unwrap();
        assert!(
            module
                .overrides
                .iter()
                .any(|(_, o)| o.name.as_deref() == Some("TRANSMITTANCE_METHOD")),
            "lighting.wgsl has no TRANSMITTANCE_METHOD override"
        );
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap();
        let codes = crate::TransmittanceMethod::ALL.map(|m| m.code());
        // Every method with every source of `diffusion` (frame_plan.rs, `LightingVariant::lateral`).
        let variants = codes
            .into_iter()
            .chain([255])
            .flat_map(|code| [0, 1, 2, 3, 255].map(|source| (code, source)));
        for (code, source) in variants {
            let mut constants = naga::back::PipelineConstants::default();
            constants.insert("TRANSMITTANCE_METHOD".into(), f64::from(code));
            constants.insert("LATERAL_SOURCE".into(), f64::from(source));
            // Each term alone and none: every `has_term` branch compiles either way.
            let terms = [7, 0, 1, 2, 4][usize::from(code as u8) % 5];
            constants.insert("DIFFUSION_TERMS".into(), f64::from(terms));
            // The chords at outlines inline or left to the outline pass, alternately.
            constants.insert("OUTLINE_PASS".into(), f64::from(source % 2));
            // The transmitted map's compute evaluation (transmitted_map.wgsl) is specialized alike.
            let entries = [
                (naga::ShaderStage::Fragment, "fs_main"),
                (naga::ShaderStage::Fragment, "fs_outline"),
                (naga::ShaderStage::Fragment, "fs_transmitted"),
                (naga::ShaderStage::Fragment, "fs_bounce"),
                (naga::ShaderStage::Fragment, "fs_surface"),
                (naga::ShaderStage::Compute, "cs_transmitted"),
                (naga::ShaderStage::Compute, "cs_bounce"),
                (naga::ShaderStage::Compute, "cs_clear"),
            ];
            for (shader_stage, entry) in entries {
                let stage = Some((shader_stage, entry));
                let (specialized, specialized_info) =
                    naga::back::pipeline_constants::process_overrides(
                        &module, &info, stage, &constants,
                    )
                    .unwrap_or_else(|e| panic!("method {code}, source {source}, {entry}: {e:?}"));
                let options = naga::back::spv::Options::default();
                let pipeline = naga::back::spv::PipelineOptions {
                    shader_stage,
                    entry_point: entry.into(),
                };
                naga::back::spv::write_vec(
                    &specialized,
                    &specialized_info,
                    &options,
                    Some(&pipeline),
                )
                .unwrap_or_else(|e| panic!("method {code}, source {source}, {entry}: {e:?}"));
            }
        }
    }

    /// Every .wgsl file beside the passes (in their subfolders too) is part of some compiled
    /// shader, so none escapes the validation above.
    #[test]
    fn every_wgsl_file_is_validated() {
        fn wgsl_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    wgsl_files(&path, out);
                } else if path.extension().is_some_and(|e| e == "wgsl") {
                    out.push(path);
                }
            }
        }
        let mut files = Vec::new();
        wgsl_files(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/passes"),
            &mut files,
        );
        for path in &files {
            let text = std::fs::read_to_string(path).unwrap();
            assert!(
                crate::passes::ALL_SHADERS
                    .iter()
                    .any(|(_, s)| s.contains(text.trim())),
                "{} is not in passes::ALL_SHADERS",
                path.display()
            );
        }
        assert!(
            files.len() >= 10,
            "expected at least 10 WGSL files, found {}",
            files.len()
        );
    }
}
