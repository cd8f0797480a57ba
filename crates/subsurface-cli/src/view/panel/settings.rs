//! The render-settings sections: Subsurface scattering, Transmittance, Image and Compare
//! (the split screen's second side).

use egui::{DragValue, Slider, Ui};
use subsurface_render::{LateralPass, SssFetch, SssMethod, TransmittanceMethod};

use super::widgets::{combo, labelled, odd_slider, settings_section, view_combo};
use crate::view::model::Model;
use crate::view::state::{Side, sss_methods, transmittance_methods, transmittance_name};

fn method_combo(ui: &mut Ui, id: &str, method: &mut SssMethod) -> bool {
    combo(ui, id, method, sss_methods(), SssMethod::name)
}

fn transmittance_combo(ui: &mut Ui, id: &str, t: &mut TransmittanceMethod) -> bool {
    combo(ui, id, t, transmittance_methods(), transmittance_name)
}

/// Method-level settings shared by the main side and the comparison side.
fn side_settings(ui: &mut Ui, id: &str, s: &mut Side) -> bool {
    let mut changed = labelled(ui, "method", |ui| {
        method_combo(ui, &format!("{id} method"), &mut s.sss.method)
    });
    if s.sss.method == SssMethod::Separable {
        changed |= odd_slider(ui, &mut s.sss.samples, 3, 63, "samples");
        changed |= ui
            .checkbox(&mut s.sss.jitter, "jitter (few-sample mode)")
            .changed();
    }
    if s.sss.method == SssMethod::Gaussian6 {
        ui.horizontal(|ui| {
            ui.label("Gaussians");
            for (k, g) in s.sss.gaussians.iter_mut().enumerate() {
                changed |= ui.checkbox(g, format!("{}", k + 2)).changed();
            }
        });
    }
    if s.sss.method.is_screen_space() {
        // Same image either way: switching shows the packed fetch's saving in the timings.
        changed |= labelled(ui, "fetch", |ui| {
            combo(
                ui,
                &format!("{id} fetch"),
                &mut s.sss.fetch,
                SssFetch::ALL,
                SssFetch::name,
            )
        });
    }
    if s.sss.method != SssMethod::None {
        changed |= ui
            .checkbox(
                &mut s.sss.follow_surface,
                "follow surface (stop at depth edges)",
            )
            .changed();
    }
    changed
}

fn thickness_filter_slider(ui: &mut Ui, n: &mut u32) -> bool {
    odd_slider(ui, n, 1, 15, "thickness filter")
}

fn lateral_taps_slider(ui: &mut Ui, n: &mut u32) -> bool {
    let max = subsurface_profile::lateral::MAX_LATERAL_TAPS;
    ui.add(Slider::new(n, 0..=max).text("lateral taps"))
        .changed()
}

fn lateral_texel_slider(ui: &mut Ui, mm: &mut f32) -> bool {
    ui.add(Slider::new(mm, 0.0..=10.0).text("lateral map texel (mm, 0 = per pixel)"))
        .changed()
}

pub fn sss(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Subsurface scattering", m, |ui, m| {
        side_settings(ui, "a", &mut m.state.a)
    });
}

pub fn transmittance(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Transmittance", m, |ui, m| {
        let t = &mut m.state.a.transmittance;
        let mut changed = labelled(ui, "method", |ui| {
            transmittance_combo(ui, "a transmittance", &mut t.method)
        });
        let speed = t.normal_shrink.max(1e-4) * 0.02;
        changed |= ui
            .add(
                DragValue::new(&mut t.normal_shrink)
                    .speed(speed)
                    .range(0.0..=f32::MAX)
                    .prefix("normal shrink "),
            )
            .changed();
        changed |= thickness_filter_slider(ui, &mut t.thickness_filter);
        changed |= lateral_taps_slider(ui, &mut t.lateral_taps);
        changed |= lateral_texel_slider(ui, &mut t.lateral_texel_mm);
        // Same map either way: switching shows the compute evaluation's saving in the timings.
        changed |= labelled(ui, "lateral pass", |ui| {
            combo(
                ui,
                "lateral pass",
                &mut t.lateral_pass,
                LateralPass::ALL,
                LateralPass::name,
            )
        });
        // Scene-wide (`[render.bounce]`): both sides of a split screen share it.
        let ring = &mut m.state.desc.render.bounce.ring;
        let max = subsurface_render::settings::MAX_BOUNCE_RING;
        changed
            | ui.add(Slider::new(ring, 0..=max).text("bounce ring (light between parts, 0 = off)"))
                .changed()
    });
}

pub fn image(ui: &mut Ui, m: &mut Model) {
    settings_section(ui, "Image", m, |ui, m| {
        let exposure = &mut m.state.desc.render.exposure_ev;
        let mut changed = ui
            .add(Slider::new(exposure, -8.0..=8.0).text("exposure EV"))
            .changed();
        changed |= labelled(ui, "debug view", |ui| {
            view_combo(ui, "a view", &mut m.state.a.view)
        });
        changed
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
            changed |= side_settings(ui, "b", b);
            changed |= labelled(ui, "transmittance", |ui| {
                transmittance_combo(ui, "b transmittance", &mut b.transmittance.method)
            });
            changed |= thickness_filter_slider(ui, &mut b.transmittance.thickness_filter);
            changed |= lateral_taps_slider(ui, &mut b.transmittance.lateral_taps);
            changed |= labelled(ui, "debug view", |ui| view_combo(ui, "b view", &mut b.view));
            ui.add(Slider::new(&mut m.state.split, 0.0..=1.0).text("divider"));
        }
        changed
    });
}
