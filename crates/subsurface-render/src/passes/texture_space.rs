//! Texture-space diffusion (d'Eon, Luebke and Enderton 2007) and translucent shadow maps.
//!
//! Per skin object: (1) the lighting pass's lights, shadows, ambient and transmittance are
//! evaluated with the mesh laid out by its texture coordinates, into an irradiance map
//! (`Rgba16Float`, alpha = covered) and a stretch map (`Rg32Float`: profile millimetres per
//! texel along u and v, from the derivatives of the world position); (2) the profile's
//! Gaussians are applied as separable 7-tap blurs, each Gaussian made from the previous one by
//! its variance increment, converted from millimetres to texels through the stretch map, and
//! summed with the profile's per-channel weights (normalised, so that the albedo carries the
//! reflectance, as in the screen-space passes); (3) the UV islands are padded by a few texels;
//! (4) the lighting pass reads the sum at the fragment's uv instead of its own irradiance.
//!
//! Albedo: `SssConfig::texture_albedo_pre` is the exponent of the albedo applied before the
//! blur; the rest is applied after it (0 = post-scatter, 0.5 = d'Eon's pre- and post-scatter,
//! the default, 1 = all before, as the screen-space passes do).
//!
//! Seams: taps that land outside every island are replaced by the centre texel, exactly as the
//! screen-space passes treat background pixels; near a seam the blur is narrower but never
//! darker. Scattering across a seam (to the other island) is not modelled.
//!
//! Translucent shadow maps ([`TsmPass`]): each shadow layer is rendered a second time storing
//! the (u, v) of the surface nearest the light (`Rg32Float`, beside the `R32Float` distance:
//! the three floats per texel the papers count). With `TransmittanceMethod::Tsm` the lighting
//! pass adds `T(s) x E_widest(u_in, v_in)` per light: the thickness `s` and `T(s)` as in the
//! 2010 method (same LUT, same filtered distance), but the back-side irradiance read from the
//! widest blurred Gaussian at the entry point instead of estimated from the vertex normal.

use subsurface_profile::SumOfGaussians;
use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::gpu_scene::{GpuObject, ShadowLayer};
use crate::passes::transmittance::MaterialCache;
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{BlurUniform, TextureSpaceUniform, TsmViewUniform, mat};

pub const SHADER: &str = concat!(
    include_str!("common.wgsl"),
    include_str!("lighting.wgsl"),
    include_str!("transmittance.wgsl"),
    include_str!("texture_space.wgsl")
);
/// Irradiance, blurred and accumulated maps.
pub const MAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Profile millimetres per texel along u and v.
pub const STRETCH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// Translucent shadow maps: (u, v) of the surface nearest the light.
pub const TSM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// The 7-tap weights, one standard deviation apart.
pub const G7: [f32; 7] = [0.006, 0.061, 0.242, 0.382, 0.242, 0.061, 0.006];
/// Largest standard deviation of one blur pass, in texels: a degenerate (zero-area) texel
/// would otherwise send its taps across the whole map.
pub const MAX_SIGMA_TEXELS: f32 = 256.0;

/// One Gaussian after the narrowest: its variance increment over the previous one (as a
/// standard deviation in profile millimetres) and its RGB weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlurStep {
    pub sigma_mm: f32,
    pub weight: [f32; 3],
}

/// The sum of Gaussians as texture-space passes: the narrowest Gaussian is the irradiance
/// itself (its variance is under a texel on skin), each later one is the previous blurred by
/// `sigma_mm`.
#[derive(Clone, Debug, PartialEq)]
pub struct BlurKernel {
    pub first_weight: [f32; 3],
    pub steps: Vec<BlurStep>,
}

impl BlurKernel {
    /// The profile's terms with weights normalised per channel.
    pub fn from_profile(profile: &SumOfGaussians) -> Self {
        let total = profile.total_weight();
        let w = |t: &subsurface_profile::GaussianTerm| {
            [0, 1, 2].map(|c| {
                if total[c] > 0.0 {
                    (t.weight[c] / total[c]) as f32
                } else {
                    0.0
                }
            })
        };
        let terms = profile.terms();
        let steps = terms
            .windows(2)
            .map(|p| BlurStep {
                sigma_mm: (p[1].variance - p[0].variance).max(0.0).sqrt() as f32,
                weight: w(&p[1]),
            })
            .collect();
        Self {
            first_weight: w(&terms[0]),
            steps,
        }
    }
}

