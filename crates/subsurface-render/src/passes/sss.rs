//! Screen-space subsurface scattering on the lighting pass's diffuse radiance, in place.
//!
//! Methods: the six-Gaussian sum of Jimenez et al. 2009 / GPU Pro 2010 (each Gaussian from the
//! previous one, accumulated by blending), Separable SSS (Jimenez et al. 2015: one horizontal
//! and one vertical pass), and Hable et al. 2009's 13-tap 2-D kernel. Every method reproduces
//! `subsurface_profile::oracle` on the same inputs.
//!
//! To use it in another wgpu application, give it your own textures:
//! ```no_run
//! # fn f(device: &wgpu::Device, queue: &wgpu::Queue, diffuse: &wgpu::Texture,
//! #      depth: &wgpu::TextureView, sss: &wgpu::TextureView, encoder: &mut wgpu::CommandEncoder) {
//! use subsurface_render::passes::sss::{SssConfig, SssInputs, SssMethod, SssPass};
//! let config = SssConfig { method: SssMethod::Separable, ..Default::default() };
//! let mut pass = SssPass::new(device, &config).unwrap();
//! pass.bind(device, &SssInputs { diffuse, depth, sss });
//! pass.set_camera(queue, 0.5 * 720.0 / (0.5f32 * 35f32.to_radians()).tan());
//! pass.encode(encoder, None); // `diffuse` now holds the scattered radiance
//! # }
//! ```

use subsurface_profile::{
    DEFAULT_FALLOFF, DEFAULT_SAMPLES, DEFAULT_STRENGTH, KernelParams, SKIN_VARIANCES_MM2,
    SKIN_WEIGHTS, hable13_kernel, separable_kernel,
};
use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::passes::util;
use crate::timing::TimedPass;

pub const SHADER: &str = include_str!("sss.wgsl");
/// Format of the diffuse texture the pass blurs in place (filterable on every adapter).
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const MAX_TAPS: usize = 64;

/// Which screen-space method to run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SssMethod {
    /// No scattering: the diffuse radiance is left as it is.
    None,
    /// Jimenez et al. 2009 / GPU Pro 2010: five Gaussians, a 7-tap H and V blur each.
    Gaussian6,
    /// Jimenez et al. 2015: one horizontal and one vertical pass of an N-tap kernel.
    #[default]
    Separable,
    /// Hable et al. 2009: one 2-D pass with 13 jittered taps.
    Hable13,
    /// d'Eon et al. 2007: the sum of Gaussians in texture space (`passes::texture_space`); this
    /// screen-space pass does nothing for it.
    Texture,
}

impl SssMethod {
    pub fn name(self) -> &'static str {
        match self {
            SssMethod::None => "none",
            SssMethod::Gaussian6 => "gaussian6",
            SssMethod::Separable => "separable",
            SssMethod::Hable13 => "hable13",
            SssMethod::Texture => "texture",
        }
    }
}

/// Settings of the pass. `width`/`height` are taken from the bound textures.
#[derive(Clone, Debug, PartialEq)]
pub struct SssConfig {
    pub method: SssMethod,
    /// Separable: number of taps (odd, 3..=63).
    pub samples: u32,
    /// Separable: per-channel strength of the kernel (the share of light that scatters).
    pub strength: [f32; 3],
    /// Separable: per-channel falloff (smaller = narrower kernel in that channel).
    pub falloff: [f32; 3],
    /// Pull taps across depth edges back to the centre colour.
    pub follow_surface: bool,
    /// Depth difference, in millimetres on the skin, that fully stops a tap.
    pub edge_mm: f32,
    /// Six-Gaussian: skip a Gaussian whose standard deviation is under this many pixels.
    pub min_sigma_px: f32,
    /// Six-Gaussian: which of the five blurred Gaussians (narrowest excluded) are on.
    pub gaussians_enabled: [bool; 5],
    /// Texture space: size of each object's UV-space maps in texels per side.
    pub texture_size: u32,
    /// Texture space: padding of the UV islands in texels (0..=16).
    pub texture_padding: u32,
    /// Texture space: exponent of the albedo applied before the blur (the rest after it):
    /// 0 = post-scatter, 0.5 = pre- and post-scatter (d'Eon), 1 = pre-scatter.
    pub texture_albedo_pre: f32,
}

