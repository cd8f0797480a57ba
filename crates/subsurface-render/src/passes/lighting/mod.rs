//! The lighting pass: Lambert diffuse with albedo, the rough boundary's specular (Cook-Torrance
//! with Beckmann facets and Smith masking, `subsurface_profile::specular`), normal
//! maps, spot falloff, inverse-square attenuation and shadows filtered by percentage-closer
//! gathers on the shadow maps' z-buffer (linear light distance stays for thickness). A depth
//! pre-pass first keeps the nearest surface, so the shader runs once per pixel. It writes
//! diffuse and specular apart (only diffuse is blurred by subsurface scattering), linear depth
//! and the per-pixel SSS strength.
//!
//! Where the frame plan has a transmitted map, its passes ([`crate::passes::transmitted_map`]) run
//! first and the lighting pass reads `diffusion`'s transmitted light and the bounce from it
//! once per pixel, with a pipeline that holds no taps of its own.
//!
//! Group 0 (camera, lights, shadow maps, translucent shadow maps, flux pyramid; declared in
//! bindings/frame.wgsl) is built by [`frame_layout`]; group 1 is the object's
//! (`gpu::object::object_layout`, bindings/object.wgsl), group 2 the
//! object's texture-space maps ([`maps::maps_layout`]), group 3 the transmitted map and the
//! back faces ([`screen_layout`]).
//!
//! Where the plan's terms hold the thin parts (`FramePlan::thin_parts`), a depth pass of the back faces runs before
//! the pre-pass: the nearest back face per pixel, from which the lighting shader measures how
//! thick the part under each pixel is (`thin_part_reflectance`). The texture-space pass draws its UV-space irradiance with the same
//! groups (`texture_space::irradiance`), group 3 being [`LightingPass::no_transmitted_map`].

mod outline;
mod targets;

pub use targets::{
    BACK_FACES_FORMAT, DEPTH_FORMAT, LightingTargets, RADIANCE_FORMAT, SSS_FORMAT, screen_layout,
    zbuffer_format,
};
use targets::{dummy_transmitted_map, no_back_faces, screen_bind_group};

use wgpu::util::DeviceExt;

use crate::frame_plan::{FramePlan, LightingVariant};
use crate::gpu::GpuContext;
use crate::gpu::object::GpuObject;
use crate::passes::maps;
use crate::passes::overrides::{
    BOUNCE_SOURCE, DIFFUSION_TERMS, LATERAL_SOURCE, OUTLINE_PASS, THICKNESS_VIEW,
    TRANSMITTANCE_METHOD, lateral,
};
use crate::passes::transmitted_map::TransmittedMapPass;
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{CameraUniform, LightsUniform};

/// The lighting shader's WGSL: common declarations, lighting.wgsl and the shadow, transmittance,
/// bounce and transmitted-map code it calls.
pub const SHADER: &str = lighting_shader!(
    include_str!("../transmitted_map/transmitted_map.wgsl"),
    include_str!("outline.wgsl"),
);

/// The outline pass's full-screen mark (outline_mark.wgsl after the full-screen vertex stage).
pub const OUTLINE_MARK_SHADER: &str = concat!(
    include_str!("../fullscreen.wgsl"),
    include_str!("outline_mark.wgsl")
);

/// Layout of group 0 of the lighting pass (`camera`, `lights`, `shadow_atlas`, `tsm_atlas`,
/// `shadow_depth` and `shadow_compare` in lighting.wgsl, `flux_position`, `flux_normal` and
/// `flux_spread` in bounce.wgsl). Equal layouts are interchangeable,
/// so other pipelines built on the lighting shader (the texture-space irradiance) may bind
/// [`LightingPass::frame_bind_group`].
pub fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Compute too: the transmitted map's evaluation (transmitted_map.wgsl, `cs_transmitted`) reads the
    // camera, the lights and the shadow maps.
    let stages = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let uniform = |binding| util::uniform_entry(binding, wgpu::ShaderStages::VERTEX | stages);
    // Shadow and translucent shadow map arrays: 32-bit floats, so not filterable.
    let atlas = |binding| {
        util::float_texture_entry(binding, stages, false, wgpu::TextureViewDimension::D2Array)
    };
    // The shadow maps' z-buffer, read through a comparison sampler: each gather tests a 2x2
    // block of texels in the texture unit (hardware PCF).
    let depth = util::depth_array_entry(4, stages);
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lighting frame"),
        entries: &[
            uniform(0),
            uniform(1),
            atlas(2),
            atlas(3),
            depth,
            // The flux pyramid (passes::bounce), also 32-bit floats.
            atlas(6),
            atlas(7),
            atlas(8),
            util::sampler_entry(5, stages, wgpu::SamplerBindingType::Comparison),
        ],
    })
}

