//! The whole frame, in the order of the data flow: shadow maps -> lighting (diffuse, specular,
//! depth, SSS strength) -> composite and tone map -> sRGB image.

use wgpu_profiler::GpuProfiler;

mod output;

use output::{ToneMapTarget, output_texture, target_views};

use crate::error::RenderError;
use crate::frame_plan::{AdapterFeatures, FramePlan};
use crate::gpu::GpuContext;
use crate::gpu_scene::{self, GpuObject};
use crate::material::{MaterialCache, ProfileTable};
use crate::passes::bounce::FluxPyramid;
use crate::passes::copy::CopyPass;
use crate::passes::lighting::{self, LightingPass, LightingTargets};
use crate::passes::shadow::ShadowPass;
use crate::passes::sss::{SssInputs, SssPass};
use crate::passes::texture_space::{self, TextureSpacePass, TextureSpaceSettings, TsmPass};
use crate::passes::tonemap::{self, DebugView};
use crate::readback;
use crate::scene::Scene;
use crate::settings::{RenderSettings, SssMethod, TransmittanceMethod};
use crate::timing::{self, PassTiming};

/// What a renderer draws with: the scene's `[render]` settings (or a copy the command line or
/// the viewer changed) and what is not part of a scene file.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// The frame's settings: size, exposure and one group per effect.
    pub settings: RenderSettings,
    /// Which buffer the output shows: the final image or an intermediate one.
    pub view: DebugView,
    /// Benchmarks: also time a plain full-screen copy of the diffuse target ("copy").
    pub baseline_copy: bool,
}

impl RenderOptions {
    /// The scene's own settings.
    pub fn from_scene(scene: &Scene) -> Self {
        Self {
            settings: scene.desc.render.clone(),
            ..Default::default()
        }
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.settings.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.settings.height
    }
}

/// A rendered frame: the tone-mapped sRGB image and the GPU time of each pass.
pub struct Frame {
    /// The tone-mapped image (or the debug view), sRGB.
    pub image: image::RgbaImage,
    /// Empty when the adapter has no timestamp queries.
    pub timings: Vec<PassTiming>,
}

impl Frame {
    /// GPU time of the whole frame, the sum of the passes', in milliseconds (0 without
    /// timestamp queries).
    pub fn gpu_total_ms(&self) -> f64 {
        self.timings.iter().map(|t| t.ms).sum()
    }
}

/// Renders a scene: the GPU resources of every pass, kept between frames.
pub struct Renderer {
    ctx: GpuContext,
    /// What the frames are drawn with.
    pub options: RenderOptions,
    /// What the lighting pass writes and screen-space SSS reads.
    pub targets: LightingTargets,
    object_layout: wgpu::BindGroupLayout,
    objects: Vec<GpuObject>,
    shadow: ShadowPass,
    /// The shadow maps' flux pyramid, where the bounce is gathered.
    bounce: Option<FluxPyramid>,
    lighting: LightingPass,
    sss: SssPass,
    copy: Option<CopyPass>,
    /// One tone-map pass per output format: `OUTPUT_FORMAT` first (PNGs), then those of
    /// the views given to `encode_to_view` (a window's swapchain).
    tonemaps: Vec<ToneMapTarget>,
    output: wgpu::Texture,
    profiler: GpuProfiler,
    background: [f32; 3],
    far: f32,
    light_kinds: Vec<[f32; 4]>,
    shadow_signature: Vec<(usize, u32)>,
    /// What the current frame is made of.
    plan: FramePlan,
    /// Each object's LUT key (`gpu_scene::lut_key`): a change re-uploads the objects.
    lut_keys: Vec<String>,
    /// The screen-space profile table and each object's row in it.
    profiles: ProfileTable,
    /// Group 2 of the lighting pass (texture-space maps per object).
    maps_layout: wgpu::BindGroupLayout,
    texture_space: TextureSpacePass,
    /// What forces the texture-space maps to be rebuilt: settings and which objects are skin.
    texture_signature: (TextureSpaceSettings, Vec<bool>),
    /// Translucent shadow maps, with `TransmittanceMethod::Tsm`.
    tsm: Option<TsmPass>,
    tsm_dummy: wgpu::TextureView,
}

fn texture_settings(options: &RenderOptions) -> TextureSpaceSettings {
    let s = &options.settings;
    TextureSpaceSettings {
        diffuse: s.sss.method == SssMethod::Texture,
        tsm: s.transmittance.method == TransmittanceMethod::Tsm,
        size: s.sss.texture_size,
        padding: s.sss.texture_padding,
        albedo_pre: s.sss.texture_albedo_pre,
    }
}

