// The outline pass's mark: a full-screen triangle over the lighting pass's SSS target whose
// `a` is 1 where the lighting pass left each light's chord to the outline pass; the stencil
// marks those pixels, and the pixels left go before the stencil test (outline.rs).

@group(0) @binding(0) var sss_target: texture_2d<f32>;

struct MarkOut {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
};

// Adds nothing to the targets the pass's draws share; the stencil is its output.
@fragment
fn fs_outline_mark(@builtin(position) p: vec4<f32>) -> MarkOut {
    if (textureLoad(sss_target, vec2<i32>(p.xy), 0).a < 0.5) {
        discard;
    }
    return MarkOut(vec4<f32>(0.0), vec4<f32>(0.0));
}