/// Group 0 of the lighting shader's pipelines ([`frame_layout`]): the camera and lights
/// uniforms (`CameraUniform`, `LightsUniform`), the shadow maps and the translucent shadow maps
/// (`Rg32Float` array; [`maps::dummy_tsm_view`] where none are drawn). Other renderers bind it
/// to [`crate::passes::transmitted_light::TransmittedLightPass`].
pub fn frame_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    [camera, lights]: [&wgpu::Buffer; 2],
    shadow: ShadowMaps<'_>,
    tsm_atlas: &wgpu::TextureView,
) -> wgpu::BindGroup {
    let shadow_compare = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("shadow compare"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        // Lit where the receiver's biased depth is at most the occluder's.
        compare: Some(wgpu::CompareFunction::LessEqual),
        ..Default::default()
    });
    let no_flux = crate::passes::bounce::dummy_views(device);
    let flux = shadow
        .flux
        .unwrap_or([&no_flux[0], &no_flux[1], &no_flux[2]]);
    let view = wgpu::BindingResource::TextureView;
    util::bind_group(
        device,
        "lighting frame",
        layout,
        [
            (0, camera.as_entire_binding()),
            (1, lights.as_entire_binding()),
            (2, view(shadow.atlas)),
            (3, view(tsm_atlas)),
            (4, view(shadow.depth)),
            (5, wgpu::BindingResource::Sampler(&shadow_compare)),
            (6, view(flux[0])),
            (7, view(flux[1])),
            (8, view(flux[2])),
        ],
    )
}

/// The shadow maps the lighting pass reads ([`crate::passes::shadow::ShadowPass::maps`]).
#[derive(Clone, Copy)]
pub struct ShadowMaps<'a> {
    /// Linear light distance and entry normal per texel (`Rg32Float` array): thickness.
    pub atlas: &'a wgpu::TextureView,
    /// The same layers' z-buffer (`Depth32Float` array): percentage-closer filtering through
    /// a comparison sampler.
    pub depth: &'a wgpu::TextureView,
    /// The flux pyramid's position and normal sums (`bounce::FluxPyramid`), where the
    /// bounce is gathered.
    pub flux: Option<[&'a wgpu::TextureView; 3]>,
}

/// The lighting pass's `fs_main` built for `variant`.
fn lighting_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    variant: LightingVariant,
) -> wgpu::RenderPipeline {
    util::MeshPipeline {
        label: "lighting",
        layout,
        module,
        vertex: "vs_main",
        fragment: "fs_main",
        targets: &[RADIANCE_FORMAT, RADIANCE_FORMAT, DEPTH_FORMAT, SSS_FORMAT],
        // Not culled: glTF skin meshes are often open (wrists, necks) and the shader flips
        // the normal of back faces.
        cull_mode: None,
        depth: util::DepthTest::Prepassed,
        stencil: Some((zbuffer_format(device), Default::default())),
        constants: &variant_constants(variant),
        blend: None,
    }
    .create(device)
}

