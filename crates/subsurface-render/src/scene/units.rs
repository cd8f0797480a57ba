//! Scene units and profile millimetres: the one conversion every pass and exporter uses.

use glam::Mat4;

/// Scene units per profile millimetre of an object: the profile's radii are in mm, the mesh's
/// units are `mm_per_unit` mm, its transform scales them into the world (the cube root of the
/// determinant is the uniform scale), and `sss_width` widens the profile.
pub fn world_per_mm(transform: Mat4, mm_per_unit: f32, sss_width: f32) -> f32 {
    let scale = transform.determinant().abs().cbrt();
    sss_width * scale / mm_per_unit
}