impl Default for SssConfig {
    fn default() -> Self {
        Self {
            method: SssMethod::Separable,
            samples: DEFAULT_SAMPLES,
            strength: DEFAULT_STRENGTH,
            falloff: DEFAULT_FALLOFF,
            follow_surface: true,
            edge_mm: 3.0,
            min_sigma_px: 0.25,
            gaussians_enabled: [true; 5],
            texture_size: 1024,
            texture_padding: 4,
            texture_albedo_pre: 0.5,
        }
    }
}

impl SssConfig {
    /// The scene's `[render]` method, samples, follow_surface and Gaussians, with the kernel
    /// strength and falloff of its first skin material (the separable kernel is one per frame).
    pub fn for_scene(scene: &crate::Scene) -> Self {
        let r = &scene.desc.render;
        let mut c = Self {
            method: r.sss,
            samples: r.samples,
            follow_surface: r.follow_surface,
            gaussians_enabled: r.gaussians,
            ..Self::default()
        };
        if let Some(o) = scene.objects.iter().find(|o| o.material.sss_strength > 0.0) {
            c.strength = o.material.kernel_strength;
            c.falloff = o.material.falloff;
        }
        c
    }

    /// The `subsurface_profile::oracle` parameters equivalent to this configuration.
    pub fn oracle_params(&self, focal_px: f32) -> subsurface_profile::oracle::ScreenParams {
        subsurface_profile::oracle::ScreenParams {
            focal_px,
            follow_surface: self.follow_surface,
            edge_mm: self.edge_mm,
        }
    }

    pub fn kernel(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        separable_kernel(&KernelParams {
            samples: self.samples,
            strength: self.strength,
            falloff: self.falloff,
        })
        .map_err(RenderError::from)
    }

