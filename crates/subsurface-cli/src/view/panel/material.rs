//! The Material section: the selected object's (or every object's) material.

use egui::{ComboBox, Slider, Ui};
use subsurface_profile::Medium;

use super::widgets::section;
use crate::view::model::Model;

pub fn material(ui: &mut Ui, m: &mut Model) {
    section(ui, "Material", |ui| {
        let n = m.state.desc.objects.len();
        if n == 0 {
            ui.label("No objects.");
            return;
        }
        m.ui.object = m.ui.object.min(n - 1);
        ui.horizontal(|ui| {
            ComboBox::from_id_salt("object")
                .selected_text(m.scene.objects[m.ui.object].name.clone())
                .show_ui(ui, |ui| {
                    for (i, o) in m.scene.objects.iter().enumerate() {
                        ui.selectable_value(&mut m.ui.object, i, o.name.clone());
                    }
                });
            ui.checkbox(&mut m.ui.edit_all_objects, "edit all");
        });
        let before = m.state.desc.objects[m.ui.object].material.clone();
        let mat = &mut m.state.desc.objects[m.ui.object].material;
        ComboBox::from_id_salt("medium")
            .selected_text(format!("medium: {}", mat.medium))
            .show_ui(ui, |ui| {
                // Coefficients from the scene file stay selected until a preset is picked.
                for name in subsurface_profile::material_names() {
                    ui.selectable_value(&mut mat.medium, Medium::Preset(name.to_string()), name);
                }
            });
        ui.add(Slider::new(&mut mat.sss_strength, 0.0..=1.0).text("SSS strength"));
        ui.add(
            Slider::new(&mut mat.sss_width, 0.05..=10.0)
                .logarithmic(true)
                .text("SSS width"),
        );
        ui.add(
            Slider::new(&mut mat.translucency, 0.0..=20.0)
                .logarithmic(true)
                .text("translucency"),
        );
        ui.add(Slider::new(&mut mat.roughness, 0.05..=1.0).text("roughness"));
        ui.add(Slider::new(&mut mat.specular, 0.0..=1.0).text("specular"));
        // Each material has its own separable kernel; unset values show the defaults of
        // its kind of profile and become its own once moved.
        let skin = mat
            .medium
            .material()
            .is_ok_and(|p| matches!(p, subsurface_profile::Material::Gaussians { .. }));
        let (mut ks, mut kf) = mat.kernel_params(skin);
        ui.label("separable kernel");
        let moved = rgb_sliders(ui, &mut ks, "strength") | rgb_sliders(ui, &mut kf, "falloff");
        if moved {
            mat.kernel_strength = Some(ks);
            mat.falloff = Some(kf);
        }
        m.material_edited(&before);
    });
}

/// One 0..=1 slider per channel, "`what` R" to "`what` B"; whether any moved.
fn rgb_sliders(ui: &mut Ui, v: &mut [f32; 3], what: &str) -> bool {
    let mut moved = false;
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        moved |= ui
            .add(Slider::new(&mut v[c], 0.0..=1.0).text(format!("{what} {name}")))
            .changed();
    }
    moved
}
