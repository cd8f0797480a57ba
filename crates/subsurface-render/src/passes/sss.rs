//! Screen-space subsurface scattering on the lighting pass's diffuse radiance, in place.
//!
//! Methods: the six-Gaussian sum of Jimenez et al. 2009 / GPU Pro 2010 (each Gaussian from the
//! previous one, accumulated by blending), Separable SSS (Jimenez et al. 2015: one horizontal
//! and one vertical pass; with `jitter`, its few-sample mode of taps moved per pixel), and Hable
//! et al. 2009's 13-tap 2-D kernel. Each pixel is blurred with
//! the kernel of its own profile (a row of the profile table, as engines keep a diffusion
//! profile per material), and every method reproduces `subsurface_profile::oracle::screen` on
//! the same inputs.
//!
//! To use it in another wgpu application, give it your own textures:
//! ```no_run
//! # fn f(device: &wgpu::Device, queue: &wgpu::Queue, diffuse: &wgpu::Texture,
//! #      depth: &wgpu::TextureView, sss: &wgpu::TextureView, encoder: &mut wgpu::CommandEncoder) {
//! use subsurface_profile::{KernelParams, ScreenKernels};
//! use subsurface_render::passes::sss::{SssInputs, SssPass};
//! use subsurface_render::{SssMethod, SssSettings};
//! let settings = SssSettings { method: SssMethod::Separable, ..Default::default() };
//! // Row 0 of the profile table: skin. Your SSS texture's blue channel picks a row per pixel.
//! let skin = ScreenKernels::skin(&KernelParams::default()).unwrap();
//! let mut pass = SssPass::new(device, &settings, &[skin]).unwrap();
//! pass.resize(device, &SssInputs { diffuse, depth, sss });
//! pass.prepare(queue, 0.5 * 720.0 / (0.5f32 * 35f32.to_radians()).tan());
//! pass.encode(encoder, None); // `diffuse` now holds the scattered radiance
//! # }
//! ```

use subsurface_profile::ScreenKernels;
use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::passes::util;
use crate::settings::{SssMethod, SssSettings};
use crate::timing::TimedPass;

pub const SHADER: &str = concat!(include_str!("fullscreen.wgsl"), include_str!("sss.wgsl"));
/// Format of the diffuse texture the pass blurs in place (filterable on every adapter).
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Rows of Hable's 13 taps in the profile table (weight row, offset row).
const HABLE_ROWS: usize = 26;

/// `SssUniform` of sss.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct SssUniform {
    direction: [f32; 2],
    focal_px: f32,
    edge_mm: f32,
    follow_surface: u32,
    min_sigma_px: f32,
    taps: u32,
    stride: u32,
    hable: u32,
    gaussians: u32,
    gaussian: u32,
    previous: u32,
    profiles: u32,
    /// Jittered separable: 0 for the horizontal pass, 1 for the vertical (seeds the hash).
    seed: u32,
    /// Jittered separable: first table row of the taps' jitter half-widths.
    widths: u32,
    _pad: u32,
}

/// The textures the pass works on. `diffuse` is read and overwritten (usage
/// TEXTURE_BINDING | RENDER_ATTACHMENT | COPY_SRC, format [`FORMAT`]); `depth` is linear view
/// depth (R32Float); `sss` holds strength in r (0 = not skin), scene units per profile
/// millimetre in g and the pixel's row of the profile table in b (any float format; the
/// lighting pass writes Rgba16Float).
pub struct SssInputs<'a> {
    pub diffuse: &'a wgpu::Texture,
    pub depth: &'a wgpu::TextureView,
    pub sss: &'a wgpu::TextureView,
}

/// Which pipeline a step runs.
#[derive(Clone, Copy)]
enum Stage {
    Separable,
    SeparableJitter,
    Gaussian,
    Hable13,
    Accumulate,
    CopyWeighted,
    Resolve,
}

