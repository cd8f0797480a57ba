//! How far the lateral taps' estimate lies from the integral it estimates, across a backlit rod.
//!
//! `cargo run --release -p subsurface-profile --example lateral_quadrature`
//!
//! The shader's lateral light is a quadrature of `K(r)` over the lit surface with a few taps
//! placed for a plane ([`subsurface_profile::lateral::taps`]). On a plane every tap weighs
//! the same and twelve are exact; on a rod lit along its diameter the lit surface curves
//! toward the exit point, so the integrand peaks near the terminators, where few taps land.
//! For each medium, rod and window this prints the estimate at several tap counts and the
//! integral itself (a 0.03 mm grid over the rod's lit half), over the slab as thick as the
//! rod's diameter, in red and green: what `confinement_mc.py --windows` compares with a random
//! walk, before the walls and the exit's angular shape (docs/lab/quality.md, session 44).

use subsurface_profile::lateral::{kernel, lateral_transmittance};
use subsurface_profile::specular::rough_transmittance;
use subsurface_profile::{
    Dipole, JENSEN2001_ETA, Material, TransportTable, material, slab_transport,
};

/// The boundary's roughness the scenes render with (`[material] roughness`).
const ROUGHNESS: f64 = 0.3;
const TAP_COUNTS: [u32; 5] = [8, 12, 16, 24, 32];

/// A rod of `radius` mm along z, lit along -y (from below), seen from +y; the window at `at`
/// radii across. Returns the exit point and its normal in the (x, y) plane.
fn window(radius: f64, at: f64) -> ([f64; 2], [f64; 2]) {
    let x = at * radius;
    let y = (radius * radius - x * x).sqrt();
    ([x, y], [x / radius, y / radius])
}

/// Where the light entered below the tap at `x` across the rod, `z` along it: the distance
/// from the exit point and the weight the shader gives it (below the exit's tangent plane,
/// times the rough boundary's transmittance there over normal incidence's).
fn entry(radius: f64, eta: f64, p: [f64; 2], n: [f64; 2], x: f64, z: f64) -> Option<(f64, f64)> {
    if x.abs() >= radius {
        return None;
    }
    let boundary = boundary_at(radius, eta, x);
    Some(entry_with(radius, p, n, x, z, boundary))
}

/// The rough boundary's transmittance where the light enters below `x`, over normal
/// incidence's.
fn boundary_at(radius: f64, eta: f64, x: f64) -> f64 {
    let cos = (radius * radius - x * x).sqrt() / radius;
    rough_transmittance(cos, ROUGHNESS, eta) / rough_transmittance(1.0, ROUGHNESS, eta)
}

fn entry_with(radius: f64, p: [f64; 2], n: [f64; 2], x: f64, z: f64, boundary: f64) -> (f64, f64) {
    let y = -(radius * radius - x * x).sqrt();
    let (dx, dy) = (x - p[0], y - p[1]);
    let r = (dx * dx + dy * dy + z * z).sqrt();
    let below = (-2.0 * (dx * n[0] + dy * n[1]) / r).clamp(0.0, 1.0);
    (r, below * boundary)
}

/// The integral the taps estimate: the kernel over the rod's lit half on a 0.03 mm grid, 30 mm
/// each way along the rod (where the slowest medium's kernel has fallen by e^-3.5 or more), times
/// the chord's rise as the taps' sum is.
fn dense(
    table: &TransportTable,
    radius: f64,
    eta: f64,
    p: [f64; 2],
    n: [f64; 2],
    chord: f64,
) -> [f64; 3] {
    let h = 0.03;
    let mut sum = [0.0; 3];
    let mut x = -radius + h / 2.0;
    while x < radius {
        let boundary = boundary_at(radius, eta, x);
        let mut z = -30.0 + h / 2.0;
        while z < 30.0 {
            let (r, w) = entry_with(radius, p, n, x, z, boundary);
            let k = kernel(table, r);
            for c in 0..3 {
                sum[c] += k[c] * w * h * h;
            }
            z += h;
        }
        x += h;
    }
    let rise = table.rise_at(chord);
    [0, 1, 2].map(|c| sum[c] * rise[c])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut media = Vec::new();
    for name in ["skin1", "skin2"] {
        if let Material::Dipole { dipole, .. } = material(name)? {
            media.push((name, dipole, JENSEN2001_ETA));
        }
    }
    // The suite's custom medium (tools/reference/suite_design.py): its red absorbs.
    media.push((
        "custom",
        Dipole::new([0.12, 0.025, 0.08], [0.6, 0.9, 0.7], 1.5)?,
        1.5,
    ));

    print!("{:<7} {:>5} {:>6} {:>2}", "medium", "rod", "at", "ch");
    for n in TAP_COUNTS {
        print!(" {:>7}", format!("{n} taps"));
    }
    println!(" {:>8}", "integral");
    for (name, dipole, eta) in media {
        let table = slab_transport(&dipole, 129, 32.0)?;
        let sigma = table.lateral_decay_per_mm();
        for radius in [4.0, 9.0] {
            let slab = table.multiple_at(2.0 * radius);
            for at in [0.0, 0.6] {
                let (p, n) = window(radius, at);
                let chord = 2.0 * p[1];
                let mut rows = [[0.0; TAP_COUNTS.len()]; 2];
                for (i, taps) in TAP_COUNTS.into_iter().enumerate() {
                    let t = lateral_transmittance(&table, chord, sigma, taps, |rho, phi| {
                        entry(radius, eta, p, n, p[0] + rho * phi.cos(), rho * phi.sin())
                    })?;
                    for c in 0..2 {
                        rows[c][i] = t[c] / slab[c];
                    }
                }
                let exact = dense(&table, radius, eta, p, n, chord);
                for c in 0..2 {
                    print!(
                        "{name:<7} {:>3.0}mm {at:>6.1} {:>2}",
                        2.0 * radius,
                        ["R", "G"][c]
                    );
                    for v in rows[c] {
                        print!(" {v:>7.3}");
                    }
                    println!(" {:>8.3}", exact[c] / slab[c]);
                }
            }
        }
    }
    Ok(())
}
