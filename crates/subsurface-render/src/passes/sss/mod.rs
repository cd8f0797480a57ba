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
//! Each texel a tap touches needs colour, depth, strength, scale and profile row. With
//! `fetch = packed` a pack step first writes them into one Rgba32Uint texel per pixel and the
//! 1-D passes hand that layout on, so a tap loads one texel per footprint texel instead of
//! three; `fetch = workgroup` (the default) runs separable's passes as compute shaders over
//! lines held in workgroup memory, the first packing its texels as it loads them, so no pack
//! step runs (on the H200 that step alone cost five times the two passes); `fetch = direct`
//! reads the three textures (no pack step or extra memory).
//! Both reproduce the oracle (the packed texel keeps colour, strength and scale as f16, which
//! is what the lighting pass's Rgba16Float targets hold anyway).
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
use crate::settings::{SssFetch, SssMethod, SssSettings};
use crate::timing::TimedPass;

mod pipelines;
mod workgroup;

use pipelines::{PipelineKey, Pipelines, Stage};

use workgroup::{Dispatch, LineFetch};
pub use workgroup::{LINE_SPAN as WORKGROUP_SPAN, LINE_TILE as WORKGROUP_TILE, pack_on_load_suits};

/// The passes with the direct fetch (three textures per texel of a tap).
pub const SHADER: &str = concat!(
    include_str!("../fullscreen.wgsl"),
    include_str!("sss.wgsl"),
    include_str!("sss_direct.wgsl")
);
/// The passes with the packed fetch (one Rgba32Uint texel per texel of a tap).
pub const SHADER_PACKED: &str = concat!(
    include_str!("../fullscreen.wgsl"),
    include_str!("sss.wgsl"),
    include_str!("sss_packed.wgsl")
);
/// The packed passes and the separable compute passes that read workgroup memory.
pub const SHADER_WORKGROUP: &str = concat!(
    include_str!("../fullscreen.wgsl"),
    include_str!("sss.wgsl"),
    include_str!("sss_packed.wgsl"),
    include_str!("sss_workgroup.wgsl")
);
/// Format of the diffuse texture the pass blurs in place (filterable on every adapter).
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The packed fetch's per-pixel texel (see sss_packed.wgsl for the layout).
pub const PACKED_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
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
    /// The separable passes' pixels `[x0, y0, x1, y1)` ([`SssPass::set_region`]).
    region: [u32; 4],
}

/// The textures the pass works on. `diffuse` is read and overwritten (usage
/// TEXTURE_BINDING | RENDER_ATTACHMENT | COPY_SRC, format [`FORMAT`]); `depth` is linear view
/// depth (R32Float); `sss` holds strength in r (0 = not skin), scene units per profile
/// millimetre in g and the pixel's row of the profile table in b (any float format; the
/// lighting pass writes Rgba16Float, and the packed fetch keeps strength and scale at that
/// f16 precision whatever the format: use the direct fetch for f32 scales).
pub struct SssInputs<'a> {
    /// Diffuse radiance, linear HDR: blurred in place.
    pub diffuse: &'a wgpu::Texture,
    /// Linear view depth in scene units.
    pub depth: &'a wgpu::TextureView,
    /// r = SSS strength, g = scene units per profile millimetre, b = profile row.
    pub sss: &'a wgpu::TextureView,
}

struct Step {
    key: PipelineKey,
    bind_group: wgpu::BindGroup,
    target: usize,
    accum: bool,
    /// A compute step (the workgroup fetch's 1-D passes).
    dispatch: Option<Dispatch>,
}

struct Bound {
    steps: Vec<Step>,
    targets: Vec<wgpu::TextureView>,
    _textures: Vec<wgpu::Texture>,
    copy: Option<(wgpu::Texture, wgpu::Texture)>,
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
    pipelines: Pipelines,
    dummy: wgpu::TextureView,
    dummy_packed: wgpu::TextureView,
    /// One per step of the method (see `uniform`).
    uniforms: Vec<wgpu::Buffer>,
    table: wgpu::Buffer,
    profiles: usize,
    taps: usize,
    focal_px: f32,
    /// Where the skin lies ([`Self::set_region`]); `None`: anywhere.
    region: Option<[u32; 4]>,
    /// The bound inputs' size.
    size: [u32; 2],
    bound: Option<Bound>,
    pack_on_load: bool,
}

