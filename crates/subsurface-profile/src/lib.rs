//! Diffusion profiles for real-time subsurface scattering of skin, without a GPU.
//!
//! * [`gaussian`] / [`SumOfGaussians`]: `G(v, r)` and d'Eon's six-Gaussian skin
//!   profile, with the transmittance `T(s)` of Jimenez et al. 2010.
//! * [`TransmittanceLut`]: `T(s)` tabulated for the GPU.
//! * [`separable_kernel`]: the Separable SSS (2015) kernel; [`HABLE13_TAPS`] and
//!   [`GAUSSIAN7_WEIGHTS`]: the older screen-space kernels.
//! * [`Dipole`], [`Multipole`], [`material`]: physically based profiles and the
//!   measured materials of Jensen et al. 2001; [`fit_sum_of_gaussians`] turns any
//!   of them into Gaussians (and so into a kernel and a `T(s)`).
//! * [`lateral`]: light reaching a point from the lit surface around it (the `diffusion`
//!   transmittance's lateral taps) and its CPU reference.
//! * [`oracle`]: CPU references of the screen-space blur passes; [`specular`]: the skin
//!   boundary's reflection that the lighting pass evaluates.
//!
//! Units: millimetres for distances, mm^2 for variances, mm^-1 for coefficients.

#![warn(missing_docs)]
// Per-channel arithmetic indexes several parallel `[_; 3]` arrays at once;
// `for c in 0..3` reads better there than zipped iterators.
#![allow(clippy::needless_range_loop)]

mod dipole;
mod error;
pub mod exact_array;
mod fit;
mod gaussian;
mod kernel;
pub mod lateral;
mod lut;
mod materials;
mod medium;
pub mod oracle;
mod slab;
pub mod specular;
mod transport;

pub use dipole::{DiffusionChannel, Dipole, Multipole, fresnel_diffuse_reflectance};
pub use error::{ProfileError, Result};
pub use fit::{GaussianFit, fit_sum_of_gaussians};
pub use gaussian::{GaussianTerm, SKIN_VARIANCES_MM2, SKIN_WEIGHTS, SumOfGaussians, gaussian};
pub use kernel::{
    DEFAULT_FALLOFF, DEFAULT_SAMPLES, DEFAULT_STRENGTH, GAUSSIAN7_OFFSETS_SIGMA, GAUSSIAN7_WEIGHTS,
    HABLE13_TAPS, KernelParams, SCREEN_GAUSSIANS, ScreenKernels, gaussian_table, hable13_for,
    hable13_kernel, separable_jitter_widths, separable_kernel, separable_kernel_for,
    separable_kernel_projected, separable_range_for, separable_range_mm, separable_range_projected,
};
pub use lut::TransmittanceLut;
pub use materials::{
    JENSEN2001_ETA, JENSEN2001_MATERIALS, Material, MeasuredMaterial, material, material_names,
};
pub use medium::{Coefficients, Medium};
pub use slab::{SlabTransmittance, slab_radiance};
pub use transport::{
    Reflection, SlabResult, SlabSolver, TransportTable, fresnel_inside, slab_transport,
};
