// A plain full-screen copy of one float texture into another: the baseline that benchmarks
// compare SSS passes with (same targets, same resolution, the cheapest possible pass).

@group(0) @binding(0) var source: texture_2d<f32>;

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let clip = in.clip;
    return textureLoad(source, vec2<i32>(clip.xy), 0);
}
