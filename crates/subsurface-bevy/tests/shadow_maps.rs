//! What docs/lab/bevy.md (c) says about Bevy's directional shadow maps, checked on a real
//! frame, for the transmittance pass that will read them: in the render world a camera's
//! `ViewLightEntities` lists its cascades in layer order of
//! `ViewShadowBindings::directional_light_depth_texture`, each with its `ExtractedView`
//! (`clip_from_world`); the maps are reverse-Z (the texel nearest the light holds the largest
//! depth) and `Depth32Float` with texture usage, so our passes can bind them.

use crate::common;

use bevy::pbr::{LightEntity, ViewLightEntities, ViewShadowBindings};
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::view::ExtractedView;
use common::*;
use subsurface_render::passes::fullscreen;

/// Layer `layer` of a depth array texture, as f32 texels (a depth texture cannot be copied
/// without COPY_SRC usage, which Bevy's shadow maps lack: a pass copies it to R32Float).
fn read_depth_layer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    depth: &wgpu::Texture,
    layer: u32,
) -> Vec<f32> {
    let size = depth.width();
    let source = format!(
        "{}@group(0) @binding(0) var depth: texture_depth_2d_array;\n\
         @fragment fn fs_copy(in: FullscreenOut) -> @location(0) f32 {{\n\
             return textureLoad(depth, vec2<i32>(in.clip.xy), {layer}, 0);\n\
         }}\n",
        fullscreen::VERTEX_WGSL
    );
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("copy depth"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = fullscreen::pipeline(
        device,
        &module,
        None,
        "fs_copy",
        &[Some(wgpu::TextureFormat::R32Float.into())],
    );
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("depth copy"),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let depth_view = depth.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        aspect: wgpu::TextureAspect::DepthOnly,
        ..Default::default()
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&depth_view),
        }],
    });
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (size * size * 4) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let view = target.create_view(&Default::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: None,
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
    // Rows of 4 * size bytes: a multiple of 256 for the power-of-two map sizes Bevy uses.
    encoder.copy_texture_to_buffer(
        target.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * size),
                rows_per_image: None,
            },
        },
        target.size(),
    );
    queue.submit([encoder.finish()]);
    buffer.map_async(wgpu::MapMode::Read, .., |r| r.expect("map"));
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
    let data = buffer.get_mapped_range(..).expect("mapped").to_vec();
    bytemuck::cast_slice::<u8, f32>(&data).to_vec()
}

#[test]
fn directional_cascades_are_reverse_z_layers_in_view_order() {
    if !gpu_available() {
        return;
    }
    let mut h = setup(app(), ());
    let m = add_asset(&mut h.app, StandardMaterial::default());
    render_scene(&mut h, MeshMaterial3d(m));

    let world = h.app.sub_app_mut(RenderApp).world_mut();
    let device = world.resource::<RenderDevice>().wgpu_device().clone();
    let queue: wgpu::Queue = (**world.resource::<RenderQueue>()).clone();
    let mut views = world.query::<(&ViewLightEntities, &ViewShadowBindings)>();
    let (lights, bindings) = views.single(world).expect("one camera with shadow views");
    let cascades = lights.lights.clone();
    let texture: wgpu::Texture = (*bindings.directional_light_depth_texture).clone();
    assert_eq!(texture.format(), wgpu::TextureFormat::Depth32Float);
    assert!(
        texture
            .usage()
            .contains(wgpu::TextureUsages::TEXTURE_BINDING)
    );
    assert!(!cascades.is_empty());
    assert!(texture.depth_or_array_layers() as usize >= cascades.len());

    // The light travels along (0.5, -4, -1) (common::spawn_scene): the point of the unit
    // sphere nearest the light is -normalize(0.5, -4, -1).
    let nearest = -Vec3::new(0.5, -4.0, -1.0).normalize();
    let mut hits = 0;
    for (layer, &entity) in cascades.iter().enumerate() {
        let mut q = world.query::<(&LightEntity, &ExtractedView)>();
        let (light, view) = q.get(world, entity).expect("cascade view");
        let LightEntity::Directional { cascade_index, .. } = *light else {
            panic!("a camera's shadow views are its directional cascades");
        };
        assert_eq!(cascade_index, layer, "cascades listed in layer order");
        let clip_from_world = view.clip_from_world.expect("cascades carry their matrix");
        let depth = read_depth_layer(&device, &queue, &texture, layer as u32);
        let size = texture.width() as usize;
        let (i, &d) = depth
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
        let ndc = Vec3::new(2.0 * x / size as f32 - 1.0, 1.0 - 2.0 * y / size as f32, d);
        let p = clip_from_world.inverse().project_point3(ndc);
        eprintln!(
            "cascade {layer}: largest depth {d} at texel ({x}, {y}) = world {p}, {} from \
             the sphere's point nearest the light",
            p.distance(nearest)
        );
        assert!(d > 0.0 && d <= 1.0);
        // Depth 1 is a caster in front of the cascade's near plane, clamped there (Bevy
        // draws directional shadows with unclipped depth): no position can be read back.
        if d == 1.0 {
            continue;
        }
        // Otherwise the largest depth is the surface nearest the light (reverse-Z), and this
        // layer's own matrix puts it on the sphere's top, within the shadow pass's depth
        // and normal biases (a few centimetres here).
        assert!(
            p.distance(nearest) < 0.05,
            "cascade {layer}: nearest texel at {p}, not on the sphere's top {nearest}"
        );
        hits += 1;
    }
    assert!(hits > 0, "every cascade clamped");
}
