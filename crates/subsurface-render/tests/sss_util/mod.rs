//! Shared helpers of the screen-space SSS tests: G-buffer textures made from an oracle input,
//! the pass run through its public API, and the test card.
#![allow(dead_code)]

use subsurface_profile::oracle::{self, ScreenInput};
use subsurface_profile::{KernelParams, ScreenKernels};
use subsurface_render::passes::sss::{SssInputs, SssPass};
use subsurface_render::{GpuContext, SssFetch, SssMethod, SssSettings};

use crate::common::{read4, upload_texture, upload_texture_with};

pub const FOCAL: f32 = 300.0;

/// Rounds colours, strengths and scales to f16 as the renderer stores them (its diffuse and
/// SSS targets are Rgba16Float, and the packed fetch keeps them so), so oracle and GPU start
/// from the same input.
pub fn to_f16_exact(input: &mut ScreenInput) {
    let f16 = |v: f32| half::f16::from_f32(v).to_f32();
    for c in &mut input.color {
        *c = c.map(f16);
    }
    for v in input.strength.iter_mut().chain(&mut input.world_per_mm) {
        *v = f16(*v);
    }
}

/// The skin kernels for `samples` taps: a one-row profile table.
pub fn skin(samples: u32) -> Vec<ScreenKernels> {
    vec![
        ScreenKernels::skin(&KernelParams {
            samples,
            ..Default::default()
        })
        .unwrap(),
    ]
}

/// Skin, marble and ketchup (Jensen et al. 2001's measured coefficients, fitted with six
/// Gaussians): the table the renderer builds for a scene with the three side by side.
pub fn three_materials(samples: u32) -> Vec<ScreenKernels> {
    let mut table = skin(samples);
    for name in ["marble", "ketchup"] {
        let fit = subsurface_profile::material(name).unwrap().fit(6).unwrap();
        let params = KernelParams {
            samples,
            strength: [1.0; 3],
            falloff: [1.0; 3],
        };
        table.push(ScreenKernels::for_profile(&fit.profile, &params).unwrap());
    }
    table
}

pub fn settings(method: SssMethod) -> SssSettings {
    SssSettings {
        method,
        ..Default::default()
    }
}

/// Runs the SSS pass with a skin-only table.
pub fn run_gpu(ctx: &GpuContext, input: &ScreenInput, settings: &SssSettings) -> Vec<[f32; 3]> {
    run_gpu_with(ctx, input, settings, &skin(settings.samples))
}

/// Runs the SSS pass on the GPU over `input` with this profile table and returns the
/// blurred colour.
pub fn run_gpu_with(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    table: &[ScreenKernels],
) -> Vec<[f32; 3]> {
    run_gpu_on(ctx, input, config, table, true)
}

/// As `run_gpu_with`; `storage`: whether the diffuse texture allows storage writes (which the
/// workgroup fetch's vertical compute pass needs, or it falls back to a fragment pass).
pub fn run_gpu_on(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    table: &[ScreenKernels],
    storage: bool,
) -> Vec<[f32; 3]> {
    run_gpu_at(ctx, input, config, table, storage, FOCAL)
}

/// As `run_gpu_on`, with the workgroup fetch's first pass packing as it loads (`true`, the
/// choice on GPUs) or after a pack step (`false`, on CPU adapters) whatever the adapter.
pub fn run_gpu_packing(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    table: &[ScreenKernels],
    storage: bool,
    pack_on_load: bool,
) -> Vec<[f32; 3]> {
    run_gpu_full(
        ctx,
        input,
        config,
        table,
        (storage, Some(pack_on_load)),
        FOCAL,
    )
}

/// As `run_gpu_on`, for a camera of focal length `focal_px` (pixels).
pub fn run_gpu_at(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    table: &[ScreenKernels],
    storage: bool,
    focal_px: f32,
) -> Vec<[f32; 3]> {
    run_gpu_full(ctx, input, config, table, (storage, None), focal_px)
}