// ---- CPU mirror ------------------------------------------------------------------------------

fn f16_round(v: f32) -> f32 {
    half::f16::from_f32(v).to_f32()
}

fn round4(c: [f32; 4]) -> [f32; 4] {
    c.map(f16_round)
}

/// One 1-D blur pass on the CPU, the same arithmetic as `ts_blur` in texture_space.wgsl.
fn cpu_pass(
    size: u32,
    src: &[[f32; 4]],
    stretch: &[[f32; 2]],
    axis: usize,
    sigma_mm: f32,
) -> Vec<[f32; 4]> {
    let n = size as i32;
    let at = |x: i32, y: i32| src[(y * n + x) as usize];
    let mut out = vec![[0.0; 4]; src.len()];
    for y in 0..n {
        for x in 0..n {
            let c = at(x, y);
            let i = (y * n + x) as usize;
            if c[3] <= 0.5 {
                out[i] = c;
                continue;
            }
            let centre = [c[0], c[1], c[2]];
            let mm = stretch[i][axis];
            let sigma = (sigma_mm / mm.max(1e-12)).min(MAX_SIGMA_TEXELS);
            let texel = |tx: i32, ty: i32| {
                let t = at(tx, ty);
                if t[3] > 0.5 {
                    [t[0], t[1], t[2]]
                } else {
                    centre
                }
            };
            let mut sum = centre.map(|v| v * G7[3]);
            for (j, w) in G7.iter().enumerate() {
                if j == 3 {
                    continue;
                }
                let off = (j as f32 - 3.0) * sigma;
                // Position along the axis in pixel coordinates (texel centres at +0.5).
                let (px, py) = if axis == 0 {
                    (x as f32 + 0.5 + off, y as f32 + 0.5)
                } else {
                    (x as f32 + 0.5, y as f32 + 0.5 + off)
                };
                let (tx, ty) = (px - 0.5, py - 0.5);
                let (fx0, fy0) = (tx.floor(), ty.floor());
                let (fx, fy) = (tx - fx0, ty - fy0);
                let (ax, ay) = ((fx0 as i32).clamp(0, n - 1), (fy0 as i32).clamp(0, n - 1));
                let (bx, by) = (
                    (fx0 as i32 + 1).clamp(0, n - 1),
                    (fy0 as i32 + 1).clamp(0, n - 1),
                );
                let mix =
                    |a: [f32; 3], b: [f32; 3], f: f32| [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * f);
                let mut top = texel(ax, ay);
                if fx > 0.0 {
                    top = mix(top, texel(bx, ay), fx);
                }
                if fy > 0.0 {
                    let mut bottom = texel(ax, by);
                    if fx > 0.0 {
                        bottom = mix(bottom, texel(bx, by), fx);
                    }
                    top = mix(top, bottom, fy);
                }
                for k in 0..3 {
                    sum[k] += w * top[k];
                }
            }
            out[i] = [sum[0], sum[1], sum[2], c[3]];
        }
    }
    out
}

/// The texture-space blur on the CPU, mirroring the GPU passes (including the `Rgba16Float`
/// rounding of every intermediate map). `irradiance` is row-major `size` x `size` RGBA (a
/// texel is covered where alpha exceeds 0.5), `stretch` profile mm per texel along u and v. Returns the accumulated
/// sum of Gaussians and the widest Gaussian alone, before padding.
pub fn cpu_blur(
    size: u32,
    irradiance: &[[f32; 4]],
    stretch: &[[f32; 2]],
    kernel: &BlurKernel,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let w0 = kernel.first_weight;
    let src: Vec<[f32; 4]> = irradiance.iter().map(|c| round4(*c)).collect();
    let mut accum: Vec<[f32; 4]> = src
        .iter()
        .map(|c| round4([c[0] * w0[0], c[1] * w0[1], c[2] * w0[2], c[3]]))
        .collect();
    let mut current = src;
    for step in &kernel.steps {
        let h: Vec<[f32; 4]> = cpu_pass(size, &current, stretch, 0, step.sigma_mm)
            .into_iter()
            .map(round4)
            .collect();
        let v: Vec<[f32; 4]> = cpu_pass(size, &h, stretch, 1, step.sigma_mm)
            .into_iter()
            .map(round4)
            .collect();
        for (a, b) in accum.iter_mut().zip(&v) {
            let w = step.weight;
            *a = round4([
                a[0] + b[0] * w[0],
                a[1] + b[1] * w[1],
                a[2] + b[2] * w[2],
                b[3],
            ]);
        }
        current = v;
    }
    (accum, current)
}

