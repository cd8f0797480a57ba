// The ids the Rust side and the shaders share (passes/overrides.rs; the values are checked
// against the Rust enums and constants by overrides::tests). Prepended to every shader built on
// the lighting shader.

// TransmittanceMethod::code: the TRANSMITTANCE_METHOD override and Lights.transmittance.
const TRANSMITTANCE_OFF: u32 = 0u;
const TRANSMITTANCE_PAPER: u32 = 1u;
const TRANSMITTANCE_BEER: u32 = 2u;
const TRANSMITTANCE_SEED_REPORT: u32 = 3u;
const TRANSMITTANCE_TSM: u32 = 4u;
const TRANSMITTANCE_DIFFUSION: u32 = 5u;

// An override left at this value follows the uniform at run time (the texture-space pass, one
// pipeline for every frame shape).
const FOLLOW_UNIFORM: u32 = 255u;

// LATERAL_SOURCE (overrides::lateral): where `diffusion` takes its lateral light from.
const LATERAL_NONE: u32 = 0u;
const LATERAL_MAP: u32 = 1u;
const LATERAL_TAPS: u32 = 2u;
const LATERAL_GIVEN: u32 = 3u;

// BOUNCE_SOURCE (overrides::bounce): where a pixel takes the bounce from.
const BOUNCE_NONE: u32 = 0u;
const BOUNCE_MAP: u32 = 1u;
const BOUNCE_GATHER: u32 = 2u;

// DIFFUSION_TERMS bits (overrides::Terms).
const TERM_BALLISTIC: u32 = 1u;
const TERM_SINGLE_SCATTERING: u32 = 2u;
const TERM_SOURCE_SHIFT: u32 = 4u;
const TERM_THIN_PARTS: u32 = 8u;
const TERM_SIDE_WALLS: u32 = 16u;
const TERM_LIT_SIDE: u32 = 32u;
