//! The light `diffusion` transmittance sends toward the camera through a slab: what the GPU
//! tests of subsurface-render and subsurface-bevy compare their transmitted light with.

use crate::{Dipole, Result, SlabSolver, TransmittanceLut, TransportTable, slab_transport};

/// Exact slab transport of one medium, tabulated as the renderer tabulates it, and the rough
/// boundary the light leaves through.
pub struct SlabTransmission {
    table: TransportTable,
    roughness: f64,
    eta: f64,
}

impl SlabTransmission {
    /// Slabs of `medium` up to `max_mm` thick, behind a boundary of Beckmann `roughness` and
    /// relative index `eta`.
    pub fn new(medium: &Dipole, max_mm: f64, roughness: f64, eta: f64) -> Result<Self> {
        let table = slab_transport(medium, TransmittanceLut::TRANSPORT_POINTS, max_mm)?;
        Ok(Self {
            table,
            roughness,
            eta,
        })
    }

    /// The transport table (T_ms / albedo and the exit shapes per thickness).
    pub fn table(&self) -> &TransportTable {
        &self.table
    }

    /// Per unit of back irradiance, what leaves through `s_mm` of the medium toward a camera
    /// at exit cosine `mu_o`: exact transport's T_ms / albedo with the slab's angular shape at
    /// cosine `c` to the flow (the table's rows blended as the GPU's filter blends them),
    /// times what the rough boundary lets out at `mu_o`.
    pub fn toward(&self, s_mm: f32, c: f32, mu_o: f32) -> [f32; 3] {
        let row = c.clamp(0.0, 1.0) * (SlabSolver::EXIT_ANGLES - 1) as f32;
        let k = (row.floor() as usize).min(SlabSolver::EXIT_ANGLES - 2);
        let f = row - k as f32;
        let at = |k: usize| {
            TransmittanceLut::transport_at(&self.table, 2048, k)
                .expect("the table's rows")
                .sample(s_mm)
        };
        let (a, b) = (at(k), at(k + 1));
        let out =
            crate::specular::rough_transmittance(f64::from(mu_o), self.roughness, self.eta) as f32;
        [0, 1, 2].map(|i| (a[i] * (1.0 - f) + b[i] * f) * out)
    }
}