/// Padding of UV islands on the CPU, as `fs_ts_dilate`: empty texels within `radius` take
/// the mean of the covered texels on the nearest square ring (alpha 0.5).
pub fn cpu_dilate(size: u32, map: &[[f32; 4]], radius: u32) -> Vec<[f32; 4]> {
    let n = size as i32;
    let mut out = map.to_vec();
    for y in 0..n {
        for x in 0..n {
            let i = (y * n + x) as usize;
            if map[i][3] > 0.5 {
                continue;
            }
            'rings: for r in 1..=radius as i32 {
                let (mut sum, mut count) = ([0.0f32; 3], 0.0f32);
                for dy in -r..=r {
                    for dx in -r..=r {
                        if dx.abs().max(dy.abs()) != r {
                            continue;
                        }
                        let (qx, qy) = (x + dx, y + dy);
                        if qx < 0 || qy < 0 || qx >= n || qy >= n {
                            continue;
                        }
                        let q = map[(qy * n + qx) as usize];
                        if q[3] > 0.5 {
                            for k in 0..3 {
                                sum[k] += q[k];
                            }
                            count += 1.0;
                        }
                    }
                }
                if count > 0.0 {
                    out[i] = [sum[0] / count, sum[1] / count, sum[2] / count, 0.5];
                    break 'rings;
                }
            }
        }
    }
    out
}

// ---- GPU blur --------------------------------------------------------------------------------

fn map_texture(
    device: &wgpu::Device,
    label: &str,
    size: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    util::render_target(device, label, size, size, format)
}

const P_COPY: usize = 0;
const P_BLUR: usize = 1;
const P_ACCUMULATE: usize = 2;
const P_DILATE: usize = 3;

/// The blur and padding pipelines; shared by every object.
pub struct TextureBlur {
    layout: wgpu::BindGroupLayout,
    pipelines: Vec<wgpu::RenderPipeline>,
}

struct BlurStepPass {
    pipeline: usize,
    bind_group: wgpu::BindGroup,
    /// Indices into `BlurTargets::views`.
    targets: [usize; 2],
    two_targets: bool,
}

/// The maps of one blur, created by [`TextureBlur::bind`]: `result` holds the padded sum of
/// Gaussians and `widest` the padded widest Gaussian (both `Rgba16Float`, alpha 1 on the
/// islands, 0.5 in the padding, 0 elsewhere).
pub struct BlurTargets {
    pub result: wgpu::Texture,
    pub widest: wgpu::Texture,
    /// The accumulated sum before padding.
    pub accum: wgpu::Texture,
    views: Vec<wgpu::TextureView>,
    _textures: Vec<wgpu::Texture>,
    _uniforms: Vec<wgpu::Buffer>,
    steps: Vec<BlurStepPass>,
}

impl BlurTargets {
    pub fn result_view(&self) -> &wgpu::TextureView {
        &self.views[V_RESULT]
    }
    pub fn widest_view(&self) -> &wgpu::TextureView {
        &self.views[V_WIDEST]
    }
}

// View indices of BlurTargets.
const V_TMP: usize = 0;
const V_PING: usize = 1;
const V_ACCUM: usize = 3;
const V_RESULT: usize = 4;
const V_WIDEST: usize = 5;