struct Step {
    stage: Stage,
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

struct Pipelines {
    separable: wgpu::RenderPipeline,
    /// The few-sample mode: the separable taps moved per pixel (its own entry point, so the
    /// plain pass stays exactly as it was).
    separable_jitter: wgpu::RenderPipeline,
    gaussian: wgpu::RenderPipeline,
    hable13: wgpu::RenderPipeline,
    /// Writes a blurred Gaussian and adds it, weighted, to the accumulation target.
    accumulate: wgpu::RenderPipeline,
    /// The narrowest Gaussian (the input times its weight) starts the accumulation.
    copy_weighted: wgpu::RenderPipeline,
    /// Writes the accumulation back into the diffuse target, on skin pixels only.
    resolve: wgpu::RenderPipeline,
}

impl Pipelines {
    fn get(&self, stage: Stage) -> &wgpu::RenderPipeline {
        match stage {
            Stage::Separable => &self.separable,
            Stage::SeparableJitter => &self.separable_jitter,
            Stage::Gaussian => &self.gaussian,
            Stage::Hable13 => &self.hable13,
            Stage::Accumulate => &self.accumulate,
            Stage::CopyWeighted => &self.copy_weighted,
            Stage::Resolve => &self.resolve,
        }
    }
}

/// The profile table as the shader reads it: per profile, the separable taps, Hable's 13 taps
/// (two rows each), the six Gaussians and the separable taps' jitter half-widths (mm, in x).
fn table_rows(profiles: &[ScreenKernels]) -> Vec<[f32; 4]> {
    let mut rows = Vec::new();
    for p in profiles {
        rows.extend_from_slice(&p.separable);
        for t in &p.hable13 {
            rows.push([t[2], t[3], t[4], 0.0]);
            rows.push([t[0], t[1], 0.0, 0.0]);
        }
        rows.extend_from_slice(&p.gaussians);
        let widths = subsurface_profile::separable_jitter_widths(&p.separable);
        rows.extend(widths.into_iter().map(|w| [w, 0.0, 0.0, 0.0]));
    }
    rows
}

/// Screen-space SSS, in place on a diffuse radiance texture.
pub struct SssPass {
    settings: SssSettings,
    layout: wgpu::BindGroupLayout,
    pipelines: Pipelines,
    dummy: wgpu::TextureView,
    /// One per step of the method (see `uniform`).
    uniforms: Vec<wgpu::Buffer>,
    table: wgpu::Buffer,
    profiles: usize,
    taps: usize,
    focal_px: f32,
    bound: Option<Bound>,
}

impl SssPass {
    /// `profiles` is the profile table: row `i` is the kernel of pixels whose SSS texture
    /// names profile `i`. Every row needs `settings.samples` separable taps.
    pub fn new(
        device: &wgpu::Device,
        settings: &SssSettings,
        profiles: &[ScreenKernels],
    ) -> Result<Self, RenderError> {
        let module = util::wgsl_module(device, "sss.wgsl", SHADER);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let tex = |binding| {
            util::float_texture_entry(binding, fragment, false, wgpu::TextureViewDimension::D2)
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sss"),
            entries: &[
                util::uniform_entry(0, fragment),
                tex(1),
                tex(2),
                tex(3),
                util::storage_entry(4, fragment),
                tex(5),
            ],
        });
        let pipeline_layout = util::pipeline_layout(device, "sss", &[&layout]);
        let replace = Some(wgpu::ColorTargetState::from(FORMAT));
        let additive = Some(util::additive_target(FORMAT));
        let make = |entry: &str, targets: &[Option<wgpu::ColorTargetState>]| {
            super::fullscreen::pipeline(device, &module, Some(&pipeline_layout), entry, targets)
        };
        let one = std::slice::from_ref(&replace);
        let pipelines = Pipelines {
            separable: make("fs_separable", one),
            separable_jitter: make("fs_separable_jitter", one),
            gaussian: make("fs_gaussian", one),
            hable13: make("fs_hable13", one),
            accumulate: make("fs_gaussian_accumulate", &[replace.clone(), additive]),
            copy_weighted: make("fs_copy", one),
            resolve: make("fs_resolve", one),
        };
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
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sss profiles"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let mut pass = Self {
            settings: settings.clone(),
            layout,
            pipelines,
            dummy,
            uniforms: Vec::new(),
            table,
            profiles: 0,
            taps: 0,
            focal_px: 1.0,
            bound: None,
        };
        pass.set_settings(device, settings, profiles)?;
        Ok(pass)
    }

    pub fn settings(&self) -> &SssSettings {
        &self.settings
    }

    /// Number of rows of the profile table.
    pub fn profile_count(&self) -> usize {
        self.profiles
    }

    /// Changes method, parameters or profile table. Call `resize` afterwards.
    pub fn set_settings(
        &mut self,
        device: &wgpu::Device,
        settings: &SssSettings,
        profiles: &[ScreenKernels],
    ) -> Result<(), RenderError> {
        settings.validate().map_err(|e| e.under("sss"))?;
        if profiles.is_empty() {
            return Err(RenderError::invalid("sss.profiles", "the table is empty"));
        }
        let taps = profiles[0].separable.len();
        if let Some(i) = profiles.iter().position(|p| p.separable.len() != taps) {
            return Err(RenderError::invalid(
                format!("sss.profiles[{i}]"),
                "every profile needs the same number of separable taps",
            ));
        }
        if settings.method == SssMethod::Separable && taps != settings.samples as usize {
            return Err(RenderError::invalid(
                "sss.samples",
                format!(
                    "the profile table has {taps} taps per profile, not {}",
                    settings.samples
                ),
            ));
        }
        self.settings = settings.clone();
        self.profiles = profiles.len();
        self.taps = taps;
        self.table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sss profiles"),
            contents: bytemuck::cast_slice(&table_rows(profiles)),
            usage: wgpu::BufferUsages::STORAGE,
        });
        self.uniforms = (0..self.step_count())
            .map(|i| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("sss uniform"),
                    contents: bytemuck::bytes_of(&self.uniform(i)),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                })
            })
            .collect();
        self.bound = None;
        Ok(())
    }

    /// Writes what changes per frame: the camera's focal length in pixels,
    /// 0.5 * height / tan(fov_y / 2).
    pub fn prepare(&mut self, queue: &wgpu::Queue, focal_px: f32) {
        self.focal_px = focal_px;
        for (i, u) in self.uniforms.iter().enumerate() {
            queue.write_buffer(u, 0, bytemuck::bytes_of(&self.uniform(i)));
        }
    }

    /// The Gaussians blurred in turn (1..6, the narrowest is the input itself), each with the
    /// one it starts from: switching one off leaves the others at their true width.
    fn gaussian_steps(&self) -> Vec<(u32, u32)> {
        let mut previous = 0;
        (1..6)
            .filter(|&k| self.settings.gaussians[k - 1])
            .map(|k| {
                let step = (k as u32, previous);
                previous = k as u32;
                step
            })
            .collect()
    }

    fn step_count(&self) -> usize {
        match self.settings.method {
            SssMethod::None | SssMethod::Texture => 0,
            SssMethod::Separable => 2,
            SssMethod::Hable13 => 1,
            SssMethod::Gaussian6 => 1 + 2 * self.gaussian_steps().len(),
        }
    }

    /// Uniform i: separable -> [H, V]; hable -> [2-D]; gaussian6 -> [copy, (H, V) per step].
    fn uniform(&self, i: usize) -> SssUniform {
        let taps = self.taps as u32;
        let mut u = SssUniform {
            focal_px: self.focal_px,
            edge_mm: self.settings.edge_mm,
            follow_surface: self.settings.follow_surface as u32,
            min_sigma_px: self.settings.min_sigma_px,
            taps,
            stride: 2 * taps + (HABLE_ROWS + subsurface_profile::SCREEN_GAUSSIANS) as u32,
            hable: taps,
            gaussians: taps + HABLE_ROWS as u32,
            widths: taps + (HABLE_ROWS + subsurface_profile::SCREEN_GAUSSIANS) as u32,
            profiles: self.profiles as u32,
            ..Default::default()
        };
        let horizontal = [1.0, 0.0];
        let vertical = [0.0, 1.0];
        match self.settings.method {
            SssMethod::Separable => {
                u.direction = if i == 0 { horizontal } else { vertical };
                u.seed = i as u32;
            }
            SssMethod::Gaussian6 if i > 0 => {
                let (k, previous) = self.gaussian_steps()[(i - 1) / 2];
                u.gaussian = k;
                u.previous = previous;
                u.direction = if (i - 1).is_multiple_of(2) {
                    horizontal
                } else {
                    vertical
                };
            }
            _ => {}
        }
        u
    }

    /// Creates the intermediate textures and bind groups for these inputs (again whenever
    /// they change size).
    pub fn resize(&mut self, device: &wgpu::Device, inputs: &SssInputs<'_>) {
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
            let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("sss"),
                layout: &self.layout,
                entries: &[
                    entry(0, self.uniforms[uniform].as_entire_binding()),
                    entry(1, wgpu::BindingResource::TextureView(color)),
                    entry(2, wgpu::BindingResource::TextureView(inputs.depth)),
                    entry(3, wgpu::BindingResource::TextureView(inputs.sss)),
                    entry(4, self.table.as_entire_binding()),
                    entry(5, wgpu::BindingResource::TextureView(accum)),
                ],
            })
        };
        let step = |stage, bind_group, target, accum| Step {
            stage,
            bind_group,
            target,
            accum,
        };
        // Target indices: 0 = the diffuse input (written in place), then intermediates.
        let mut textures = Vec::new();
        let mut targets = vec![diffuse_view.clone()];
        let mut steps = Vec::new();
        let mut copy = None;
        match self.settings.method {
            SssMethod::None | SssMethod::Texture => {}
            SssMethod::Separable => {
                let tmp = make_target("sss tmp");
                let tmp_view = view(&tmp);
                let stage = if self.settings.jitter {
                    Stage::SeparableJitter
                } else {
                    Stage::Separable
                };
                steps.push(step(stage, bg(0, &diffuse_view, &self.dummy), 1, false));
                steps.push(step(stage, bg(1, &tmp_view, &self.dummy), 0, false));
                targets.push(tmp_view);
                textures.push(tmp);
            }
            SssMethod::Hable13 => {
                let tmp = make_target("sss tmp");
                let tmp_view = view(&tmp);
                steps.push(step(
                    Stage::Hable13,
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
                    Stage::CopyWeighted,
                    bg(0, &diffuse_view, &self.dummy),
                    4,
                    false,
                ));
                let mut source = 0;
                for s in 0..self.gaussian_steps().len() {
                    let blurred = 2 + s % 2;
                    steps.push(step(
                        Stage::Gaussian,
                        bg(1 + 2 * s, &targets[source].clone(), &self.dummy),
                        1,
                        false,
                    ));
                    steps.push(step(
                        Stage::Accumulate,
                        bg(2 + 2 * s, &targets[1].clone(), &self.dummy),
                        blurred,
                        true,
                    ));
                    source = blurred;
                }
                steps.push(step(
                    Stage::Resolve,
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

    /// Records the passes. Call `resize` first; without bound inputs nothing is recorded.
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
            let timer = TimedPass::begin(profiler, "sss", encoder);
            {
                let attach = |v| util::color_attachment(v, wgpu::LoadOp::Load);
                let accum_target = [
                    attach(&bound.targets[s.target]),
                    attach(&bound.targets[4.min(bound.targets.len() - 1)]),
                ];
                let single = [attach(&bound.targets[s.target])];
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("sss"),
                    color_attachments: if s.accum { &accum_target } else { &single },
                    depth_stencil_attachment: None,
                    timestamp_writes: timer.writes(),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(self.pipelines.get(s.stage));
                pass.set_bind_group(0, &s.bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
            timer.end(profiler, encoder);
        }
    }
}