fn run_gpu_full(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    table: &[ScreenKernels],
    (storage, pack_on_load): (bool, Option<bool>),
    focal_px: f32,
) -> Vec<[f32; 3]> {
    let (w, h) = (input.width, input.height);
    let colour: Vec<half::f16> = input
        .color
        .iter()
        .flat_map(|c| [c[0], c[1], c[2], 1.0])
        .map(half::f16::from_f32)
        .collect();
    let diffuse = upload_texture_with(
        ctx,
        w,
        h,
        wgpu::TextureFormat::Rgba16Float,
        bytemuck::cast_slice(&colour),
        if storage {
            wgpu::TextureUsages::STORAGE_BINDING
        } else {
            wgpu::TextureUsages::empty()
        },
    );
    let depth = upload_texture(
        ctx,
        w,
        h,
        wgpu::TextureFormat::R32Float,
        bytemuck::cast_slice(&input.depth),
    );
    let sss_data: Vec<f32> = (0..input.strength.len())
        .flat_map(|i| {
            [
                input.strength[i],
                input.world_per_mm[i],
                input.profile[i] as f32,
                0.0,
            ]
        })
        .collect();
    let sss = upload_texture(
        ctx,
        w,
        h,
        wgpu::TextureFormat::Rgba32Float,
        bytemuck::cast_slice(&sss_data),
    );
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let mut pass = SssPass::new(&ctx.device, config, table).unwrap();
    if let Some(on) = pack_on_load {
        pass.set_pack_on_load(on);
    }
    pass.resize(
        &ctx.device,
        &SssInputs {
            diffuse: &diffuse,
            depth: &view(&depth),
            sss: &view(&sss),
        },
    );
    pass.prepare(&ctx.queue, focal_px);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    pass.encode(&mut encoder, None);
    ctx.queue.submit([encoder.finish()]);
    ctx.check().unwrap();
    read4(ctx, &diffuse)
        .into_iter()
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// A 96x64 test card: smooth colour waves (so bilinear weight precision does not matter),
/// a near and a far surface with a depth step, a non-skin square, and varying strength.
pub fn test_card() -> ScreenInput {
    let (w, h) = (96u32, 64u32);
    let mut input = ScreenInput::uniform(w, h, [0.0; 3], 1.0, 1.0, 0.004);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (fx, fy) = (x as f32, y as f32);
            input.color[i] = [
                0.2 + 0.1 * (fx * 0.35).sin() + 0.05 * (fx * 1.3).sin(),
                0.2 + 0.1 * (fy * 0.3).cos(),
                0.15 + 0.1 * ((fx + fy) * 0.25).sin(),
            ];
            input.depth[i] = if x < 60 { 0.5 } else { 0.8 };
            input.strength[i] = if x > 70 { 0.5 } else { 1.0 };
            if (20..34).contains(&x) && (20..40).contains(&y) {
                input.strength[i] = 0.0;
                input.color[i] = [0.1, 0.4, 0.45];
            }
        }
    }
    to_f16_exact(&mut input);
    input
}

pub fn max_abs_diff(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()))
        .fold(0.0, f32::max)
}

pub fn params(config: &SssSettings) -> oracle::ScreenParams {
    oracle::ScreenParams {
        focal_px: FOCAL,
        follow_surface: config.follow_surface,
        edge_mm: config.edge_mm,
    }
}

pub const METHODS: [SssMethod; 3] = [
    SssMethod::Separable,
    SssMethod::Gaussian6,
    SssMethod::Hable13,
];

/// Every screen-space method with every way of fetching texels.
pub fn methods_and_fetches() -> impl Iterator<Item = (SssMethod, SssFetch, SssSettings)> {
    METHODS.into_iter().flat_map(|m| {
        SssFetch::ALL.map(|fetch| {
            let config = SssSettings {
                fetch,
                ..settings(m)
            };
            (m, fetch, config)
        })
    })
}