fn skin_flags(scene: &Scene) -> Vec<bool> {
    scene
        .objects
        .iter()
        .filter(|o| !o.mesh.indices.is_empty())
        .map(|o| o.material.sss_strength > 0.0)
        .collect()
}

fn check_options(ctx: &GpuContext, options: &RenderOptions) -> Result<(), RenderError> {
    options.settings.validate()?;
    ctx.check_size("", options.width(), options.height())
}

fn profile_table(scene: &Scene, options: &RenderOptions) -> Result<ProfileTable, RenderError> {
    ProfileTable::for_scene(
        scene,
        options.settings.sss.samples,
        &mut MaterialCache::default(),
    )
}

/// The pixels the blur runs on ([`crate::frame_plan::sss_region`]).
fn sss_region(scene: &Scene, options: &RenderOptions, profiles: &ProfileTable) -> [u32; 4] {
    crate::frame_plan::sss_region(
        scene,
        (options.width(), options.height()),
        &profiles.kernels,
        &profiles.object_rows,
        options.settings.sss.jitter,
    )
}

fn light_kinds(lights: &gpu_scene::LightSetup, count: usize) -> Vec<[f32; 4]> {
    (0..count)
        .map(|i| {
            let l = &lights.uniform.lights[i];
            [l.kind, l.direction[0], l.direction[1], l.direction[2]]
        })
        .collect()
}

/// What forces the shadow atlas to be rebuilt: the layers' lights and sizes.
fn shadow_signature(lights: &gpu_scene::LightSetup) -> Vec<(usize, u32)> {
    let mut v: Vec<(usize, u32)> = lights.layers.iter().map(|l| (l.light, l.size)).collect();
    v.push((usize::MAX, lights.atlas_size));
    v
}

/// The flux pyramid of `shadow` where the plan gathers the bounce.
fn flux_pyramid(
    ctx: &GpuContext,
    shadow: &ShadowPass,
    lights: &gpu_scene::LightSetup,
    plan: &FramePlan,
) -> Option<FluxPyramid> {
    (plan.bounce_ring > 0).then(|| {
        FluxPyramid::new(
            ctx,
            &shadow.atlas_view,
            &lights.layers,
            lights.atlas_size,
            &lights.uniform,
        )
    })
}

/// The shadow maps the lighting pass binds, with `bounce`'s flux pyramid.
fn shadow_maps<'a>(
    shadow: &'a ShadowPass,
    bounce: &'a Option<FluxPyramid>,
) -> lighting::ShadowMaps<'a> {
    let mut maps = shadow.maps();
    maps.flux = bounce
        .as_ref()
        .map(|b| [&b.position_view, &b.normal_view, &b.spread_view]);
    maps
}

