//! The shadow entry pass (passes::shadow_entry) on a caller's z-buffer: the distance it writes
//! follows the layer's matrix, `set_layers` moves a layer as a new pass would, and
//! `set_region` writes only its texels.

use crate::common;

use glam::{Mat4, Vec3};
use subsurface_render::passes::shadow_entry::{EntryLayer, ShadowEntryPass};
use subsurface_render::passes::util;
use subsurface_render::{GpuContext, readback};

const SIZE: u32 = 8;

/// A directional light at `origin` looking down -z through an orthographic box 2 wide and
/// `depth` deep: a texel's depth z lies at distance z * depth from the origin.
fn layer(origin: Vec3, depth: f32) -> EntryLayer {
    let view = Mat4::look_at_rh(origin, origin + Vec3::NEG_Z, Vec3::Y);
    EntryLayer {
        view_proj: Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.0, depth) * view,
        kind: 2.0,
        origin,
        direction: Vec3::NEG_Z,
        size: SIZE,
    }
}

/// The distance channel of the pass's atlas over a z-buffer cleared to 0.5.
fn distances(ctx: &GpuContext, pass: &ShadowEntryPass, depth: &wgpu::Texture) -> Vec<f32> {
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let view = util::layer_view(depth, 0);
        let clear = wgpu::LoadOp::Clear(0.5);
        util::depth_pass(&mut encoder, "caller's shadow map", &view, clear, None);
    }
    pass.encode(&mut encoder, None);
    ctx.queue.submit([encoder.finish()]);
    ctx.check().unwrap();
    let (texels, channels) = readback::read_float(ctx, pass.atlas()).unwrap();
    texels.chunks(channels).map(|t| t[0]).collect()
}

/// The caller's one-layer `Depth32Float` shadow map and its array view.
fn callers_shadow_map(ctx: &GpuContext) -> (wgpu::Texture, wgpu::TextureView) {
    let depth = util::texture_2d(
        &ctx.device,
        "caller's shadow map",
        SIZE,
        SIZE,
        1,
        wgpu::TextureFormat::Depth32Float,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let array = util::array_view(&depth);
    (depth, array)
}

#[test]
fn distances_follow_the_layer_and_set_layers_moves_it() {
    let Some(ctx) = common::context() else { return };
    let (depth, array) = callers_shadow_map(&ctx);
    let (near, far) = (layer(Vec3::ZERO, 2.0), layer(Vec3::new(0.0, 0.0, 3.0), 8.0));
    let fresh = distances(
        &ctx,
        &ShadowEntryPass::new(&ctx.device, &array, SIZE, &[far]),
        &depth,
    );
    let mut moved = ShadowEntryPass::new(&ctx.device, &array, SIZE, &[near]);
    let before = distances(&ctx, &moved, &depth);
    moved.set_layers(&ctx.queue, &[far]);
    let after = distances(&ctx, &moved, &depth);
    // z = 0.5 of a box 2 deep is 1 from its origin; of a box 8 deep, 4.
    for (name, values, want) in [("before", &before, 1.0), ("after", &after, 4.0)] {
        for v in values.iter() {
            assert!((v - want).abs() < 1e-4, "{name}: distance {v}, want {want}");
        }
    }
    assert_eq!(after, fresh, "set_layers gives the fresh pass's maps");
}

#[test]
fn set_region_writes_its_texels_only() {
    let Some(ctx) = common::context() else { return };
    let (depth, array) = callers_shadow_map(&ctx);
    let mut pass = ShadowEntryPass::new(&ctx.device, &array, SIZE, &[layer(Vec3::ZERO, 2.0)]);
    // Reaching past the layer's edge: clipped to x 6..8, y 3..5.
    pass.set_region(0, Some([6, 3, 5, 2]));
    let values = distances(&ctx, &pass, &depth);
    for (i, v) in values.iter().enumerate() {
        let (x, y) = (i as u32 % SIZE, i as u32 / SIZE);
        let inside = (6..8).contains(&x) && (3..5).contains(&y);
        let want = if inside { 1.0 } else { f32::MAX };
        assert!(
            (v - want).abs() < 1e-4,
            "texel ({x}, {y}): {v}, want {want}"
        );
    }
    pass.set_region(0, None);
    assert!(
        distances(&ctx, &pass, &depth)
            .iter()
            .all(|v| (v - 1.0).abs() < 1e-4)
    );
}
