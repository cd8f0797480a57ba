// One of the transmittance step's own passes (transmit.rs). Preceded by subsurface_render's
// fullscreen.wgsl (vs_fullscreen, FullscreenOut).

// fs_add: the transmitted light's unscattered part, kept aside while the blur ran, added
// onto the main texture (the blend adds; alpha is kept). Pixels that got none are left
// untouched.
@group(0) @binding(0) var unscattered: texture_2d<f32>;

@fragment
fn fs_add(in: FullscreenOut) -> @location(0) vec4<f32> {
    let c = textureLoad(unscattered, vec2<i32>(in.clip.xy), 0);
    if (all(c.rgb == vec3<f32>(0.0))) {
        discard;
    }
    return vec4<f32>(c.rgb, 0.0);
}
