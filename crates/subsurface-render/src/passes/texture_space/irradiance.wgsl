// Texture-space diffusion (d'Eon et al.), step 1: the irradiance in UV space. Appended to
// common.wgsl, lighting.wgsl and transmittance.wgsl, so the UV-space irradiance uses the very
// same lights, shadows and transmittance as the lighting pass (and the same bind groups).

// The mesh laid out by its texture coordinates: texel (x, y) of the map holds the surface at
// uv = ((x, y) + 0.5) / size, so the map is sampled with the mesh's own uv.
@vertex
fn vs_irradiance(v: VertexIn) -> LitVarying {
    var out: LitVarying;
    out.world = world_position(v).xyz;
    out.clip = vec4<f32>(v.uv.x * 2.0 - 1.0, 1.0 - v.uv.y * 2.0, 0.0, 1.0);
    out.normal = world_normal(v);
    out.tangent = world_tangent(v);
    out.uv = v.uv;
    return out;
}

struct IrradianceOut {
    // rgb = albedo^pre x (irradiance + ambient + transmitted light), a = 1 (texel covered)
    @location(0) irradiance: vec4<f32>,
    // profile millimetres per texel along u and along v (the inverse of d'Eon's stretch)
    @location(1) stretch: vec2<f32>,
};

@fragment
fn fs_irradiance(in: LitVarying) -> IrradianceOut {
    // Screen derivatives here are derivatives per texel of the map: the surface's size of one
    // texel along u and along v, in profile millimetres (scene units per mm include the
    // material's sss_width; the SSS strength widens the profile as in screen space).
    let mm = object.world_per_mm * max(object.sss_strength, 1e-6);
    let stretch = vec2<f32>(length(dpdx(in.world)), length(dpdy(in.world))) / mm;
    // No front or back here: the normal is the mesh's own.
    let n_vertex = normalize(in.normal);
    let n = shading_normal(in, n_vertex);
    var albedo = object.albedo;
    if (object.has_albedo_map != 0u) {
        albedo *= textureSample(albedo_map, material_sampler, in.uv).rgb;
    }
    // Texels of a UV map are no pixels of the transmitted map: the taps run here.
    let screen = ScreenSample(vec2<f32>(0.0), 0.0, vec2<f32>(0.0), 0u);
    let s = shade(in.world, n, n_vertex, n_vertex, 1.0, 0.0, false, screen);
    var out: IrradianceOut;
    let pre = albedo_power(albedo, texture_space.params.z);
    out.irradiance = vec4<f32>(pre * (s.irradiance + lights.ambient + s.transmitted), 1.0);
    out.stretch = stretch;
    return out;
}
