//! The Camera and Lights sections.

use egui::{ComboBox, DragValue, RichText, Slider, Ui};
use subsurface_render::scene::LightKind;

use super::widgets::{combo, section};
use crate::view::camera::Mode;
use crate::view::model::Model;

const SHADOW_SIZES: [u32; 6] = [256, 512, 1024, 2048, 4096, 8192];

pub fn camera(ui: &mut Ui, m: &mut Model) {
    section(ui, "Camera", |ui| {
        ui.horizontal(|ui| {
            let mut mode = m.camera.mode;
            ui.radio_value(&mut mode, Mode::Orbit, "orbit");
            ui.radio_value(&mut mode, Mode::Fly, "fly");
            if mode != m.camera.mode {
                m.camera.set_mode(mode);
                m.camera_moved();
            }
            if ui
                .button("Reset")
                .on_hover_text("the scene's camera")
                .clicked()
            {
                m.reset_camera();
            }
        });
        let help = match m.camera.mode {
            Mode::Orbit => "drag: rotate, wheel: zoom, middle/right drag: pan",
            Mode::Fly => "WASD: move, Q/E: down/up, Shift: faster, drag: look",
        };
        ui.label(RichText::new(format!("{help}; Shift+drag: move the light")).small());
        let fov = &mut m.state.desc.camera.fov_y_deg;
        if ui
            .add(Slider::new(fov, 5.0..=120.0).text("fov y").suffix("°"))
            .changed()
        {
            m.dirty.update = true;
        }
    });
}

pub fn lights(ui: &mut Ui, m: &mut Model) {
    section(ui, "Lights", |ui| {
        let n = m.state.desc.lights.len();
        ui.horizontal(|ui| {
            ComboBox::from_id_salt("light")
                .selected_text(if n == 0 {
                    "no lights".to_string()
                } else {
                    format!("light {}", m.ui.light)
                })
                .show_ui(ui, |ui| {
                    for (i, l) in m.state.desc.lights.iter().enumerate() {
                        ui.selectable_value(
                            &mut m.ui.light,
                            i,
                            format!("light {i} ({:?})", l.kind).to_lowercase(),
                        );
                    }
                });
            if ui.button("Add").clicked() {
                m.add_light();
            }
            if ui.add_enabled(n > 0, egui::Button::new("Remove")).clicked() {
                m.remove_light(m.ui.light);
            }
        });
        let i = m.ui.light;
        if i >= m.state.desc.lights.len() {
            return;
        }
        position(ui, m, i);
        let before = m.state.desc.lights[i].clone();
        let l = &mut m.state.desc.lights[i];
        ui.horizontal(|ui| {
            let kinds = [LightKind::Point, LightKind::Spot, LightKind::Directional];
            combo(ui, "kind", &mut l.kind, kinds, |k| {
                format!("{k:?}").to_lowercase()
            });
            ui.color_edit_button_rgb(&mut l.color);
            ui.label("colour");
        });
        ui.add(
            Slider::new(&mut l.intensity, 0.0..=(before.intensity * 4.0).max(10.0))
                .logarithmic(true)
                .text("intensity"),
        );
        if l.kind == LightKind::Spot {
            ui.add(Slider::new(&mut l.outer_angle_deg, 1.0..=89.0).text("outer angle"));
            let outer = l.outer_angle_deg;
            l.inner_angle_deg = l.inner_angle_deg.min(outer);
            ui.add(Slider::new(&mut l.inner_angle_deg, 0.5..=outer).text("inner angle"));
        }
        ui.horizontal(|ui| {
            let mut shadow = l.shadow_map_size > 0;
            if ui.checkbox(&mut shadow, "shadow").changed() {
                l.shadow_map_size = if shadow { 2048 } else { 0 };
            }
            if shadow {
                combo(
                    ui,
                    "shadow size",
                    &mut l.shadow_map_size,
                    SHADOW_SIZES,
                    |s| format!("{s} px"),
                );
            }
        });
        let speed = l.shadow_bias.max(1e-4) * 0.05;
        ui.add(
            DragValue::new(&mut l.shadow_bias)
                .speed(speed)
                .range(0.0..=f32::MAX)
                .prefix("shadow bias "),
        );
        if l.kind != LightKind::Point && ui.button("Aim at the scene centre").clicked() {
            m.aim_light_at_centre(i);
        }
        if m.state.desc.lights[i] != before {
            m.dirty.update = true;
        }
    });
}

/// Light `i`'s position as azimuth, elevation and distance about the scene's centre.
fn position(ui: &mut Ui, m: &mut Model, i: usize) {
    let (mut az, mut el, mut dist) = m.light_spherical(i);
    let degrees = |ui: &mut Ui, v: &mut f32, max: f32, text: &str| {
        ui.add(Slider::new(v, -max..=max).text(text).suffix("°"))
            .changed()
    };
    let mut moved = degrees(ui, &mut az, 180.0, "azimuth");
    moved |= degrees(ui, &mut el, 89.0, "elevation");
    let (min_d, max_d) = ((dist * 0.1).max(1e-4), (dist * 4.0).max(1e-3));
    moved |= ui
        .add(
            Slider::new(&mut dist, min_d..=max_d)
                .logarithmic(true)
                .text("distance"),
        )
        .changed();
    if moved {
        m.set_light_spherical(i, az, el, dist);
    }
}
