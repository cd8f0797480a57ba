// Translucent shadow maps: appended to common.wgsl and bindings/object.wgsl (`object`, `VertexIn`). Each shadow layer
// is rendered a second time storing the (u, v) of the surface nearest the light.

struct TsmView {
    view_proj: mat4x4<f32>,
};

@group(0) @binding(14) var<uniform> tsm_view: TsmView;

struct TsmOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_tsm(v: VertexIn) -> TsmOut {
    var out: TsmOut;
    out.clip = tsm_view.view_proj * world_position(v);
    out.uv = v.uv;
    return out;
}

// The (u, v) of the surface nearest the light, beside the standard map's linear distance.
@fragment
fn fs_tsm(in: TsmOut) -> @location(0) vec2<f32> {
    return in.uv;
}