impl TextureBlur {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = util::wgsl_module(device, "texture_space.wgsl", SHADER);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        // The stretch map is Rg32Float; the blur reads texels without a sampler anyway.
        let tex = |binding| {
            util::float_texture_entry(binding, fragment, false, wgpu::TextureViewDimension::D2)
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("texture-space blur"),
            entries: &[util::uniform_entry(10, fragment), tex(11), tex(12), tex(13)],
        });
        let pipeline_layout = util::pipeline_layout(device, "texture-space blur", &[&layout]);
        let replace = Some(wgpu::ColorTargetState::from(MAP_FORMAT));
        let additive = Some(util::additive_target(MAP_FORMAT));
        let make = |entry: &str, targets: &[Option<wgpu::ColorTargetState>]| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_ts_fullscreen"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipelines = vec![
            make("fs_ts_copy", std::slice::from_ref(&replace)),
            make("fs_ts_blur", std::slice::from_ref(&replace)),
            make("fs_ts_blur_accumulate", &[replace.clone(), additive]),
            make("fs_ts_dilate", &[replace.clone(), replace]),
        ];
        Self { layout, pipelines }
    }

    /// Creates the maps and bind groups that blur `irradiance` (`Rgba16Float`, square, alpha >
    /// 0.5 = covered) with `stretch` (`Rg32Float`, profile mm per texel along u and v).
    pub fn bind(
        &self,
        device: &wgpu::Device,
        irradiance: &wgpu::Texture,
        stretch: &wgpu::Texture,
        kernel: &BlurKernel,
        padding: u32,
    ) -> BlurTargets {
        let size = irradiance.width();
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let textures: Vec<wgpu::Texture> = [
            "texture-space tmp",
            "texture-space ping",
            "texture-space pong",
            "texture-space accum",
            "texture-space result",
            "texture-space widest",
        ]
        .iter()
        .map(|l| map_texture(device, l, size, MAP_FORMAT))
        .collect();
        let views: Vec<wgpu::TextureView> = textures.iter().map(view).collect();
        let irradiance_view = view(irradiance);
        let stretch_view = view(stretch);
        let mut uniforms = Vec::new();
        let mut bind = |u: BlurUniform, src: &wgpu::TextureView, extra: &wgpu::TextureView| {
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("texture-space blur"),
                contents: bytemuck::bytes_of(&u),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("texture-space blur"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 10,
                        resource: buffer.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 11,
                        resource: wgpu::BindingResource::TextureView(src),
                    },
                    wgpu::BindGroupEntry {
                        binding: 12,
                        resource: wgpu::BindingResource::TextureView(&stretch_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 13,
                        resource: wgpu::BindingResource::TextureView(extra),
                    },
                ],
            });
            uniforms.push(buffer);
            bg
        };
        let params = [padding as f32, MAX_SIGMA_TEXELS, 0.0, 0.0];
        let w4 = |w: [f32; 3]| [w[0], w[1], w[2], 0.0];
        let mut steps = vec![BlurStepPass {
            pipeline: P_COPY,
            bind_group: bind(
                BlurUniform {
                    dir: [0.0; 4],
                    weight: w4(kernel.first_weight),
                    params,
                },
                &irradiance_view,
                &irradiance_view,
            ),
            targets: [V_ACCUM, V_ACCUM],
            two_targets: false,
        }];
        // None = the irradiance map itself.
        let mut source: Option<usize> = None;
        for (k, s) in kernel.steps.iter().enumerate() {
            let src = source.map_or(&irradiance_view, |i| &views[i]);
            let h = bind(
                BlurUniform {
                    dir: [1.0, 0.0, s.sigma_mm, 0.0],
                    weight: w4(s.weight),
                    params,
                },
                src,
                src,
            );
            steps.push(BlurStepPass {
                pipeline: P_BLUR,
                bind_group: h,
                targets: [V_TMP, V_TMP],
                two_targets: false,
            });
            let v = bind(
                BlurUniform {
                    dir: [0.0, 1.0, s.sigma_mm, 0.0],
                    weight: w4(s.weight),
                    params,
                },
                &views[V_TMP],
                &views[V_TMP],
            );
            let dst = V_PING + k % 2;
            steps.push(BlurStepPass {
                pipeline: P_ACCUMULATE,
                bind_group: v,
                targets: [dst, V_ACCUM],
                two_targets: true,
            });
            source = Some(dst);
        }
        let widest = source.map_or(&irradiance_view, |i| &views[i]);
        let dilate = bind(
            BlurUniform {
                dir: [0.0; 4],
                weight: [0.0; 4],
                params,
            },
            &views[V_ACCUM],
            widest,
        );
        steps.push(BlurStepPass {
            pipeline: P_DILATE,
            bind_group: dilate,
            targets: [V_RESULT, V_WIDEST],
            two_targets: true,
        });
        BlurTargets {
            result: textures[V_RESULT].clone(),
            widest: textures[V_WIDEST].clone(),
            accum: textures[V_ACCUM].clone(),
            views,
            _textures: textures,
            _uniforms: uniforms,
            steps,
        }
    }

    /// Records the copy, blur and padding passes (timed as "texture").
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &BlurTargets,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for s in &targets.steps {
            let timer = TimedPass::begin(profiler, "texture", encoder);
            {
                let attach =
                    |i: usize| util::color_attachment(&targets.views[i], wgpu::LoadOp::Load);
                let two = [attach(s.targets[0]), attach(s.targets[1])];
                let one = [attach(s.targets[0])];
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("texture-space blur"),
                    color_attachments: if s.two_targets { &two } else { &one },
                    depth_stencil_attachment: None,
                    timestamp_writes: timer.writes(),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.pipelines[s.pipeline]);
                pass.set_bind_group(0, &s.bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
            timer.end(profiler, encoder);
        }
    }
}

