//! The skin passes in a renderer that is not ours.
//!
//! This program draws the default scene (the backlit hand and the wedge) with its own small
//! forward renderer: its own WGSL, vertex buffers, depth-only shadow maps, a thin G-buffer
//! pre-pass (normal, albedo) and a forward pass that writes diffuse and specular light apart.
//! Then it hands its textures to three of the library's passes:
//!
//! 1. [`ShadowEntryPass`]: the skin's shadow maps (light distance, entry normal) made from
//!    the program's own z-buffer shadow maps;
//! 2. [`TransmittedLightPass`]: light through thin parts, and the bounce from the lit surfaces
//!    around (gathered from a [`FluxPyramid`] of the skin's shadow maps where the settings'
//!    `bounce.ring` is above 0), added to the diffuse and specular targets;
//! 3. [`SssPass`]: the screen-space blur of the diffuse light, skin pixels only;
//!
//! and tone-maps with [`ToneMapPass`]. It writes `OUT_DIR/skin_in_your_renderer.png` and,
//! for comparison, `OUT_DIR/skin_in_your_renderer_without_skin.png` (the same frame without
//! the three passes).
//!
//! ```text
//! cargo run --release -p subsurface-render --example skin_in_your_renderer -- [OUT_DIR]
//! ```
//!
//! For brevity the program takes the scene, the materials' optics and the lights' matrices
//! from the library (`Scene`, `MaterialCache`, `light_setup`); an engine fills
//! `LightsUniform` and `ObjectUniform` from its own lights and materials. What the library
//! sees of the frame is only what the passes take as inputs.

use std::error::Error;
use std::path::PathBuf;

use glam::{Mat4, Vec3, Vec4};

use subsurface_render::gpu_scene::camera_uniform;
use subsurface_render::lights::light_setup;
use subsurface_render::material::{MaterialCache, ProfileTable};
use subsurface_render::passes::bounce::FluxPyramid;
use subsurface_render::passes::lighting::{self, ShadowMaps};
use subsurface_render::passes::shadow_entry::{EntryLayer, ShadowEntryPass};
use subsurface_render::passes::sss::{SssInputs, SssPass};
use subsurface_render::passes::tonemap::{self, ToneMapInputs, ToneMapPass};
use subsurface_render::passes::transmitted_light::{SkinGBuffer, TransmittedLightPass};
use subsurface_render::passes::{maps, util};
use subsurface_render::timing::{self, PassTiming, TimedPass};
use subsurface_render::uniforms::{CameraUniform, LightsUniform};
use subsurface_render::{DebugView, GpuContext, RenderError, RenderSettings, Scene, readback};

// The program's own uniform blocks, meshes and lights (a folder, so that Cargo does not take the
// file for an example of its own).
#[path = "skin_in_your_renderer/forward.rs"]
mod forward;
use forward::{ViewUniform, buffer, draw, uniform_group};

/// The program's own shaders: a depth-only shadow pass, a G-buffer pre-pass and a forward
/// pass (Lambert diffuse, a Beckmann specular lobe, 3x3 percentage-closer shadows).
const FORWARD_WGSL: &str = include_str!("skin_in_your_renderer.wgsl");

/// The settings the example's frame matches: the scene's own, with `diffusion`'s lateral
/// taps and the bounce gathered per pixel (the transmitted map is a lower-rate evaluation inside
/// our renderer), and without the diffusion source's shadow shift and the thin parts'
/// reflectance (terms of our lighting pass's reflected light, which a caller's forward pass
/// computes its own way).
pub fn example_settings(scene: &Scene, width: u32, height: u32) -> RenderSettings {
    let mut s = scene.desc.render.clone();
    s.width = width;
    s.height = height;
    s.transmitted_map.texel_mm = 0.0;
    s.sss.source_shift = false;
    s.sss.thin_parts = false;
    s
}