/// The frame plan of `scene` with `options` on `ctx`'s adapter, and the lights it is lit by
/// (their uniform written with what the plan decided and the shaders read).
fn plan_frame(
    ctx: &GpuContext,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<(FramePlan, gpu_scene::LightSetup), RenderError> {
    let mut plan = FramePlan::new(scene, &options.settings, AdapterFeatures::of(&ctx.device));
    plan.lighting.thickness_view = options.view == DebugView::Thickness;
    let mut lights = gpu_scene::light_setup(scene, &options.settings)?;
    plan.write_lights(&mut lights.uniform);
    Ok((plan, lights))
}

impl Renderer {
    /// Uploads the scene and builds every pass for `options`. Errors when a setting is out of
    /// range or beyond the device's limits, when the frame exceeds the memory or work budget, or
    /// when a skin mesh lacks the UVs a texture-space method needs.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        options: RenderOptions,
    ) -> Result<Self, RenderError> {
        check_options(ctx, &options)?;
        crate::budget::check(scene, &options.settings)?;
        texture_space::check_uvs(scene, &texture_settings(&options))?;
        let device = &ctx.device;
        let object_layout = gpu_scene::object_layout(device);
        let profiles = profile_table(scene, &options)?;
        let objects = gpu_scene::upload_objects(ctx, scene, &object_layout, &profiles.object_rows)?;
        let (plan, lights) = plan_frame(ctx, scene, &options)?;
        let kinds = light_kinds(&lights, scene.desc.lights.len());
        let shadow = ShadowPass::new(
            ctx,
            &object_layout,
            &lights.layers,
            lights.atlas_size,
            &kinds,
        )?;
        let bounce = flux_pyramid(ctx, &shadow, &lights, &plan);
        let camera = gpu_scene::camera_uniform(scene, options.width(), options.height());
        let maps_layout = texture_space::maps_layout(device);
        let settings = texture_settings(&options);
        let tsm = settings
            .tsm
            .then(|| TsmPass::new(ctx, &object_layout, &lights.layers, lights.atlas_size));
        let tsm_dummy = texture_space::dummy_tsm_view(device);
        let lighting = LightingPass::with_maps(
            ctx,
            [&object_layout, &maps_layout],
            (&camera, &lights.uniform),
            shadow_maps(&shadow, &bounce),
            tsm.as_ref().map_or(&tsm_dummy, |t| &t.atlas_view),
            &plan,
        );
        let texture_space = TextureSpacePass::new(ctx, scene, &settings, &maps_layout)?;
        let mut targets =
            LightingTargets::with_map(ctx, options.width(), options.height(), plan.map);
        targets.set_back_faces(ctx, plan.thin_parts());
        let views = target_views(&targets);
        let mut sss = SssPass::new(device, &options.settings.sss, &profiles.kernels)?;
        sss.resize(
            device,
            &SssInputs {
                diffuse: &targets.diffuse,
                depth: &views[2],
                sss: &views[3],
            },
        );
        sss.prepare(&ctx.queue, camera.focal_px);
        sss.set_region(&ctx.queue, Some(sss_region(scene, &options, &profiles)));
        let output = output_texture(ctx, options.width(), options.height());
        let profiler = timing::new_profiler(device)?;
        let copy = options
            .baseline_copy
            .then(|| CopyPass::new(device, &targets.diffuse));
        ctx.check()?;
        let mut renderer = Self {
            ctx: ctx.clone(),
            targets,
            object_layout,
            objects,
            shadow,
            bounce,
            lighting,
            copy,
            sss,
            tonemaps: Vec::new(),
            output,
            profiler,
            background: options.settings.background,
            far: scene.desc.camera.far,
            light_kinds: kinds,
            shadow_signature: shadow_signature(&lights),
            plan,
            lut_keys: gpu_scene::lut_keys(scene),
            profiles,
            maps_layout,
            texture_space,
            texture_signature: (settings, skin_flags(scene)),
            tsm,
            tsm_dummy,
            options,
        };
        renderer.add_tonemap(tonemap::OUTPUT_FORMAT);
        Ok(renderer)
    }

    /// Applies a changed scene description (camera, lights, materials, transforms) and
    /// options (size, SSS, transmittance, exposure, view) without reloading meshes or
    /// textures: the viewer calls this on every edit. The scene's objects must be the same
    /// meshes as at creation (same count, same order); otherwise create a new `Renderer`.
    pub fn update(&mut self, scene: &Scene, options: &RenderOptions) -> Result<(), RenderError> {
        check_options(&self.ctx, options)?;
        crate::budget::check(scene, &options.settings)?;
        texture_space::check_uvs(scene, &texture_settings(options))?;
        let device = self.ctx.device.clone();
        let queue = self.ctx.queue.clone();
        let keys = gpu_scene::lut_keys(scene);
        let profiles = profile_table(scene, options)?;
        let new_profiles = profiles.kernels != self.profiles.kernels;
        let reuploaded = keys != self.lut_keys;
        if reuploaded {
            // A different medium needs a different LUT in the object's bind group.
            self.objects = gpu_scene::upload_objects(
                &self.ctx,
                scene,
                &self.object_layout,
                &profiles.object_rows,
            )?;
            self.lut_keys = keys;
        } else {
            let mut cache = MaterialCache::default();
            let mut gpu = self.objects.iter().enumerate();
            for (i, o) in scene.objects.iter().enumerate() {
                if o.mesh.indices.is_empty() {
                    continue;
                }
                let Some((index, g)) = gpu.next() else { break };
                let optics =
                    cache.get(&o.material.medium, &format!("objects[{i}].material.medium"))?;
                let row = profiles.object_rows[i];
                let u = crate::uniforms::ObjectUniform {
                    index: index as u32,
                    ..gpu_scene::object_uniform(
                        o,
                        &optics,
                        subsurface_profile::TransmittanceLut::DEFAULT_S_MAX_MM,
                        row,
                    )
                };
                queue.write_buffer(&g.uniform, 0, bytemuck::bytes_of(&u));
            }
        }
        let (plan, lights) = plan_frame(&self.ctx, scene, options)?;
        let kinds = light_kinds(&lights, scene.desc.lights.len());
        let signature = shadow_signature(&lights);
        let settings = texture_settings(options);
        let rebuild_shadows =
            signature != self.shadow_signature || kinds.len() != self.light_kinds.len();
        if rebuild_shadows {
            self.shadow = ShadowPass::new(
                &self.ctx,
                &self.object_layout,
                &lights.layers,
                lights.atlas_size,
                &kinds,
            )?;
            self.shadow_signature = signature;
        } else {
            self.shadow.update_layers(&queue, &lights.layers, &kinds);
        }
        let had_bounce = self.bounce.is_some();
        match &self.bounce {
            Some(b) if !rebuild_shadows && plan.bounce_ring > 0 => {
                b.update(&queue, &lights.layers, &lights.uniform)
            }
            _ => self.bounce = flux_pyramid(&self.ctx, &self.shadow, &lights, &plan),
        }
        let new_bounce = rebuild_shadows || had_bounce != self.bounce.is_some();
        let had_tsm = self.tsm.is_some();
        match (&mut self.tsm, settings.tsm) {
            (Some(tsm), true) if !rebuild_shadows => tsm.update_layers(&queue, &lights.layers),
            (_, true) => {
                self.tsm = Some(TsmPass::new(
                    &self.ctx,
                    &self.object_layout,
                    &lights.layers,
                    lights.atlas_size,
                ));
            }
            (_, false) => self.tsm = None,
        }
        self.light_kinds = kinds;
        let camera = gpu_scene::camera_uniform(scene, options.width(), options.height());
        // The lighting pass binds the shadow atlas and translucent shadow maps: rebuilt only
        // when those are new, else a camera or light move is two buffer writes (the viewer
        // calls this on every mouse drag).
        let new_maps = new_bounce || had_tsm != settings.tsm || (settings.tsm && !had_tsm);
        if !new_maps {
            // The uniforms and the plan's pipelines.
            self.lighting
                .prepare(&self.ctx, &camera, &lights.uniform, &plan);
        } else {
            self.lighting = LightingPass::with_maps(
                &self.ctx,
                [&self.object_layout, &self.maps_layout],
                (&camera, &lights.uniform),
                shadow_maps(&self.shadow, &self.bounce),
                self.tsm.as_ref().map_or(&self.tsm_dummy, |t| &t.atlas_view),
                &plan,
            );
        }
        let texture_signature = (settings, skin_flags(scene));
        if reuploaded || texture_signature != self.texture_signature {
            self.texture_space =
                TextureSpacePass::new(&self.ctx, scene, &texture_signature.0, &self.maps_layout)?;
            self.texture_signature = texture_signature;
        }
        // New targets (and every binding of them) when the size changes; a new transmitted map
        // alone when only its shape does (the camera moved the skin nearer or farther, a
        // shadowed light came or went).
        let resized =
            (options.width(), options.height()) != (self.options.width(), self.options.height());
        if resized {
            self.targets =
                LightingTargets::with_map(&self.ctx, options.width(), options.height(), plan.map);
            self.output = output_texture(&self.ctx, options.width(), options.height());
        } else if plan.map != self.targets.map_shape() {
            self.targets.set_map(&self.ctx, plan.map);
        }
        self.targets.set_back_faces(&self.ctx, plan.thin_parts());
        let views = target_views(&self.targets);
        let new_sss = new_profiles || options.settings.sss != self.options.settings.sss;
        if new_sss {
            self.sss
                .set_settings(&device, &options.settings.sss, &profiles.kernels)?;
        }
        self.profiles = profiles;
        if resized || new_sss {
            self.sss.resize(
                &device,
                &SssInputs {
                    diffuse: &self.targets.diffuse,
                    depth: &views[2],
                    sss: &views[3],
                },
            );
        }
        self.sss.prepare(&queue, camera.focal_px);
        self.sss
            .set_region(&queue, Some(sss_region(scene, options, &self.profiles)));
        if resized || options.baseline_copy != self.copy.is_some() {
            self.copy = options
                .baseline_copy
                .then(|| CopyPass::new(&device, &self.targets.diffuse));
        }
        self.background = options.settings.background;
        self.far = scene.desc.camera.far;
        self.options = options.clone();
        self.plan = plan;
        self.rebind_tonemaps(resized);
        self.ctx.check()
    }

    /// The device and queue it renders with.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Number of shadow-map layers (1 per shadowed spot/directional light, 6 per point light).
    pub fn shadow_layer_count(&self) -> usize {
        self.shadow.layer_count()
    }

    /// The shadow maps' flux pyramid, where the bounce is gathered (`passes::bounce`).
    pub fn flux_pyramid(&self) -> Option<&FluxPyramid> {
        self.bounce.as_ref()
    }

    /// The shadow atlas (`Rg32Float` array: linear light distance and the entry normal).
    pub fn shadow_atlas(&self) -> &wgpu::Texture {
        &self.shadow.atlas
    }

    /// Texture-space maps of the `index`th object with a mesh: (irradiance, stretch, blurred
    /// maps); None when the object has none (not skin, or neither `--sss texture` nor TSM).
    pub fn texture_space_maps(
        &self,
        index: usize,
    ) -> Option<(&wgpu::Texture, &wgpu::Texture, &texture_space::BlurTargets)> {
        self.texture_space.object_maps(index)
    }

    /// Records shadow maps, texture-space maps, lighting and SSS: everything up to the HDR
    /// targets.
    pub fn encode_scene(&self, encoder: &mut wgpu::CommandEncoder) {
        let p = Some(&self.profiler);
        self.shadow.encode(encoder, &self.objects, p);
        if let Some(bounce) = &self.bounce {
            bounce.encode(encoder, p);
        }
        if let Some(tsm) = &self.tsm {
            tsm.encode(encoder, &self.objects, p);
        }
        self.texture_space
            .encode(encoder, &self.lighting, &self.objects, p);
        self.lighting.encode_with_maps(
            encoder,
            &self.targets,
            &self.objects,
            self.texture_space.bind_groups(),
            self.background,
            self.far,
            p,
        );
        if self.options.view.blurs() && self.options.settings.sss.method.is_screen_space() {
            self.sss.encode(encoder, p);
        }
        if let Some(copy) = &self.copy {
            copy.encode(encoder, p);
        }
    }

    /// After `encode_to_view` or `encode_frame`: resolves this frame's timestamp queries into
    /// `encoder`. Call once per frame before submitting.
    pub fn resolve_timings(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.profiler.resolve_queries(encoder);
    }

    /// After submitting: closes the frame and returns the newest finished frame's per-pass
    /// GPU times, without waiting (None until one is ready).
    pub fn finish_frame(&mut self) -> Result<Option<Vec<PassTiming>>, RenderError> {
        self.profiler
            .end_frame()
            .map_err(|e| RenderError::Validation(format!("profiler: {e}")))?;
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        let period = self.ctx.queue.get_timestamp_period();
        let mut latest = None;
        while let Some(results) = self.profiler.process_finished_frame(period) {
            latest = Some(timing::collect(&results));
        }
        Ok(latest)
    }

    /// Renders a frame on the GPU and waits for it; returns the per-pass GPU times.
    pub fn render_timed(&mut self) -> Result<Vec<PassTiming>, RenderError> {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_frame(&mut encoder);
        self.profiler.resolve_queries(&mut encoder);
        self.ctx.queue.submit([encoder.finish()]);
        self.profiler
            .end_frame()
            .map_err(|e| RenderError::Validation(format!("profiler: {e}")))?;
        self.ctx.check()?;
        let period = self.ctx.queue.get_timestamp_period();
        let mut timings = Vec::new();
        while let Some(results) = self.profiler.process_finished_frame(period) {
            timings = timing::collect(&results);
        }
        Ok(timings)
    }

    /// Renders a frame and reads the tone-mapped image back.
    pub fn render(&mut self) -> Result<Frame, RenderError> {
        let timings = self.render_timed()?;
        let image = readback::read_rgba8(&self.ctx, &self.output)?;
        Ok(Frame { image, timings })
    }

    /// Linear view depth of the last frame, row-major, in scene units.
    pub fn read_linear_depth(&self) -> Result<Vec<f32>, RenderError> {
        Ok(readback::read_float(&self.ctx, &self.targets.depth)?.0)
    }

    /// Diffuse radiance of the last frame as RGBA f32.
    pub fn read_diffuse(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(rgba(
            readback::read_float(&self.ctx, &self.targets.diffuse)?.0,
        ))
    }

    /// Specular radiance of the last frame as RGBA f32.
    pub fn read_specular(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(rgba(
            readback::read_float(&self.ctx, &self.targets.specular)?.0,
        ))
    }

    /// (SSS strength, scene units per mm, profile row, unused) of the last frame.
    pub fn read_sss(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(rgba(readback::read_float(&self.ctx, &self.targets.sss)?.0))
    }

    /// The screen-space profile table (row `i` is the kernel of pixels whose SSS target
    /// names profile `i`) and each scene object's row.
    pub fn profile_table(&self) -> &ProfileTable {
        &self.profiles
    }

    /// The screen-space SSS pass, as this frame runs it (e.g. whether its workgroup fetch packs
    /// on load, [`SssPass::pack_on_load`]).
    pub fn sss_pass(&self) -> &SssPass {
        &self.sss
    }
}

fn rgba(v: Vec<f32>) -> Vec<[f32; 4]> {
    v.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}