// ---- Per-object maps and the lighting pass's group 2 ------------------------------------------

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

fn maps_bind_group(
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
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("texture-space maps"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(result),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(widest),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
        ],
    })
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

struct ObjectMaps {
    irradiance: wgpu::Texture,
    stretch: wgpu::Texture,
    views: [wgpu::TextureView; 2],
    blur: BlurTargets,
}

/// Per-object UV-space maps of skin objects (`sss_strength` > 0 and a mesh), their blur, and
/// the group-2 bind group the lighting pass uses for each `GpuObject`.
pub struct TextureSpacePass {
    settings: TextureSpaceSettings,
    blur: TextureBlur,
    /// One per GpuObject: Some for skin objects when the pass is active.
    maps: Vec<Option<ObjectMaps>>,
    bind_groups: Vec<wgpu::BindGroup>,
}

impl TextureSpacePass {
    /// `objects_enabled`: one flag per `GpuObject` (skin objects). Nothing is allocated when
    /// neither the diffuse nor TSM is on.
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
        let blur = TextureBlur::new(device);
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
            if !active || o.material.sss_strength <= 0.0 {
                maps.push(None);
                bind_groups.push(default_maps_bind_group(device, maps_layout));
                continue;
            }
            let optics = cache.get(
                &o.material.profile,
                &format!("objects[{i}].material.profile"),
            )?;
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
            let targets = blur.bind(device, &irradiance, &stretch, &kernel, settings.padding);
            let params = [
                settings.diffuse as u32 as f32,
                settings.tsm as u32 as f32,
                albedo_pre,
                0.0,
            ];
            bind_groups.push(maps_bind_group(
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
            blur,
            maps,
            bind_groups,
        })
    }

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
        lighting: &crate::passes::lighting::LightingPass,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for ((m, o), bg) in self.maps.iter().zip(objects).zip(&self.bind_groups) {
            let Some(m) = m else { continue };
            let timer = TimedPass::begin(profiler, "texture", encoder);
            {
                let attach =
                    |v| util::color_attachment(v, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT));
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("texture-space irradiance"),
                    color_attachments: &[attach(&m.views[0]), attach(&m.views[1])],
                    depth_stencil_attachment: None,
                    timestamp_writes: timer.writes(),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                lighting.draw_uv_irradiance(&mut pass, o, bg);
            }
            timer.end(profiler, encoder);
            self.blur.encode(encoder, &m.blur, profiler);
        }
    }
}

// ---- Translucent shadow maps -----------------------------------------------------------------