/// Renders `scene` at `settings`' size; with `skin`, through the library's skin passes.
pub fn render(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    skin: bool,
) -> Result<(image::RgbaImage, Vec<PassTiming>), RenderError> {
    let device = &ctx.device;
    let (width, height) = (settings.width, settings.height);
    let camera: CameraUniform = camera_uniform(scene, width, height);
    let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
    let setup = light_setup(scene, settings)?;
    let mut lights_uniform: LightsUniform = setup.uniform;
    // No transmitted map: the skin passes below run their taps and the bounce's gather per pixel.
    lights_uniform.map_downsample = 1;
    lights_uniform.bounce_ring = settings.bounce.ring;

    // The program's own materials and meshes.
    let mut cache = MaterialCache::default();
    let profiles = ProfileTable::for_scene(scene, settings.sss.samples, &mut cache)?;
    let module = util::wgsl_module(device, "forward", FORWARD_WGSL);
    let uniform_entry = |b, stages| util::uniform_entry(b, stages);
    let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material"),
        entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
    });
    let (meshes, media) =
        forward::upload_objects(ctx, scene, &profiles, &mut cache, &material_layout)?;

    // The program's own shadow maps: a z-buffer per light, drawn with the lights' matrices.
    let atlas = setup.atlas_size;
    let layer_count = setup.layers.len().max(1) as u32;
    let shadow_depth = util::texture_2d(
        device,
        "shadow maps",
        atlas,
        atlas,
        layer_count,
        wgpu::TextureFormat::Depth32Float,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let shadow_array = util::array_view(&shadow_depth);
    let lights = forward::lights_data(&lights_uniform, &setup, settings.ambient);
    let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("view"),
        entries: &[
            uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
            uniform_entry(1, wgpu::ShaderStages::FRAGMENT),
            util::depth_array_entry(2, wgpu::ShaderStages::FRAGMENT),
            util::sampler_entry(
                3,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::SamplerBindingType::Comparison,
            ),
        ],
    });
    let shadow_view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("shadow view"),
        entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX)],
    });
    let lights_buffer = buffer(
        device,
        "lights",
        bytemuck::bytes_of(&lights),
        wgpu::BufferUsages::UNIFORM,
    );
    let compare = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("shadow compare"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        compare: Some(wgpu::CompareFunction::LessEqual),
        ..Default::default()
    });
    let view_data = ViewUniform {
        view_proj: camera.view_proj,
        position: Vec3::from(camera.position).extend(1.0),
        forward: Vec3::from(camera.forward).extend(0.0),
    };
    let view_buffer = buffer(
        device,
        "view",
        bytemuck::bytes_of(&view_data),
        wgpu::BufferUsages::UNIFORM,
    );
    let view_group = util::bind_group(
        device,
        "view",
        &view_layout,
        [
            (0, view_buffer.as_entire_binding()),
            (1, lights_buffer.as_entire_binding()),
            (2, wgpu::BindingResource::TextureView(&shadow_array)),
            (3, wgpu::BindingResource::Sampler(&compare)),
        ],
    );

    let vertex_layout = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<subsurface_render::mesh::Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
    };
    let depth_state = |compare| {
        Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        })
    };
    let pipeline = |label,
                    layout: &wgpu::PipelineLayout,
                    vertex,
                    fragment: Option<&str>,
                    targets: &[Option<wgpu::ColorTargetState>],
                    compare| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vertex),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout.clone())],
            },
            primitive: Default::default(),
            depth_stencil: depth_state(compare),
            multisample: Default::default(),
            fragment: fragment.map(|f| wgpu::FragmentState {
                module: &module,
                entry_point: Some(f),
                compilation_options: Default::default(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let shadow_layout =
        util::pipeline_layout(device, "shadow", &[&shadow_view_layout, &material_layout]);
    let forward_layout =
        util::pipeline_layout(device, "forward", &[&view_layout, &material_layout]);
    let shadow_pipeline = pipeline(
        "shadow",
        &shadow_layout,
        "vs_shadow",
        None,
        &[],
        wgpu::CompareFunction::Less,
    );
    let f16 = wgpu::TextureFormat::Rgba16Float;
    let gbuffer_pipeline = pipeline(
        "g-buffer",
        &forward_layout,
        "vs_main",
        Some("fs_gbuffer"),
        &[Some(f16.into()), Some(f16.into())],
        wgpu::CompareFunction::Less,
    );
    let forward_targets = [f16, f16, wgpu::TextureFormat::R32Float, f16].map(|f| Some(f.into()));
    let forward_pipeline = pipeline(
        "forward",
        &forward_layout,
        "vs_main",
        Some("fs_forward"),
        &forward_targets,
        wgpu::CompareFunction::Equal,
    );

    // The frame's targets.
    let target = |label, format| util::render_target(device, label, width, height, format);
    let diffuse = target("diffuse", f16);
    let specular = target("specular", f16);
    let depth = target("linear depth", wgpu::TextureFormat::R32Float);
    let sss = target("sss", f16);
    let normal = target("normal", f16);
    let albedo = target("albedo", f16);
    let zbuffer = util::texture_2d(
        device,
        "zbuffer",
        width,
        height,
        1,
        wgpu::TextureFormat::Depth32Float,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let tv = |t: &wgpu::Texture| t.create_view(&Default::default());
    let views = [&diffuse, &specular, &depth, &sss, &normal, &albedo].map(tv);
    let zview = tv(&zbuffer);

    // GPU time per pass: ours (`shadow`, `g-buffer`, `forward`) and the library's.
    let mut profiler = timing::new_profiler(device)?;
    let mut encoder = device.create_command_encoder(&Default::default());
    let p = Some(&profiler);
    for (i, layer) in setup.layers.iter().enumerate() {
        let data = ViewUniform {
            view_proj: layer.view_proj.to_cols_array_2d(),
            position: Vec4::ZERO,
            forward: Vec4::ZERO,
        };
        let group = uniform_group(
            device,
            "shadow view",
            &shadow_view_layout,
            bytemuck::bytes_of(&data),
        );
        let target = util::layer_view(&shadow_depth, i as u32);
        let timer = TimedPass::begin(p, "shadow", &mut encoder);
        let clear = wgpu::LoadOp::Clear(1.0);
        let mut pass = util::depth_pass(&mut encoder, "shadow", &target, clear, timer.writes());
        pass.set_viewport(0.0, 0.0, layer.size as f32, layer.size as f32, 0.0, 1.0);
        pass.set_scissor_rect(0, 0, layer.size, layer.size);
        pass.set_pipeline(&shadow_pipeline);
        pass.set_bind_group(0, &group, &[]);
        draw(&mut pass, &meshes);
        drop(pass);
        timer.end(p, &mut encoder);
    }
    let bg = settings.background;
    let clear = |r: f32, g: f32, b: f32| {
        wgpu::LoadOp::Clear(wgpu::Color {
            r: r.into(),
            g: g.into(),
            b: b.into(),
            a: 1.0,
        })
    };
    // The g-buffer, then the forward pass on its z-buffer: the objects drawn with the view's
    // group, into `colors` and the z-buffer, loaded and stored as `z`.
    let draw_objects = |encoder: &mut wgpu::CommandEncoder,
                        label: &str,
                        colors: &[Option<wgpu::RenderPassColorAttachment<'_>>],
                        z: wgpu::Operations<f32>,
                        pipeline: &wgpu::RenderPipeline| {
        let timer = TimedPass::begin(p, label, encoder);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: colors,
            depth_stencil_attachment: util::depth_attachment(&zview, z.load, z.store),
            timestamp_writes: timer.writes(),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &view_group, &[]);
        draw(&mut pass, &meshes);
        drop(pass);
        timer.end(p, encoder);
    };
    let black = || clear(0.0, 0.0, 0.0);
    draw_objects(
        &mut encoder,
        "g-buffer",
        &[
            util::color_attachment(&views[4], black()),
            util::color_attachment(&views[5], black()),
        ],
        wgpu::Operations {
            load: wgpu::LoadOp::Clear(1.0),
            store: wgpu::StoreOp::Store,
        },
        &gbuffer_pipeline,
    );
    let far = scene.desc.camera.far;
    draw_objects(
        &mut encoder,
        "forward",
        &[
            util::color_attachment(&views[0], clear(bg[0], bg[1], bg[2])),
            util::color_attachment(&views[1], black()),
            util::color_attachment(&views[2], clear(far, 0.0, 0.0)),
            util::color_attachment(&views[3], wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)),
        ],
        wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Discard,
        },
        &forward_pipeline,
    );

    // The library's passes, on the program's textures. They are built here each frame for a
    // short program; an application builds them once and re-encodes them every frame.
    let entry_layers: Vec<EntryLayer> = setup
        .layers
        .iter()
        .map(|l| {
            let light = &lights_uniform.lights[l.light];
            EntryLayer {
                view_proj: l.view_proj,
                kind: light.kind,
                origin: l.origin,
                direction: Vec3::from(light.direction),
                size: l.size,
            }
        })
        .collect();
    let transmitted = TransmittedLightPass::new(device, settings);
    let mut blur = SssPass::new(device, &settings.sss, &profiles.kernels)?;
    let entry = ShadowEntryPass::new(device, &shadow_array, atlas, &entry_layers);
    let uniform = |bytes: &[u8]| buffer(device, "skin uniform", bytes, wgpu::BufferUsages::UNIFORM);
    let (camera_buffer, skin_lights) = (
        uniform(bytemuck::bytes_of(&camera)),
        uniform(bytemuck::bytes_of(&lights_uniform)),
    );
    let tsm = maps::dummy_tsm_view(device);
    // The bounce's senders: every texel of the skin's shadow maps (a reflective shadow map).
    let flux = settings.bounce.enabled().then(|| {
        FluxPyramid::new(
            ctx,
            entry.atlas_view(),
            &setup.layers,
            atlas,
            &lights_uniform,
        )
    });
    let shadow = ShadowMaps {
        atlas: entry.atlas_view(),
        depth: &shadow_array,
        flux: flux
            .as_ref()
            .map(|f| [&f.position_view, &f.normal_view, &f.spread_view]),
    };
    let frame = lighting::frame_bind_group(
        device,
        transmitted.frame_layout(),
        [&camera_buffer, &skin_lights],
        shadow,
        &tsm,
    );
    let gbuffer = SkinGBuffer {
        depth: &views[2],
        normal: &views[4],
        albedo: &views[5],
        medium: &views[3],
    };
    let gbuffer = transmitted.bind_gbuffer(device, &gbuffer, view_proj);
    if skin {
        entry.encode(&mut encoder, p);
        if let Some(flux) = &flux {
            flux.encode(&mut encoder, p);
        }
        transmitted.encode(
            &mut encoder,
            &frame,
            &gbuffer.bind_group,
            &media,
            [&views[0], &views[1]],
            p,
        );
        blur.resize(
            device,
            &SssInputs {
                diffuse: &diffuse,
                depth: &views[2],
                sss: &views[3],
            },
        );
        blur.prepare(&ctx.queue, camera.focal_px);
        blur.encode(&mut encoder, p);
    }

    // Tone mapping into an sRGB image.
    let output = util::texture_2d(
        device,
        "output",
        width,
        height,
        1,
        tonemap::OUTPUT_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let tone = ToneMapPass::new(device, tonemap::OUTPUT_FORMAT);
    tone.set_params(
        &ctx.queue,
        settings.exposure_ev,
        DebugView::Final,
        scene.desc.camera.far,
    );
    let inputs = ToneMapInputs {
        diffuse: &views[0],
        specular: &views[1],
        depth: &views[2],
        sss: &views[3],
    };
    tone.encode(&mut encoder, &tone.bind(device, &inputs), &tv(&output), p);
    profiler.resolve_queries(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    ctx.check()?;
    let image = readback::read_rgba8(ctx, &output)?;
    profiler
        .end_frame()
        .map_err(|e| RenderError::Validation(format!("profiler: {e}")))?;
    let _ = device.poll(wgpu::PollType::wait_indefinitely());
    let results = profiler.process_finished_frame(ctx.queue.get_timestamp_period());
    Ok((
        image,
        results.map_or_else(Vec::new, |r| timing::collect(&r)),
    ))
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn Error>> {
    let out_dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&out_dir)?;
    let ctx = GpuContext::new_headless()?;
    println!("adapter: {}", ctx.adapter_name());
    let scene = Scene::default_scene();
    let settings = example_settings(&scene, scene.desc.render.width, scene.desc.render.height);
    for (skin, name) in [
        (true, "skin_in_your_renderer.png"),
        (false, "skin_in_your_renderer_without_skin.png"),
    ] {
        let (image, timings) = render(&ctx, &scene, &settings, skin)?;
        let path = out_dir.join(name);
        image.save(&path)?;
        let passes: Vec<String> = timings
            .iter()
            .map(|t| format!("{} {:.2} ms", t.name, t.ms))
            .collect();
        println!("wrote {} (GPU: {})", path.display(), passes.join(", "));
    }
    Ok(())
}
