// The outline pass: each light's chord (`transmittance`, without taps) at the pixels where the
// transmitted map holds no texel of the pixel's surface (an outline, a depth edge), drawn after
// the lighting pass over the skin with the same vertex stage and z-buffer and added to its
// targets. The lighting pass, built with OUTLINE_PASS, added no transmitted light there: this
// pass adds the larger of the chords' sum and the diffuse light of the nearest texel in depth,
// as shade() inline keeps it. The same image as the chords inline, without their code, or the
// nearest texel's search, in the lighting pass's shader
// (frame_plan::LightingVariant::outline_pass).
//
// The lighting pass marks those pixels in its SSS target's `a`; a full-screen draw
// (outline_mark.wgsl) copies the mark into the z-buffer's stencil, and fs_outline draws the
// skin behind the stencil test. A shader that leaves with `discard` still runs its whole code
// on a CPU rasteriser (llvmpipe masks the pixels out rather than jumping), but a block of
// pixels that fails the stencil test before the shader runs none of it.

struct OutlineOut {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
};

@fragment
fn fs_outline(in: LitVarying, @builtin(front_facing) front: bool) -> OutlineOut {
    let n_vertex = select(-1.0, 1.0, front) * normalize(in.normal);
    let depth = dot(in.world - camera.position, camera.forward);
    var screen = ScreenSample(in.clip.xy, depth, vec2<f32>(dpdx(depth), dpdy(depth)), 0u);
    var albedo = object.albedo;
    if (object.has_albedo_map != 0u) {
        albedo *= textureSample(albedo_map, material_sampler, in.uv).rgb;
    }
    let v = normalize(camera.position - in.world);
    var diffuse = vec3<f32>(0.0);
    var specular = vec3<f32>(0.0);
    let count = min(lights.count, MAX_LIGHTS);
    for (var i = 0u; i < count; i++) {
        let light = lights.lights[i];
        let l = light_direction(light.kind, light.position, light.direction, in.world);
        let radiance = light_radiance(light, in.world, l);
        if (all(radiance <= vec3<f32>(0.0))) {
            continue;
        }
        let shadow = shadow_factor(light, in.world);
        screen.lit = lit_code(screen.lit, i, dot(n_vertex, l), shadow);
        let t = transmittance(light, in.world, n_vertex, l, v, shadow);
        diffuse += radiance * t.diffuse;
        specular += radiance * t.ballistic;
    }
    let nearest = nearest_texel_light(screen);
    var out: OutlineOut;
    let transmitted = albedo * max(diffuse, nearest);
    out.diffuse = vec4<f32>(min(transmitted, vec3<f32>(HALF_MAX)), 0.0);
    out.specular = vec4<f32>(min(specular, vec3<f32>(HALF_MAX)), 0.0);
    return out;
}
