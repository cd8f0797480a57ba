// A plain full-screen copy of one float texture into another: the baseline that benchmarks
// compare SSS passes with (same targets, same resolution, the cheapest possible pass).

@group(0) @binding(0) var source: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) clip: vec4<f32>) -> @location(0) vec4<f32> {
    return textureLoad(source, vec2<i32>(clip.xy), 0);
}
