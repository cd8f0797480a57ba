//! The whole frame, in the order of the data flow: shadow maps -> lighting (diffuse, specular,
//! depth, SSS strength) -> composite and tone map -> sRGB image.

use wgpu_profiler::GpuProfiler;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::gpu_scene::{self, GpuObject};
use crate::passes::copy::CopyPass;
use crate::passes::lighting::{LightingPass, LightingTargets};
use crate::passes::shadow::ShadowPass;
use crate::passes::sss::{SssConfig, SssInputs, SssMethod, SssPass};
use crate::passes::tonemap::{self, DebugView, ToneMapInputs, ToneMapPass};
use crate::passes::transmittance::TransmittanceConfig;
use crate::readback;
use crate::scene::Scene;
use crate::timing::{self, PassTiming};

/// Per-render settings that are not part of the scene file.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    pub exposure_ev: f32,
    pub view: DebugView,
    /// Screen-space subsurface scattering settings.
    pub sss: SssConfig,
    /// Light through thin parts.
    pub transmittance: TransmittanceConfig,
    /// Benchmarks: also time a plain full-screen copy of the diffuse target ("copy").
    pub baseline_copy: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
            exposure_ev: 0.0,
            view: DebugView::Final,
            sss: SssConfig::default(),
            transmittance: TransmittanceConfig::default(),
            baseline_copy: false,
        }
    }
}

impl RenderOptions {
    /// The scene's own size and exposure.
    pub fn from_scene(scene: &Scene) -> Self {
        let r = &scene.desc.render;
        Self {
            width: r.width,
            height: r.height,
            exposure_ev: r.exposure_ev,
            view: DebugView::Final,
            sss: SssConfig::default(),
            transmittance: TransmittanceConfig {
                normal_shrink: r.normal_shrink,
                ..Default::default()
            },
            baseline_copy: false,
        }
    }
}

/// A rendered frame: the tone-mapped sRGB image and the GPU time of each pass.
pub struct Frame {
    pub image: image::RgbaImage,
    /// Empty when the adapter has no timestamp queries.
    pub timings: Vec<PassTiming>,
}

impl Frame {
    pub fn gpu_total_ms(&self) -> f64 {
        self.timings.iter().map(|t| t.ms).sum()
    }
}

pub struct Renderer {
    ctx: GpuContext,
    pub options: RenderOptions,
    pub targets: LightingTargets,
    objects: Vec<GpuObject>,
    shadow: ShadowPass,
    lighting: LightingPass,
    sss: SssPass,
    copy: Option<CopyPass>,
    tonemap: ToneMapPass,
    tonemap_bind_group: wgpu::BindGroup,
    output: wgpu::Texture,
    profiler: GpuProfiler,
    background: [f32; 3],
    far: f32,
}

impl Renderer {
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        options: RenderOptions,
    ) -> Result<Self, RenderError> {
        ctx.check_size("", options.width, options.height)?;
        if !options.exposure_ev.is_finite() || options.exposure_ev.abs() > 32.0 {
            return Err(RenderError::invalid(
                "exposure",
                format!(
                    "must be finite and within +-32 EV (got {})",
                    options.exposure_ev
                ),
            ));
        }
        options.transmittance.validate()?;
        let device = &ctx.device;
        let object_layout = gpu_scene::object_layout(device);
        let objects = gpu_scene::upload_objects(ctx, scene, &object_layout)?;
        let lights = gpu_scene::light_setup(scene, &options.transmittance)?;
        let kinds: Vec<[f32; 4]> = (0..scene.desc.lights.len())
            .map(|i| {
                let l = &lights.uniform.lights[i];
                [
                    l.position[3],
                    l.direction[0],
                    l.direction[1],
                    l.direction[2],
                ]
            })
            .collect();
        let shadow = ShadowPass::new(
            ctx,
            &object_layout,
            &lights.layers,
            lights.atlas_size,
            &kinds,
        )?;
        let camera = gpu_scene::camera_uniform(scene, options.width, options.height);
        let lighting = LightingPass::new(
            ctx,
            &object_layout,
            &camera,
            &lights.uniform,
            &shadow.atlas_view,
        );
        let targets = LightingTargets::new(ctx, options.width, options.height);
        let tonemap = ToneMapPass::new(device, tonemap::OUTPUT_FORMAT);
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let mut sss = SssPass::new(device, &options.sss)?;
        sss.bind(
            device,
            &SssInputs {
                diffuse: &targets.diffuse,
                depth: &view(&targets.depth),
                sss: &view(&targets.sss),
            },
        );
        sss.set_camera(&ctx.queue, camera.params[2]);
        let tonemap_bind_group = tonemap.bind(
            device,
            &ToneMapInputs {
                diffuse: &view(&targets.diffuse),
                specular: &view(&targets.specular),
                depth: &view(&targets.depth),
                sss: &view(&targets.sss),
            },
        );
        let output = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("output"),
            size: wgpu::Extent3d {
                width: options.width,
                height: options.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: tonemap::OUTPUT_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let profiler = timing::new_profiler(device)?;
        ctx.check()?;
        let copy = options
            .baseline_copy
            .then(|| CopyPass::new(device, &targets.diffuse));
        Ok(Self {
            ctx: ctx.clone(),
            targets,
            objects,
            shadow,
            lighting,
            copy,
            sss,
            tonemap,
            tonemap_bind_group,
            output,
            profiler,
            background: scene.desc.render.background,
            far: scene.desc.camera.far,
            options,
        })
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Number of shadow-map layers (1 per shadowed spot/directional light, 6 per point light).
    pub fn shadow_layer_count(&self) -> usize {
        self.shadow.layer_count()
    }

    /// The shadow atlas (R32Float array of linear light distances).
    pub fn shadow_atlas(&self) -> &wgpu::Texture {
        &self.shadow.atlas
    }

    /// Records one whole frame into `encoder`, ending with the tone-mapped `output` texture.
    pub fn encode_frame(&self, encoder: &mut wgpu::CommandEncoder) {
        let p = Some(&self.profiler);
        self.tonemap.set_params(
            &self.ctx.queue,
            self.options.exposure_ev,
            self.options.view,
            self.far,
        );
        self.shadow.encode(encoder, &self.objects, p);
        self.lighting.encode(
            encoder,
            &self.targets,
            &self.objects,
            self.background,
            self.far,
            p,
        );
        if self.options.view != DebugView::DiffuseBeforeSss
            && self.options.sss.method != SssMethod::None
        {
            self.sss.encode(encoder, p);
        }
        if let Some(copy) = &self.copy {
            copy.encode(encoder, p);
        }
        let out = self.output.create_view(&Default::default());
        self.tonemap
            .encode(encoder, &self.tonemap_bind_group, &out, p);
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

    /// (SSS strength, scene units per mm) of the last frame.
    pub fn read_sss(&self) -> Result<Vec<[f32; 2]>, RenderError> {
        let v = readback::read_float(&self.ctx, &self.targets.sss)?.0;
        Ok(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
    }
}

fn rgba(v: Vec<f32>) -> Vec<[f32; 4]> {
    v.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}