    pub fn validate(&self) -> Result<(), RenderError> {
        if self.method == SssMethod::Separable {
            self.kernel()?;
        }
        if !(self.edge_mm.is_finite() && self.edge_mm > 0.0) {
            return Err(RenderError::invalid(
                "sss.edge_mm",
                format!("must be finite and > 0 (got {})", self.edge_mm),
            ));
        }
        if !(self.min_sigma_px.is_finite() && self.min_sigma_px >= 0.0) {
            return Err(RenderError::invalid(
                "min_sigma_px",
                format!("must be finite and >= 0 (got {})", self.min_sigma_px),
            ));
        }
        if !(16..=16384).contains(&self.texture_size) {
            return Err(RenderError::invalid(
                "sss.texture_size",
                format!("must be in 16..=16384 (got {})", self.texture_size),
            ));
        }
        if self.texture_padding > 16 {
            return Err(RenderError::invalid(
                "sss.texture_padding",
                format!("must be in 0..=16 (got {})", self.texture_padding),
            ));
        }
        if !(0.0..=1.0).contains(&self.texture_albedo_pre) {
            return Err(RenderError::invalid(
                "sss.texture_albedo_pre",
                format!("must be in 0..=1 (got {})", self.texture_albedo_pre),
            ));
        }
        Ok(())
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SssUniform {
    dir: [f32; 4],
    params: [f32; 4],
    counts: [u32; 4],
    kernel: [[f32; 4]; MAX_TAPS],
}

/// The textures the pass works on. `diffuse` is read and overwritten (usage
/// TEXTURE_BINDING | RENDER_ATTACHMENT | COPY_SRC, format [`FORMAT`]); `depth` is linear view
/// depth (R32Float); `sss` holds strength in r (0 = not skin) and scene units per profile
/// millimetre in g (Rg32Float).
pub struct SssInputs<'a> {
    pub diffuse: &'a wgpu::Texture,
    pub depth: &'a wgpu::TextureView,
    pub sss: &'a wgpu::TextureView,
}

struct Step {
    label: &'static str,
    pipeline: usize,
    bind_group: wgpu::BindGroup,
    target: usize,
    accum: bool,
}

struct Bound {
    steps: Vec<Step>,
    targets: Vec<wgpu::TextureView>,
    _textures: Vec<wgpu::Texture>,
    copy: Option<(wgpu::Texture, wgpu::Texture)>,
}

/// Screen-space SSS, in place on a diffuse radiance texture.
pub struct SssPass {
    config: SssConfig,
    layout: wgpu::BindGroupLayout,
    /// separable/gaussian/hable (1 target, replace), accumulate (2 targets), copy-weighted, resolve
    pipelines: Vec<wgpu::RenderPipeline>,
    dummy: wgpu::TextureView,
    uniforms: Vec<wgpu::Buffer>,
    focal_px: f32,
    bound: Option<Bound>,
}

const P_SEPARABLE: usize = 0;
const P_GAUSSIAN: usize = 1;
const P_HABLE: usize = 2;
const P_ACCUMULATE: usize = 3;
const P_COPY_WEIGHTED: usize = 4;
const P_RESOLVE: usize = 5;

impl SssPass {
    pub fn new(device: &wgpu::Device, config: &SssConfig) -> Result<Self, RenderError> {
        config.validate()?;
        let module = util::wgsl_module(device, "sss.wgsl", SHADER);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let tex = |binding, filterable| {
            util::float_texture_entry(
                binding,
                fragment,
                filterable,
                wgpu::TextureViewDimension::D2,
            )
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sss"),
            entries: &[
                util::uniform_entry(0, fragment),
                tex(1, false),
                tex(2, false),
                tex(3, false),
                tex(5, false),
            ],
        });
        let pipeline_layout = util::pipeline_layout(device, "sss", &[&layout]);
        let replace = Some(wgpu::ColorTargetState::from(FORMAT));
        let additive = Some(util::additive_target(FORMAT));
        let make = |entry: &str, targets: &[Option<wgpu::ColorTargetState>]| {
            super::fullscreen::pipeline(device, &module, Some(&pipeline_layout), entry, targets)
        };
        let pipelines = vec![
            make("fs_separable", std::slice::from_ref(&replace)),
            make("fs_gaussian", std::slice::from_ref(&replace)),
            make("fs_hable13", std::slice::from_ref(&replace)),
            make("fs_gaussian_accumulate", &[replace.clone(), additive]),
            make("fs_copy", std::slice::from_ref(&replace)),
            make("fs_resolve", &[replace]),
        ];
        let dummy = util::texture_2d(
            device,
            "sss dummy",
            1,
            1,
            1,
            FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING,
        )
        .create_view(&Default::default());
        let mut pass = Self {
            config: config.clone(),
            layout,
            pipelines,
            dummy,
            uniforms: Vec::new(),
            focal_px: 1.0,
            bound: None,
        };
        pass.uniforms = pass.make_uniforms(device)?;
        Ok(pass)
    }

    pub fn config(&self) -> &SssConfig {
        &self.config
    }

    /// Changes method or parameters. Re-`bind` afterwards.
    pub fn set_config(
        &mut self,
        device: &wgpu::Device,
        config: &SssConfig,
    ) -> Result<(), RenderError> {
        config.validate()?;
        self.config = config.clone();
        self.uniforms = self.make_uniforms(device)?;
        self.bound = None;
        Ok(())
    }

    /// The camera's focal length in pixels: 0.5 * height / tan(fov_y / 2).
    pub fn set_camera(&mut self, queue: &wgpu::Queue, focal_px: f32) {
        self.focal_px = focal_px;
        for (i, u) in self.uniforms.iter().enumerate() {
            let v = self.uniform_data(i);
            queue.write_buffer(u, 0, bytemuck::bytes_of(&v));
        }
    }

