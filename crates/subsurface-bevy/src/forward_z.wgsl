// One of the transmittance step's own passes (transmit.rs). Preceded by subsurface_render's
// fullscreen.wgsl (vs_fullscreen, FullscreenOut).

// fs_forward_z: one layer of Bevy's directional shadow maps into a layer of ours, as
// subsurface-render's shadow entry pass and shadow lookups read z-buffers: depth 0 near,
// 1 far, cleared to 1. Bevy's are reverse-Z (near 1, cleared to 0), and a cascade draws the
// casters in front of its near plane clamped to 1 ("pancaking"): those texels hold no
// position, so they become empty too, rather than a surface on the near plane.
struct CopyLayer {
    // x: the layer of Bevy's texture; yzw unused (a uniform block is 16 bytes).
    layer: vec4<i32>,
};

@group(0) @binding(0) var bevy_depth: texture_depth_2d_array;
@group(0) @binding(1) var<uniform> copy_layer: CopyLayer;

@fragment
fn fs_forward_z(in: FullscreenOut) -> @builtin(frag_depth) f32 {
    let d = textureLoad(bevy_depth, vec2<i32>(in.clip.xy), copy_layer.layer.x, 0);
    if (d <= 0.0 || d >= 1.0) {
        return 1.0;
    }
    return 1.0 - d;
}

// fs_forward_z_view: the same from a one-layer view (a spot light's map, which Bevy places
// after every camera's cascades). Its infinite perspective is reverse-Z too (d = near /
// depth, cleared to 0), so 1 - d is the forward-Z depth of forward_z's matrix as well.
@group(0) @binding(2) var bevy_view_depth: texture_depth_2d;

@fragment
fn fs_forward_z_view(in: FullscreenOut) -> @builtin(frag_depth) f32 {
    let d = textureLoad(bevy_view_depth, vec2<i32>(in.clip.xy), 0);
    if (d <= 0.0 || d >= 1.0) {
        return 1.0;
    }
    return 1.0 - d;
}
