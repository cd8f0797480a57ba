// One triangle that covers the viewport (no vertex buffer): the vertex stage of every image
// pass (SSS, tone map, copy), prepended to their WGSL by passes/fullscreen.rs.

struct FullscreenOut {
    @builtin(position) clip: vec4<f32>,
};

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> FullscreenOut {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var out: FullscreenOut;
    out.clip = vec4<f32>(p * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
    return out;
}