    /// Variances increments of the Gaussians after the narrowest, and their RGB weights
    /// (d'Eon's skin profile, 000_* Figure 7): each Gaussian is the previous one blurred by
    /// the difference of variances.
    fn gaussian_steps(&self) -> Vec<(f32, [f32; 3])> {
        let mut previous = SKIN_VARIANCES_MM2[0];
        (1..6)
            .filter(|&k| self.config.gaussians_enabled[k - 1])
            .map(|k| {
                // Increment from the last Gaussian actually computed, so switching one off
                // leaves the others at their true width.
                let sigma = (SKIN_VARIANCES_MM2[k] - previous).sqrt() as f32;
                previous = SKIN_VARIANCES_MM2[k];
                (sigma, SKIN_WEIGHTS[k].map(|w| w as f32))
            })
            .collect()
    }

    /// Uniform i: separable -> [H, V]; hable -> [2-D]; gaussian6 -> [copy, (H, V) per step].
    fn uniform_data(&self, i: usize) -> SssUniform {
        let mut u = SssUniform {
            dir: [0.0; 4],
            params: [
                self.focal_px,
                self.config.edge_mm,
                self.config.follow_surface as u32 as f32,
                self.config.min_sigma_px,
            ],
            counts: [0; 4],
            kernel: [[0.0; 4]; MAX_TAPS],
        };
        match self.config.method {
            SssMethod::Separable => {
                let k = self.config.kernel().unwrap_or_default();
                u.counts[0] = k.len() as u32;
                u.kernel[..k.len()].copy_from_slice(&k);
                u.dir = if i == 0 {
                    [1.0, 0.0, 0.0, 0.0]
                } else {
                    [0.0, 1.0, 0.0, 0.0]
                };
            }
            SssMethod::Hable13 => {
                let k = hable13_kernel();
                u.counts[0] = k.len() as u32;
                for (t, tap) in k.iter().enumerate() {
                    u.kernel[2 * t] = [tap[2], tap[3], tap[4], 0.0];
                    u.kernel[2 * t + 1] = [tap[0], tap[1], 0.0, 0.0];
                }
            }
            SssMethod::Gaussian6 => {
                if i == 0 {
                    let w0 = SKIN_WEIGHTS[0];
                    u.kernel[0] = [w0[0] as f32, w0[1] as f32, w0[2] as f32, 0.0];
                } else {
                    let steps = self.gaussian_steps();
                    let (sigma, weight) = steps[(i - 1) / 2];
                    u.kernel[0] = [weight[0], weight[1], weight[2], 0.0];
                    let horizontal = (i - 1).is_multiple_of(2);
                    u.dir = if horizontal {
                        [1.0, 0.0, sigma, 0.0]
                    } else {
                        [0.0, 1.0, sigma, 0.0]
                    };
                }
            }
            SssMethod::None | SssMethod::Texture => {}
        }
        u
    }

