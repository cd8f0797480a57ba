//! CPU reference ("oracle") implementations of every image pass: the GPU shaders are written
//! to match these, and the GPU tests compare against them.
//!
//! * [`screen`]: the screen-space blurs (six Gaussians, Separable SSS, Hable's 13 taps), with
//!   a profile per pixel.
//! * [`texture`]: the texture-space (UV) blur of d'Eon et al. 2007.
//! * [`bounce`]: the flux pyramid of the shadow maps and the light between parts gathered
//!   from it.
//! * [`transmitted`]: the light `diffusion` sends through a slab toward the camera.

pub mod bounce;
pub mod screen;
pub mod texture;
pub mod transmitted;

pub use screen::*;
