//! The render-settings sections: Subsurface scattering, Transmittance, Image and Compare
//! (the split screen's second side). Each holds its method pickers and the generated rows
//! (`generated`) of the keys that change the frame; "All settings" lists every key.

use egui::{Slider, Ui};
use subsurface_render::{RenderSettings, SssMethod, TransmittanceMethod};

use super::generated;
use super::widgets::{combo, labelled, settings_section, view_combo};
use crate::view::model::Model;
use crate::view::state::{Which, per_side};

fn method_combo(ui: &mut Ui, id: &str, method: &mut SssMethod) -> bool {
    labelled(ui, "method", |ui| {
        combo(ui, id, method, SssMethod::ALL, SssMethod::name)
    })
}

fn transmittance_combo(ui: &mut Ui, id: &str, t: &mut TransmittanceMethod) -> bool {
    labelled(ui, "transmittance", |ui| {
        combo(
            ui,
            id,
            t,
            TransmittanceMethod::ALL,
            TransmittanceMethod::name,
        )
    })
}

/// A side's keys below `table` (but its method, picked above them) that change the frame.
fn effect_keys(table: &'static str) -> impl Fn(&str, &RenderSettings) -> bool {
    move |key, s| {
        key.strip_prefix(table)
            .is_some_and(|k| k.starts_with('.') && k != ".method")
            && s.matters(key)
    }
}

pub fn sss(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Subsurface scattering", m, |ui, m| {
        let changed = method_combo(ui, "a method", &mut m.state.a.sss.method);
        generated::rows(ui, m, Which::A, "sss.", effect_keys("sss"));
        changed
    });
}

pub fn transmittance(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Transmittance", m, |ui, m| {
        let changed =
            transmittance_combo(ui, "a transmittance", &mut m.state.a.transmittance.method);
        let (t, b) = (effect_keys("transmittance"), effect_keys("bounce"));
        // `bounce.*` is the scene's (`[render.bounce]`): both sides of a split screen share it.
        generated::rows(ui, m, Which::A, "transmittance.", move |k, s| {
            t(k, s) || b(k, s)
        });
        changed
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
            let b = &mut m.state.b;
            changed |= method_combo(ui, "b method", &mut b.sss.method);
            changed |= transmittance_combo(ui, "b transmittance", &mut b.transmittance.method);
            changed |= labelled(ui, "debug view", |ui| view_combo(ui, "b view", &mut b.view));
            // The right side's own keys; the scene's are shared with the left.
            generated::rows(ui, m, Which::B, "", |k, s| {
                per_side(k) && !k.ends_with(".method") && s.matters(k)
            });
            ui.add(Slider::new(&mut m.state.split, 0.0..=1.0).text("divider"));
        }
        changed
    });
}
