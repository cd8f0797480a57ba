//! The render-settings sections: Subsurface scattering, Transmittance, Image and Compare
//! (the split screen's second side). Each holds the generated rows (`generated`) of its
//! methods and of the keys that change the frame; "All settings" lists every key.

use egui::{Slider, Ui};
use subsurface_render::{RenderSettings, SssMethod};

use super::generated;
use super::widgets::{labelled, settings_section, view_combo};
use crate::view::model::Model;
use crate::view::state::{Which, per_side};

/// The keys below `table` that change the frame, its method first (the table's order).
fn effect_keys(table: &'static str) -> impl Fn(&str, &RenderSettings) -> bool {
    move |key, s| {
        key.strip_prefix(table).is_some_and(|k| k.starts_with('.'))
            && (key.ends_with(".method") || s.matters(key))
    }
}

pub fn sss(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Subsurface scattering", m, |ui, m| {
        generated::rows(ui, m, Which::A, "sss.", effect_keys("sss"));
        false
    });
}

pub fn transmittance(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Transmittance", m, |ui, m| {
        let effects = [
            effect_keys("transmittance"),
            effect_keys("transmitted_map"),
            effect_keys("bounce"),
        ];
        // `transmitted_map.*` and `bounce.*` are the scene's: both sides of a split screen
        // share them.
        generated::rows(ui, m, Which::A, "transmittance.", move |k, s| {
            effects.iter().any(|e| e(k, s))
        });
        false
    });
}

pub fn image(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Image", m, |ui, m| {
        generated::rows(ui, m, Which::A, "", |k, _| k == "exposure_ev");
        labelled(ui, "debug view", |ui| {
            view_combo(ui, "a view", &mut m.state.a.view)
        })
    });
}

pub fn compare(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Compare", m, |ui, m| {
        let mut changed = ui
            .checkbox(
                &mut m.state.compare,
                "split screen: main settings | these (right)",
            )
            .changed();
        ui.horizontal(|ui| {
            if ui.button("main | SSS off").clicked() {
                if m.state.a.sss.method == SssMethod::None {
                    m.state.a.sss.method = SssMethod::Separable;
                }
                m.state.compare_with(SssMethod::None);
                changed = true;
            }
            if ui.button("main | other method").clicked() {
                let other = if m.state.a.sss.method == SssMethod::Gaussian6 {
                    SssMethod::Separable
                } else {
                    SssMethod::Gaussian6
                };
                m.state.compare_with(other);
                changed = true;
            }
        });
        if m.state.compare {
            changed |= labelled(ui, "debug view", |ui| {
                view_combo(ui, "b view", &mut m.state.b.view)
            });
            // The right side's own keys, methods first; the scene's are shared with the left.
            generated::rows(ui, m, Which::B, "", |k, s| {
                per_side(k) && (k.ends_with(".method") || s.matters(k))
            });
            ui.add(Slider::new(&mut m.state.split, 0.0..=1.0).text("divider"));
        }
        changed
    });
}