    fn make_uniforms(&self, device: &wgpu::Device) -> Result<Vec<wgpu::Buffer>, RenderError> {
        let count = match self.config.method {
            SssMethod::None | SssMethod::Texture => 0,
            SssMethod::Separable => 2,
            SssMethod::Hable13 => 1,
            SssMethod::Gaussian6 => 1 + 2 * self.gaussian_steps().len(),
        };
        Ok((0..count)
            .map(|i| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("sss uniform"),
                    contents: bytemuck::bytes_of(&self.uniform_data(i)),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                })
            })
            .collect())
    }

    /// Creates the intermediate textures and bind groups for these inputs.
    pub fn bind(&mut self, device: &wgpu::Device, inputs: &SssInputs<'_>) {
        let size = inputs.diffuse.size();
        let make_target = |label| {
            util::texture_2d(
                device,
                label,
                size.width,
                size.height,
                size.depth_or_array_layers,
                FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_DST,
            )
        };
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let diffuse_view = view(inputs.diffuse);
        let bg = |uniform: usize, color: &wgpu::TextureView, accum: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("sss"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.uniforms[uniform].as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(color),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(inputs.depth),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(inputs.sss),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: wgpu::BindingResource::TextureView(accum),
                    },
                ],
            })
        };
        let step = |label, pipeline, bind_group, target, accum| Step {
            label,
            pipeline,
            bind_group,
            target,
            accum,
        };
        // Target indices: 0 = the diffuse input (written in place), then intermediates.
        let mut textures = Vec::new();
        let mut targets = vec![diffuse_view.clone()];
        let mut steps = Vec::new();
        let mut copy = None;
        match self.config.method {
            SssMethod::None | SssMethod::Texture => {}
            SssMethod::Separable => {
                let tmp = make_target("sss tmp");
                let tmp_view = view(&tmp);
                steps.push(step(
                    "sss",
                    P_SEPARABLE,
                    bg(0, &diffuse_view, &self.dummy),
                    1,
                    false,
                ));
                steps.push(step(
                    "sss",
                    P_SEPARABLE,
                    bg(1, &tmp_view, &self.dummy),
                    0,
                    false,
                ));
                targets.push(tmp_view);
                textures.push(tmp);
            }
            SssMethod::Hable13 => {
                let tmp = make_target("sss tmp");
                let tmp_view = view(&tmp);
                steps.push(step(
                    "sss",
                    P_HABLE,
                    bg(0, &tmp_view, &self.dummy),
                    0,
                    false,
                ));
                copy = Some((inputs.diffuse.clone(), tmp.clone()));
                targets.push(tmp_view);
                textures.push(tmp);
            }
            SssMethod::Gaussian6 => {
                // 1 = horizontal tmp, 2/3 = ping/pong blurred Gaussians, 4 = accumulation.
                for label in ["sss tmp", "sss ping", "sss pong", "sss accum"] {
                    let t = make_target(label);
                    targets.push(view(&t));
                    textures.push(t);
                }
                steps.push(step(
                    "sss",
                    P_COPY_WEIGHTED,
                    bg(0, &diffuse_view, &self.dummy),
                    4,
                    false,
                ));
                let mut source = 0;
                for s in 0..self.gaussian_steps().len() {
                    let blurred = 2 + s % 2;
                    steps.push(step(
                        "sss",
                        P_GAUSSIAN,
                        bg(1 + 2 * s, &targets[source].clone(), &self.dummy),
                        1,
                        false,
                    ));
                    steps.push(step(
                        "sss",
                        P_ACCUMULATE,
                        bg(2 + 2 * s, &targets[1].clone(), &self.dummy),
                        blurred,
                        true,
                    ));
                    source = blurred;
                }
                steps.push(step(
                    "sss",
                    P_RESOLVE,
                    bg(0, &self.dummy, &targets[4].clone()),
                    0,
                    false,
                ));
            }
        }
        self.bound = Some(Bound {
            steps,
            targets,
            _textures: textures,
            copy,
        });
    }

    /// Records the passes. Call `bind` first; without bound inputs nothing is recorded.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let Some(bound) = &self.bound else { return };
        if let Some((src, dst)) = &bound.copy {
            encoder.copy_texture_to_texture(src.as_image_copy(), dst.as_image_copy(), src.size());
        }
        for s in &bound.steps {
            let timer = TimedPass::begin(profiler, s.label, encoder);
            {
                let attach = |v| util::color_attachment(v, wgpu::LoadOp::Load);
                let accum_target = [
                    attach(&bound.targets[s.target]),
                    attach(&bound.targets[4.min(bound.targets.len() - 1)]),
                ];
                let single = [attach(&bound.targets[s.target])];
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(s.label),
                    color_attachments: if s.accum { &accum_target } else { &single },
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