impl SssPass {
    /// `profiles` is the profile table: row `i` is the kernel of pixels whose SSS texture
    /// names profile `i`. Every row needs `settings.samples` separable taps.
    pub fn new(
        device: &wgpu::Device,
        settings: &SssSettings,
        profiles: &[ScreenKernels],
    ) -> Result<Self, RenderError> {
        let dummy_of = |format| {
            util::dummy_view(
                device,
                "sss dummy",
                format,
                wgpu::TextureUsages::TEXTURE_BINDING,
            )
        };
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sss profiles"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let mut pass = Self {
            settings: settings.clone(),
            pipelines: Pipelines::new(device),
            dummy: dummy_of(FORMAT),
            dummy_packed: dummy_of(PACKED_FORMAT),
            uniforms: Vec::new(),
            table,
            profiles: 0,
            taps: 0,
            focal_px: 1.0,
            region: None,
            size: [0, 0],
            bound: None,
            pack_on_load: pack_on_load_suits(device),
        };
        pass.set_settings(device, settings, profiles)?;
        Ok(pass)
    }

    /// Whether the workgroup fetch's first compute pass packs its texels as it loads them into
    /// workgroup memory (true), or a pack step runs before the passes, which then read their
    /// taps from the packed texture (false); the image is the same. The default depends on
    /// the adapter: see [`pack_on_load_suits`].
    pub fn pack_on_load(&self) -> bool {
        self.pack_on_load
    }

    /// Overrides [`Self::pack_on_load`]'s choice; takes effect at the next `resize`.
    pub fn set_pack_on_load(&mut self, on: bool) {
        self.pack_on_load = on;
        self.bound = None;
    }

    /// The settings the pass was built for.
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
        self.uniforms = self.make_uniforms(device);
        self.bound = None;
        Ok(())
    }

    /// Writes what changes per frame: the camera's focal length in pixels,
    /// 0.5 * height / tan(fov_y / 2).
    pub fn prepare(&mut self, queue: &wgpu::Queue, focal_px: f32) {
        self.focal_px = focal_px;
        self.write_uniforms(queue);
    }

    /// One uniform buffer per step, holding the current values.
    fn make_uniforms(&self, device: &wgpu::Device) -> Vec<wgpu::Buffer> {
        (0..self.step_count())
            .map(|i| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("sss uniform"),
                    contents: bytemuck::bytes_of(&self.uniform(i)),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                })
            })
            .collect()
    }

    fn write_uniforms(&self, queue: &wgpu::Queue) {
        for (i, u) in self.uniforms.iter().enumerate() {
            queue.write_buffer(u, 0, bytemuck::bytes_of(&self.uniform(i)));
        }
    }

    /// Limits the separable method to the pixels `[x0, y0, x1, y1)` of `region`, which must
    /// hold every skin pixel and every pixel a skin pixel's taps reach
    /// (`frame_plan::sss_region` finds it from the skin's bounds and the kernels' reach);
    /// pixels outside are left untouched and cost nothing, and an empty region skips the
    /// passes. `None` runs over the whole frame. The other methods always run over the whole
    /// frame.
    pub fn set_region(&mut self, queue: &wgpu::Queue, region: Option<[u32; 4]>) {
        self.region = region;
        self.write_uniforms(queue);
    }

    /// The separable passes' pixels, within the bound inputs.
    fn region_px(&self) -> [u32; 4] {
        let [w, h] = self.size;
        match self.region {
            Some([x0, y0, x1, y1]) if self.settings.method == SssMethod::Separable => {
                let (x1, y1) = (x1.min(w), y1.min(h));
                [x0.min(x1), y0.min(y1), x1, y1]
            }
            _ => [0, 0, w, h],
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
            region: self.region_px(),
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
        self.size = [size.width, size.height];
        // The region is clamped to the new size.
        self.uniforms = self.make_uniforms(device);
        let fetch = self.settings.fetch;
        // Compute steps write their output as a storage texture.
        let compute = fetch == SssFetch::Workgroup
            && self.settings.method == SssMethod::Separable
            && util::supports_compute_storage(device);
        if compute {
            self.pipelines.prepare_compute(device);
        }
        let make_target = |label, format| {
            let storage = if compute {
                wgpu::TextureUsages::STORAGE_BINDING
            } else {
                wgpu::TextureUsages::empty()
            };
            util::texture_2d(
                device,
                label,
                size.width,
                size.height,
                size.depth_or_array_layers,
                format,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_DST
                    | storage,
            )
        };
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let diffuse_view = view(inputs.diffuse);
        let packed = fetch != SssFetch::Direct;
        // The workgroup fetch's fragment steps are the packed fetch's.
        let fragment_fetch = if packed { SssFetch::Packed } else { fetch };
        // Binding 1 is the colour a direct step reads (the pack step's input); binding 6 the
        // packed texel a packed step reads.
        let bg = |uniform: usize, color: &wgpu::TextureView, accum: &wgpu::TextureView| {
            let (color, packed_in) = if packed {
                (&self.dummy, color)
            } else {
                (color, &self.dummy_packed)
            };
            self.bind_group(device, inputs, uniform, color, accum, packed_in)
        };
        let key = |stage, packed_out| PipelineKey {
            stage,
            fetch: fragment_fetch,
            packed_out,
        };
        let step = |stage, packed_out, bind_group, target, accum| Step {
            key: key(stage, packed_out),
            bind_group,
            target,
            accum,
            dispatch: None,
        };
        let parts = || {
            self.pipelines
                .compute
                .as_ref()
                .expect("prepared for compute")
        };
        let compute_step = |stage, uniform: usize, input, out_packed, out_color, horizontal| {
            let fetch = match input {
                workgroup::LineInput::Inputs { .. } => LineFetch::PackOnLoad,
                workgroup::LineInput::Packed(_) if self.pack_on_load => LineFetch::Shared,
                workgroup::LineInput::Packed(_) => LineFetch::Texture,
            };
            let desc = workgroup::BindGroupDesc {
                uniform: &self.uniforms[uniform],
                table: &self.table,
                input,
                dummies: &parts().dummies,
                out_packed,
                out_color,
            };
            Step {
                // Compute pipelines are looked up by stage alone.
                key: key(stage, false),
                bind_group: workgroup::bind_group(device, &parts().layout, &desc),
                target: 0,
                accum: false,
                dispatch: Some(Dispatch { horizontal, fetch }),
            }
        };
        // Target indices: 0 = the diffuse input (written in place), then intermediates; an
        // intermediate a later step reads is packed with the packed fetch.
        let between = if packed { PACKED_FORMAT } else { FORMAT };
        let mut textures = Vec::new();
        let mut targets = vec![diffuse_view.clone()];
        let mut steps = Vec::new();
        let mut copy = None;
        // The packed fetch starts with the pack step into `input` (the last target); the
        // direct fetch reads the diffuse texture itself.
        let mut input = diffuse_view.clone();
        let mut packed_input = None;
        let pack_on_load = compute && self.pack_on_load;
        if packed && self.settings.method.is_screen_space() && !pack_on_load {
            let t = make_target("sss packed input", PACKED_FORMAT);
            input = view(&t);
            packed_input = Some(input.clone());
            textures.push(t);
        }
        match self.settings.method {
            SssMethod::None | SssMethod::Texture => {}
            SssMethod::Separable => {
                let tmp = make_target("sss tmp", between);
                let tmp_view = view(&tmp);
                let stage = if self.settings.jitter {
                    Stage::SeparableJitter
                } else {
                    Stage::Separable
                };
                if compute {
                    let color = &parts().dummies.color;
                    let input = if pack_on_load {
                        workgroup::LineInput::Inputs {
                            color: &diffuse_view,
                            depth: inputs.depth,
                            sss: inputs.sss,
                        }
                    } else {
                        workgroup::LineInput::Packed(&input)
                    };
                    steps.push(compute_step(stage, 0, input, &tmp_view, color, true));
                } else {
                    steps.push(step(stage, packed, bg(0, &input, &self.dummy), 1, false));
                }
                let storage = wgpu::TextureUsages::STORAGE_BINDING;
                if compute && inputs.diffuse.usage().contains(storage) {
                    let packed_dummy = &parts().dummies.packed;
                    let tmp = workgroup::LineInput::Packed(&tmp_view);
                    let v = compute_step(stage, 1, tmp, packed_dummy, &diffuse_view, false);
                    steps.push(v);
                } else {
                    steps.push(step(stage, false, bg(1, &tmp_view, &self.dummy), 0, false));
                }
                targets.push(tmp_view);
                textures.push(tmp);
            }
            SssMethod::Hable13 => {
                if packed {
                    // The packed copy is the input, so the pass writes the diffuse directly.
                    steps.push(step(
                        Stage::Hable13,
                        false,
                        bg(0, &input, &self.dummy),
                        0,
                        false,
                    ));
                } else {
                    let tmp = make_target("sss tmp", FORMAT);
                    let tmp_view = view(&tmp);
                    let bind_group = bg(0, &tmp_view, &self.dummy);
                    steps.push(step(Stage::Hable13, false, bind_group, 0, false));
                    copy = Some((inputs.diffuse.clone(), tmp.clone()));
                    targets.push(tmp_view);
                    textures.push(tmp);
                }
            }
            SssMethod::Gaussian6 => {
                // 1 = horizontal tmp, 2/3 = ping/pong blurred Gaussians, 4 = accumulation.
                for (label, format) in [
                    ("sss tmp", between),
                    ("sss ping", between),
                    ("sss pong", between),
                    ("sss accum", FORMAT),
                ] {
                    let t = make_target(label, format);
                    targets.push(view(&t));
                    textures.push(t);
                }
                let start = bg(0, &input, &self.dummy);
                steps.push(step(Stage::CopyWeighted, false, start, 4, false));
                let mut source = input.clone();
                for s in 0..self.gaussian_steps().len() {
                    let blurred = 2 + s % 2;
                    let h = bg(1 + 2 * s, &source, &self.dummy);
                    steps.push(step(Stage::Gaussian, packed, h, 1, false));
                    let v = bg(2 + 2 * s, &targets[1].clone(), &self.dummy);
                    steps.push(step(Stage::Accumulate, packed, v, blurred, true));
                    source = targets[blurred].clone();
                }
                // The resolve reads which pixels are skin from the input (packed or not).
                let resolve = if packed {
                    bg(0, &input, &targets[4].clone())
                } else {
                    bg(0, &self.dummy, &targets[4].clone())
                };
                steps.push(step(Stage::Resolve, false, resolve, 0, false));
            }
        }
        if let Some(packed_input) = packed_input {
            // The pack step reads the three inputs (direct bindings) whatever the fetch.
            let bind_group = self.bind_group(
                device,
                inputs,
                0,
                &diffuse_view,
                &self.dummy,
                &self.dummy_packed,
            );
            let pack = step(Stage::Pack, true, bind_group, targets.len(), false);
            steps.insert(0, pack);
            targets.push(packed_input);
        }
        for s in &steps {
            if let Some(d) = s.dispatch {
                self.pipelines.ensure_compute(device, s.key.stage, d.fetch);
            } else {
                self.pipelines.ensure_render(device, s.key);
            }
        }
        self.bound = Some(Bound {
            steps,
            targets,
            _textures: textures,
            copy,
        });
    }

    fn bind_group(
        &self,
        device: &wgpu::Device,
        inputs: &SssInputs<'_>,
        uniform: usize,
        color: &wgpu::TextureView,
        accum: &wgpu::TextureView,
        packed: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        let tex = wgpu::BindingResource::TextureView;
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sss"),
            layout: &self.pipelines.layout,
            entries: &[
                entry(0, self.uniforms[uniform].as_entire_binding()),
                entry(1, tex(color)),
                entry(2, tex(inputs.depth)),
                entry(3, tex(inputs.sss)),
                entry(4, self.table.as_entire_binding()),
                entry(5, tex(accum)),
                entry(6, tex(packed)),
            ],
        })
    }

    /// Records the passes. Call `resize` first; without bound inputs nothing is recorded.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let Some(bound) = &self.bound else { return };
        let [x0, y0, x1, y1] = self.region_px();
        if x1 <= x0 || y1 <= y0 {
            // No skin in view.
            return;
        }
        let [w, h] = [x1 - x0, y1 - y0];
        if let Some((src, dst)) = &bound.copy {
            encoder.copy_texture_to_texture(src.as_image_copy(), dst.as_image_copy(), src.size());
        }
        for s in &bound.steps {
            let timer = TimedPass::begin(profiler, "sss", encoder);
            if let Some(d) = s.dispatch {
                let [x, y] = workgroup::dispatch(w, h, d.horizontal);
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("sss"),
                        timestamp_writes: timer.compute_writes(),
                    });
                    pass.set_pipeline(self.pipelines.compute(s.key.stage, d.fetch));
                    pass.set_bind_group(0, &s.bind_group, &[]);
                    pass.dispatch_workgroups(x, y, 1);
                }
                timer.end(profiler, encoder);
                continue;
            }
            {
                let attach = |v| util::color_attachment(v, wgpu::LoadOp::Load);
                let accum_target = [
                    attach(&bound.targets[s.target]),
                    attach(&bound.targets[4.min(bound.targets.len() - 1)]),
                ];
                let single = [attach(&bound.targets[s.target])];
                let mut pass = util::color_pass(
                    encoder,
                    "sss",
                    if s.accum { &accum_target } else { &single },
                    timer.writes(),
                );
                pass.set_scissor_rect(x0, y0, w, h);
                pass.set_pipeline(self.pipelines.render(s.key));
                pass.set_bind_group(0, &s.bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
            timer.end(profiler, encoder);
        }
    }
}
