// Group 0 of the lighting shader's pipelines (lighting/mod.rs, `frame_layout`): what every
// object of the frame is lit with. Prepended to the lighting pass, the transmitted map's passes,
// the texture-space irradiance and the transmitted light pass.

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<uniform> lights: Lights;
// Linear light distance and the entry normal per texel (shadow.rs, or shadow_entry/ from a
// caller's z-buffer): thickness and where transmitted light enters.
@group(0) @binding(2) var shadow_atlas: texture_2d_array<f32>;
// Translucent shadow maps: the (u, v) of the surface nearest each light, one layer per shadow
// layer (-1 where nothing was drawn).
@group(0) @binding(3) var tsm_atlas: texture_2d_array<f32>;
// The shadow maps' z-buffer, for percentage-closer filtering in the texture unit.
@group(0) @binding(4) var shadow_depth: texture_depth_2d_array;
@group(0) @binding(5) var shadow_compare: sampler_comparison;
// The flux pyramid (bounce.rs, bounce_build.wgsl). Per cell: rgb = sum of flux x position,
// a = the flux (per unit of the light's colour: spot falloff x the texel's solid angle, or its
// area across a directional beam).
@group(0) @binding(6) var flux_position: texture_2d_array<f32>;
// rgb = sum of flux x normal (a cell's cosines toward a direction add up linearly while none
// is negative), a = sum of flux over the cosine of incidence (what its boundary reflects).
@group(0) @binding(7) var flux_normal: texture_2d_array<f32>;
// r = sum of flux x squared distance from the light's origin (`position` of its uniform).
@group(0) @binding(8) var flux_spread: texture_2d_array<f32>;