/// The (u, v) of the surface nearest each light, one layer per shadow layer, at the shadow
/// atlas's size: rendered as a second pass over the same layers ("tsm").
pub struct TsmPass {
    pipeline: wgpu::RenderPipeline,
    layers: Vec<(u32, wgpu::Buffer, wgpu::BindGroup, wgpu::TextureView)>,
    depth: wgpu::TextureView,
    pub atlas: wgpu::Texture,
    pub atlas_view: wgpu::TextureView,
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

impl TsmPass {
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        layers: &[ShadowLayer],
        atlas_size: u32,
    ) -> Self {
        let device = &ctx.device;
        let module = util::wgsl_module(device, "texture_space.wgsl (tsm)", SHADER);
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tsm view"),
            entries: &[util::uniform_entry(14, wgpu::ShaderStages::VERTEX)],
        });
        let layout = util::pipeline_layout(device, "tsm", &[&view_layout, object_layout]);
        let pipeline = util::MeshPipeline {
            label: "tsm",
            layout: &layout,
            module: &module,
            vertex: "vs_tsm",
            fragment: "fs_tsm",
            targets: &[TSM_FORMAT],
            // As the shadow maps: the surface nearest the light, whichever way it faces.
            cull_mode: None,
            depth_test: true,
        }
        .create(device);
        let size = atlas_size.max(1);
        let atlas = util::texture_2d(
            device,
            "translucent shadow maps",
            size,
            size,
            layers.len().max(1) as u32,
            TSM_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let atlas_view = util::array_view(&atlas);
        let depth = util::depth_buffer(device, "tsm depth", size, size);
        let layers = layers
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("tsm view"),
                    contents: bytemuck::bytes_of(&TsmViewUniform {
                        view_proj: mat(l.view_proj),
                    }),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                });
                let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("tsm view"),
                    layout: &view_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 14,
                        resource: buffer.as_entire_binding(),
                    }],
                });
                let view = util::layer_view(&atlas, i as u32);
                (l.size, buffer, bg, view)
            })
            .collect();
        Self {
            pipeline,
            layers,
            depth,
            atlas,
            atlas_view,
        }
    }

    /// Moves the light cameras (same layers and sizes as at creation).
    pub fn update_layers(&mut self, queue: &wgpu::Queue, layers: &[ShadowLayer]) {
        for ((_, buffer, _, _), l) in self.layers.iter().zip(layers) {
            let u = TsmViewUniform {
                view_proj: mat(l.view_proj),
            };
            queue.write_buffer(buffer, 0, bytemuck::bytes_of(&u));
        }
    }

    /// Renders every layer ("tsm"); texels where nothing is drawn hold (-1, -1).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for (size, _, bind_group, view) in &self.layers {
            let timer = TimedPass::begin(profiler, "tsm", encoder);
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("tsm"),
                    color_attachments: &[util::color_attachment(
                        view,
                        wgpu::LoadOp::Clear(wgpu::Color {
                            r: -1.0,
                            g: -1.0,
                            b: 0.0,
                            a: 0.0,
                        }),
                    )],
                    depth_stencil_attachment: util::depth_attachment(&self.depth),
                    timestamp_writes: timer.writes(),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_viewport(0.0, 0.0, *size as f32, *size as f32, 0.0, 1.0);
                pass.set_scissor_rect(0, 0, *size, *size);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, bind_group, &[]);
                for o in objects {
                    o.draw(&mut pass);
                }
            }
            timer.end(profiler, encoder);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_from_skin_matches_the_screen_space_increments() {
        let k = BlurKernel::from_profile(&SumOfGaussians::skin());
        assert_eq!(k.steps.len(), 5);
        let v = subsurface_profile::SKIN_VARIANCES_MM2;
        assert!((k.steps[0].sigma_mm - ((v[1] - v[0]).sqrt() as f32)).abs() < 1e-6);
        for c in 0..3 {
            let sum: f32 = k.first_weight[c] + k.steps.iter().map(|s| s.weight[c]).sum::<f32>();
            assert!((sum - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn cpu_blur_keeps_a_constant_island_constant() {
        let size = 16;
        let mut map = vec![[0.0f32; 4]; 256];
        for y in 4..12 {
            for x in 2..14 {
                map[y * 16 + x] = [0.5, 0.25, 0.125, 1.0];
            }
        }
        let stretch = vec![[0.3f32, 0.2]; 256];
        let (acc, _) = cpu_blur(
            size,
            &map,
            &stretch,
            &BlurKernel::from_profile(&SumOfGaussians::skin()),
        );
        for (a, m) in acc.iter().zip(&map) {
            if m[3] > 0.5 {
                for c in 0..3 {
                    assert!((a[c] - m[c]).abs() < 2e-3, "{a:?} vs {m:?}");
                }
            }
        }
    }
}
