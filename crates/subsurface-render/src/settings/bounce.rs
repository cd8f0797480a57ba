//! Settings of the light that one lit part of the skin sends another across the air (a
//! finger's lit side toward its neighbour), gathered from a flux pyramid of the shadow maps
//! (`passes::bounce`; docs/lab/fidelity.md, finding 11).

use serde::{Deserialize, Serialize};

use super::{InvalidSetting, check, check_int};

/// Largest [`BounceSettings::ring`].
pub const MAX_BOUNCE_RING: u32 = 8;

/// The `[render.bounce]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BounceSettings {
    /// How many cells of each level of the pyramid lie between a shaded point and the next,
    /// coarser level (0..=8): each level is read from `ring` to `2 ring` of its cells away,
    /// about `9.4 ring^2` reads a level. 0 turns the bounce off.
    pub ring: u32,
    /// Width of the finest cells read, in profile millimetres across the light (0.1..=50):
    /// below the medium's own blur, the cells' detail would not show.
    pub cell_mm: f32,
}

impl Default for BounceSettings {
    fn default() -> Self {
        Self {
            ring: 2,
            cell_mm: 2.0,
        }
    }
}

impl BounceSettings {
    /// The settings with the bounce left out.
    pub const OFF: Self = Self {
        ring: 0,
        cell_mm: 2.0,
    };

    /// Whether the bounce runs (`ring` > 0).
    pub fn enabled(&self) -> bool {
        self.ring > 0
    }

    /// Checks each key's range; the error names the key below `bounce`.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        check_int("ring", self.ring, 0..=MAX_BOUNCE_RING)?;
        check(
            "cell_mm",
            self.cell_mm,
            (0.1..=50.0).contains(&self.cell_mm),
            "in 0.1..=50",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_values_name_their_field() {
        let bad = |s: BounceSettings| s.validate().unwrap_err().field;
        let d = BounceSettings::default();
        assert!(d.validate().is_ok() && d.enabled() && !BounceSettings::OFF.enabled());
        for ring in [9, u32::MAX] {
            assert_eq!(bad(BounceSettings { ring, ..d.clone() }), "ring");
        }
        for cell_mm in [0.0, 0.05, 51.0, f32::NAN, f32::INFINITY] {
            assert_eq!(
                bad(BounceSettings {
                    cell_mm,
                    ..d.clone()
                }),
                "cell_mm"
            );
        }
    }
}