/// The overrides that build the lighting shader's entry points for `variant`.
fn variant_constants(variant: LightingVariant) -> [(&'static str, f64); 6] {
    [
        (TRANSMITTANCE_METHOD, f64::from(variant.method)),
        (BOUNCE_SOURCE, f64::from(variant.bounce)),
        (LATERAL_SOURCE, f64::from(variant.lateral)),
        (DIFFUSION_TERMS, f64::from(variant.terms.0)),
        (OUTLINE_PASS, f64::from(u8::from(variant.outline_pass))),
        (THICKNESS_VIEW, f64::from(u8::from(variant.thickness_view))),
    ]
}

/// Lights every pixel: writes diffuse and specular radiance, linear depth and the SSS inputs
/// ([`LightingTargets`]), with the lights' shadows, transmittance and the bounce.
pub struct LightingPass {
    /// Depth only, the lighting shader's vertex stage: the nearest surface per pixel.
    prepass: wgpu::RenderPipeline,
    /// Front faces culled: the nearest back face's depth and normal per pixel (`fs_back_faces`).
    back_faces: wgpu::RenderPipeline,
    /// Whether the plan's terms hold the thin parts, which read the back faces.
    thin_parts: bool,
    /// `fs_main` built per [`LightingVariant`], each kept once built: switching methods back
    /// and forth in the viewer compiles each once.
    pipelines: Vec<(LightingVariant, wgpu::RenderPipeline)>,
    /// The index in `pipelines` of the plan's variant.
    current: usize,
    /// Where `current` reads the transmitted map: the index in `pipelines` of its variant that
    /// gathers the taps at each pixel instead, for the objects `taps_objects` marks (skin too
    /// far for the map's texels, the plan's `taps_objects`).
    taps: Option<usize>,
    taps_objects: Vec<bool>,
    /// The outline pass ([`LightingVariant::outline_pass`]).
    outline: outline::Outline,
    module: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    /// The transmitted map's passes, on the same shader and groups.
    map: TransmittedMapPass,
    /// Group 3 for pipelines that take the screen layout but never read the map.
    no_transmitted_map: wgpu::BindGroup,
    frame_bind_group: wgpu::BindGroup,
    /// Group 2 for objects without texture-space maps.
    default_maps: wgpu::BindGroup,
    /// Written only through [`Self::prepare`], with the pipelines of the same plan.
    camera: wgpu::Buffer,
    lights: wgpu::Buffer,
}

impl LightingPass {
    /// Without texture-space maps or translucent shadow maps.
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        camera: &CameraUniform,
        lights: &LightsUniform,
        shadow: ShadowMaps<'_>,
        plan: &FramePlan,
    ) -> Self {
        let maps_layout = maps::maps_layout(&ctx.device);
        let tsm = maps::dummy_tsm_view(&ctx.device);
        let uniforms = (camera, lights);
        Self::with_maps(
            ctx,
            [object_layout, &maps_layout],
            uniforms,
            shadow,
            &tsm,
            plan,
        )
    }

    /// `layouts`: the objects' group 1 ([`crate::gpu::object::object_layout`]) and their
    /// texture-space maps' group 2 ([`maps::maps_layout`]); `tsm_atlas` the translucent
    /// shadow maps (`Rg32Float` array, same layers as the shadow maps).
    pub fn with_maps(
        ctx: &GpuContext,
        layouts: [&wgpu::BindGroupLayout; 2],
        (camera, lights): (&CameraUniform, &LightsUniform),
        shadow: ShadowMaps<'_>,
        tsm_atlas: &wgpu::TextureView,
        plan: &FramePlan,
    ) -> Self {
        let [object_layout, maps_layout] = layouts;
        let device = &ctx.device;
        let module = util::wgsl_module(device, "lighting.wgsl", SHADER);
        let frame_layout = frame_layout(device);
        let buffer = |label, contents| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
        };
        let camera = buffer("camera", bytemuck::bytes_of(camera));
        let lights = buffer("lights", bytemuck::bytes_of(lights));
        let frame_bind_group =
            frame_bind_group(device, &frame_layout, [&camera, &lights], shadow, tsm_atlas);
        let prepass_layout = util::pipeline_layout(
            device,
            "depth prepass",
            &[&frame_layout, object_layout, maps_layout],
        );
        let layout = util::pipeline_layout(
            device,
            "lighting",
            &[
                &frame_layout,
                object_layout,
                maps_layout,
                &screen_layout(device),
            ],
        );
        let map = TransmittedMapPass::new(
            device,
            &module,
            [&frame_layout, object_layout, maps_layout],
            plan,
        );
        let pipeline = lighting_pipeline(device, &layout, &module, plan.lighting);
        // Meshes drawn without culling in any order would shade every surface a pixel covers
        // that lands before the nearest one (the back of a head, the far side of a hand): a
        // depth-only pass first leaves the lighting shader one fragment per pixel.
        let prepass = util::depth_prepass_pipeline(
            device,
            &prepass_layout,
            &module,
            "vs_main",
            zbuffer_format(device),
        );
        let back_faces = util::MeshPipeline {
            label: "back faces",
            layout: &prepass_layout,
            module: &module,
            vertex: "vs_main",
            fragment: "fs_back_faces",
            targets: &[BACK_FACES_FORMAT],
            cull_mode: Some(wgpu::Face::Front),
            depth: util::DepthTest::Nearest,
            stencil: None,
            constants: &[],
            blend: None,
        }
        .create(device);
        let default_maps = maps::default_maps_bind_group(device, maps_layout);
        let mut pass = Self {
            prepass,
            back_faces,
            thin_parts: plan.thin_parts(),
            pipelines: vec![(plan.lighting, pipeline)],
            taps: None,
            taps_objects: Vec::new(),
            outline: Default::default(),
            current: 0,
            module,
            layout,
            map,
            no_transmitted_map: screen_bind_group(
                device,
                &dummy_transmitted_map(device),
                &no_back_faces(device),
            ),
            default_maps,
            frame_bind_group,
            camera,
            lights,
        };
        pass.set_taps_objects(device, plan);
        pass.set_outline(device, plan);
        pass
    }

    /// Group 0 (see [`frame_layout`]): camera, lights, shadow maps, translucent shadow maps.
    pub fn frame_bind_group(&self) -> &wgpu::BindGroup {
        &self.frame_bind_group
    }

    /// Group 3 (see [`screen_layout`]) without a transmitted map, for pipelines on the lighting
    /// shader that never read it.
    pub fn no_transmitted_map(&self) -> &wgpu::BindGroup {
        &self.no_transmitted_map
    }

    /// Writes the per-frame uniforms (the camera and the lights) and takes `plan`'s pipelines,
    /// building those it has not built yet.
    pub fn prepare(
        &mut self,
        ctx: &GpuContext,
        camera: &CameraUniform,
        lights: &LightsUniform,
        plan: &FramePlan,
    ) {
        ctx.queue
            .write_buffer(&self.camera, 0, bytemuck::bytes_of(camera));
        ctx.queue
            .write_buffer(&self.lights, 0, bytemuck::bytes_of(lights));
        self.current = self.pipeline_index(&ctx.device, plan.lighting);
        self.thin_parts = plan.thin_parts();
        self.set_taps_objects(&ctx.device, plan);
        self.set_outline(&ctx.device, plan);
        self.map.prepare(&ctx.device, plan);
    }

    /// The index in `pipelines` of `key`'s pipeline, built the first time it is asked for.
    fn pipeline_index(&mut self, device: &wgpu::Device, key: LightingVariant) -> usize {
        match self.pipelines.iter().position(|(k, _)| *k == key) {
            Some(i) => i,
            None => {
                let pipeline = lighting_pipeline(device, &self.layout, &self.module, key);
                self.pipelines.push((key, pipeline));
                self.pipelines.len() - 1
            }
        }
    }

    /// The objects (`objects[i]` of [`Self::encode_with_maps`]) that gather `diffusion`'s
    /// lateral taps at each pixel although the frame reads them from the transmitted map (the
    /// plan's `taps_objects`: skin whose texels would be too coarse), with their pipeline
    /// built the first time. Ignored where the current variant reads no map.
    fn set_taps_objects(&mut self, device: &wgpu::Device, plan: &FramePlan) {
        let key = self.pipelines[self.current].0;
        self.taps = (key.lateral == lateral::MAP && plan.taps_objects.contains(&true)).then(|| {
            let taps = LightingVariant {
                lateral: plan.taps_objects_lateral,
                outline_pass: false,
                ..key
            };
            self.pipeline_index(device, taps)
        });
        self.taps_objects = plan.taps_objects.clone();
    }

    /// The lighting pass's draws: each object with the current pipeline, or its variant that
    /// gathers the taps itself where the plan marked the object.
    fn draw_lit_objects(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
    ) {
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        let mut bound = None;
        for (i, o) in objects.iter().enumerate() {
            let index = match self.taps {
                Some(taps) if self.taps_objects.get(i) == Some(&true) => taps,
                _ => self.current,
            };
            if bound != Some(index) {
                pass.set_pipeline(&self.pipelines[index].1);
                bound = Some(index);
            }
            pass.set_bind_group(2, maps.get(i).unwrap_or(&self.default_maps), &[]);
            o.draw(pass);
        }
    }

    /// The depth pre-pass into `zbuffer` (cleared), timed as `timed`: the nearest surface per
    /// pixel, for the [`util::DepthTest::Prepassed`] pipelines after it.
    fn encode_prepass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        zbuffer: &wgpu::TextureView,
        timed: &str,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, timed, encoder);
        {
            let mut pass = util::render_pass(
                encoder,
                "depth prepass",
                &[],
                util::depth_attachment(zbuffer, wgpu::LoadOp::Clear(1.0), wgpu::StoreOp::Store),
                timer.writes(),
            );
            util::draw_objects(
                &mut pass,
                &self.prepass,
                &self.frame_bind_group,
                objects,
                maps,
                &self.default_maps,
            );
        }
        timer.end(profiler, encoder);
    }

    /// The back faces' pass into `targets.back_faces` (cleared to 0: no back face), timed as
    /// "back faces".
    fn encode_back_faces(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let view = targets.back_faces.create_view(&Default::default());
        let timer = TimedPass::begin(profiler, "back faces", encoder);
        {
            let mut pass = util::render_pass(
                encoder,
                "back faces",
                &[util::color_attachment(
                    &view,
                    wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                )],
                util::depth_attachment(
                    &targets.back_zbuffer,
                    wgpu::LoadOp::Clear(1.0),
                    wgpu::StoreOp::Discard,
                ),
                timer.writes(),
            );
            util::draw_objects(
                &mut pass,
                &self.back_faces,
                &self.frame_bind_group,
                objects,
                maps,
                &self.default_maps,
            );
        }
        timer.end(profiler, encoder);
    }

    /// The transmitted map's passes where the plan has them, the depth pre-pass and the lighting
    /// pass into `targets`, with each object's texture-space bind group (`maps[i]` for
    /// `objects[i]`; objects beyond `maps` are lit plainly).
    #[allow(clippy::too_many_arguments)]
    pub fn encode_with_maps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        background: [f32; 3],
        far: f32,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        if let Some(map) = &targets.map
            && self.map.runs()
        {
            self.map.encode(
                encoder,
                map,
                &self.frame_bind_group,
                objects,
                maps,
                &self.default_maps,
                profiler,
            );
        }
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (diffuse, specular, depth, sss) = (
            view(&targets.diffuse),
            view(&targets.specular),
            view(&targets.depth),
            view(&targets.sss),
        );
        let attach = |v, c| util::color_attachment(v, wgpu::LoadOp::Clear(c));
        let bg = wgpu::Color {
            r: background[0] as f64,
            g: background[1] as f64,
            b: background[2] as f64,
            a: 1.0,
        };
        // Targets without them (made for another plan) hold a stand-in that reads as no back
        // face: the term then changes nothing rather than reading garbage.
        if self.thin_parts && targets.back_faces_on() {
            self.encode_back_faces(encoder, targets, objects, maps, profiler);
        }
        self.encode_prepass(
            encoder,
            &targets.zbuffer,
            "depth prepass",
            objects,
            maps,
            profiler,
        );
        let timer = TimedPass::begin(profiler, "lighting", encoder);
        {
            let mut pass = util::render_pass(
                encoder,
                "lighting",
                &[
                    attach(&diffuse, bg),
                    attach(&specular, wgpu::Color::TRANSPARENT),
                    attach(
                        &depth,
                        wgpu::Color {
                            r: far as f64,
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        },
                    ),
                    attach(&sss, wgpu::Color::TRANSPARENT),
                ],
                util::depth_attachment(
                    &targets.zbuffer,
                    wgpu::LoadOp::Load,
                    // The outline pass tests against it after this one.
                    if self.runs_outline() {
                        wgpu::StoreOp::Store
                    } else {
                        wgpu::StoreOp::Discard
                    },
                ),
                timer.writes(),
            );
            pass.set_bind_group(3, &targets.screen, &[]);
            self.draw_lit_objects(&mut pass, objects, maps);
        }
        timer.end(profiler, encoder);
        self.encode_outline(
            encoder,
            targets,
            [&diffuse, &specular],
            objects,
            maps,
            profiler,
        );
    }
}
