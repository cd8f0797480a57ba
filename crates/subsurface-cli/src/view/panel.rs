//! The egui side panel and the 3D view's mouse and keyboard input.

use egui::{Color32, ComboBox, DragValue, PointerButton, RichText, Sense, Slider, Ui};
use subsurface_render::DebugView;
use subsurface_render::scene::LightKind;
use subsurface_render::{SssMethod, TransmittanceMethod};

use super::camera::{FlyInput, Mode};
use super::model::{Level, Model, typed_path};
use super::state::{Side, sss_methods, transmittance_methods, transmittance_name};

/// What the panel asks of the app that needs the GPU.
#[derive(Debug)]
pub enum Action {
    Screenshot(std::path::PathBuf),
    /// Diagnostics: destroy the device to exercise the recovery path.
    LoseDevice,
}

/// Size of the 3D view in physical pixels and pixels per egui point.
pub struct Viewport {
    pub width: u32,
    pub height: u32,
    pub pixels_per_point: f32,
    /// Seconds since the previous frame (fly speed).
    pub dt: f32,
}

/// The renderer's debug views.
const VIEWS: [(DebugView, &str); 8] = [
    (DebugView::Final, "final"),
    (DebugView::Mask, "SSS mask"),
    (DebugView::Depth, "depth"),
    (DebugView::DiffuseBeforeSss, "diffuse before SSS"),
    (DebugView::Diffuse, "diffuse after SSS"),
    (DebugView::Specular, "specular"),
    (DebugView::Thickness, "thickness (transmittance)"),
    (
        DebugView::Irradiance,
        "irradiance (UV map with texture SSS)",
    ),
];
const SHADOW_SIZES: [u32; 6] = [256, 512, 1024, 2048, 4096, 8192];

fn view_name(v: DebugView) -> &'static str {
    VIEWS.iter().find(|(d, _)| *d == v).map_or("?", |(_, n)| n)
}

/// The whole UI for one frame; returns the GPU actions requested.
pub fn show(ui: &mut Ui, m: &mut Model, vp: &Viewport) -> Vec<Action> {
    let mut actions = Vec::new();
    if ui.input(|i| i.key_pressed(egui::Key::F1)) {
        m.ui.show_panel = !m.ui.show_panel;
    }
    if m.ui.show_panel {
        egui::Panel::left("settings")
            .default_size(330.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    panel(ui, m, &mut actions);
                });
            });
    }
    let rect = ui.available_rect_before_wrap();
    view_input(ui, rect, m, vp);
    actions
}

fn panel(ui: &mut Ui, m: &mut Model, actions: &mut Vec<Action>) {
    ui.heading("subsurface view");
    ui.label(
        RichText::new(format!(
            "{:.1} ms/frame ({:.0} fps) — F1 hides this panel",
            m.stats.frame_ms,
            1000.0 / m.stats.frame_ms.max(1e-3)
        ))
        .small(),
    );
    if let Some(e) = &m.error {
        ui.colored_label(Color32::LIGHT_RED, e);
    }
    files(ui, m, actions);
    camera(ui, m);
    lights(ui, m);
    sss(ui, m);
    material(ui, m);
    transmittance(ui, m);
    image(ui, m);
    compare(ui, m);
    timings(ui, m, actions);
    ui.separator();
    for (level, msg) in m.log.iter().rev().take(8) {
        match level {
            Level::Info => ui.label(RichText::new(msg).small()),
            Level::Error => ui.colored_label(Color32::LIGHT_RED, msg),
        };
    }
}

fn path_row(ui: &mut Ui, label: &str, path: &mut String, button: &str) -> bool {
    ui.horizontal(|ui| {
        ui.label(label);
        let edit = ui.add(egui::TextEdit::singleline(path).desired_width(170.0));
        let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        ui.button(button).clicked() || enter
    })
    .inner
}

fn files(ui: &mut Ui, m: &mut Model, actions: &mut Vec<Action>) {
    ui.collapsing("Files", |ui| {
        ui.label(
            RichText::new(
                "Drop a .glb/.gltf model or a .toml scene on the window, or type a path.",
            )
            .small(),
        );
        if path_row(ui, "open", &mut m.ui.open_path, "Open") && !m.ui.open_path.trim().is_empty() {
            let p = typed_path(&m.ui.open_path);
            m.open(&p);
        }
        if path_row(ui, "scene", &mut m.ui.save_path, "Save") {
            let p = typed_path(&m.ui.save_path);
            m.save_scene(&p);
        }
        if path_row(ui, "image", &mut m.ui.screenshot_path, "Screenshot") {
            actions.push(Action::Screenshot(typed_path(&m.ui.screenshot_path)));
        }
    });
}

fn camera(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Camera")
        .default_open(true)
        .show(ui, |ui| {
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

fn lights(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Lights")
        .default_open(true)
        .show(ui, |ui| {
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
            let (mut az, mut el, mut dist) = m.light_spherical(i);
            let mut moved = false;
            moved |= ui
                .add(
                    Slider::new(&mut az, -180.0..=180.0)
                        .text("azimuth")
                        .suffix("°"),
                )
                .changed();
            moved |= ui
                .add(
                    Slider::new(&mut el, -89.0..=89.0)
                        .text("elevation")
                        .suffix("°"),
                )
                .changed();
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
            let before = m.state.desc.lights[i].clone();
            let l = &mut m.state.desc.lights[i];
            ui.horizontal(|ui| {
                ComboBox::from_id_salt("kind")
                    .selected_text(format!("{:?}", l.kind).to_lowercase())
                    .show_ui(ui, |ui| {
                        for k in [LightKind::Point, LightKind::Spot, LightKind::Directional] {
                            ui.selectable_value(&mut l.kind, k, format!("{k:?}").to_lowercase());
                        }
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
                    ComboBox::from_id_salt("shadow size")
                        .selected_text(format!("{} px", l.shadow_map_size))
                        .show_ui(ui, |ui| {
                            for s in SHADOW_SIZES {
                                ui.selectable_value(&mut l.shadow_map_size, s, format!("{s} px"));
                            }
                        });
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

fn method_combo(ui: &mut Ui, id: &str, method: &mut SssMethod) -> bool {
    let old = *method;
    ComboBox::from_id_salt(id)
        .selected_text(method.name())
        .show_ui(ui, |ui| {
            for k in sss_methods() {
                ui.selectable_value(method, k, k.name());
            }
        });
    *method != old
}

fn transmittance_combo(ui: &mut Ui, id: &str, t: &mut TransmittanceMethod) -> bool {
    let old = *t;
    ComboBox::from_id_salt(id)
        .selected_text(transmittance_name(*t))
        .show_ui(ui, |ui| {
            for k in transmittance_methods() {
                ui.selectable_value(t, k, transmittance_name(k));
            }
        });
    *t != old
}

fn view_combo(ui: &mut Ui, id: &str, v: &mut DebugView) -> bool {
    let old = *v;
    ComboBox::from_id_salt(id)
        .selected_text(view_name(*v))
        .show_ui(ui, |ui| {
            for (k, name) in VIEWS {
                ui.selectable_value(v, k, name);
            }
        });
    *v != old
}

/// An odd count in `lo..=hi` as a slider over the odd values.
fn odd_slider(ui: &mut Ui, n: &mut u32, lo: u32, hi: u32, text: &str) -> bool {
    let mut k = n.saturating_sub(1) / 2;
    let changed = ui
        .add(
            Slider::new(&mut k, (lo - 1) / 2..=(hi - 1) / 2)
                .custom_formatter(|v, _| format!("{}", 2 * v as u32 + 1))
                .custom_parser(|s| s.parse::<f64>().ok().map(|v| ((v - 1.0) / 2.0).round()))
                .text(text),
        )
        .changed();
    *n = 2 * k + 1;
    changed
}

/// Method-level settings shared by the main side and the comparison side.
fn side_settings(ui: &mut Ui, id: &str, s: &mut Side) -> bool {
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label("method");
        changed |= method_combo(ui, &format!("{id} method"), &mut s.sss.method);
    });
    if s.sss.method == SssMethod::Separable {
        changed |= odd_slider(ui, &mut s.sss.samples, 3, 63, "samples");
    }
    if s.sss.method == SssMethod::Gaussian6 {
        ui.horizontal(|ui| {
            ui.label("Gaussians");
            for (k, g) in s.sss.gaussians.iter_mut().enumerate() {
                changed |= ui.checkbox(g, format!("{}", k + 2)).changed();
            }
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

fn sss(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Subsurface scattering")
        .default_open(true)
        .show(ui, |ui| {
            if side_settings(ui, "a", &mut m.state.a) {
                m.dirty.update = true;
            }
        });
}

fn material(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Material")
        .default_open(true)
        .show(ui, |ui| {
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
            ComboBox::from_id_salt("profile")
                .selected_text(format!("profile: {}", mat.profile))
                .show_ui(ui, |ui| {
                    for name in subsurface_profile::material_names() {
                        ui.selectable_value(&mut mat.profile, name.to_string(), name);
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
            let skin = subsurface_profile::material(&mat.profile)
                .is_ok_and(|p| matches!(p, subsurface_profile::Material::Gaussians { .. }));
            let (mut ks, mut kf) = mat.kernel_params(skin);
            let mut moved = false;
            ui.label("separable kernel");
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                moved |= ui
                    .add(Slider::new(&mut ks[c], 0.0..=1.0).text(format!("strength {name}")))
                    .changed();
            }
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                moved |= ui
                    .add(Slider::new(&mut kf[c], 0.0..=1.0).text(format!("falloff {name}")))
                    .changed();
            }
            if moved {
                mat.kernel_strength = Some(ks);
                mat.falloff = Some(kf);
            }
            m.material_edited(&before);
        });
}

fn transmittance(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Transmittance")
        .default_open(true)
        .show(ui, |ui| {
            let mut changed = false;
            ui.horizontal(|ui| {
                ui.label("method");
                changed |=
                    transmittance_combo(ui, "a transmittance", &mut m.state.a.transmittance.method);
            });
            let ns = &mut m.state.a.transmittance.normal_shrink;
            let speed = ns.max(1e-4) * 0.02;
            changed |= ui
                .add(
                    DragValue::new(ns)
                        .speed(speed)
                        .range(0.0..=f32::MAX)
                        .prefix("normal shrink "),
                )
                .changed();
            changed |= odd_slider(
                ui,
                &mut m.state.a.transmittance.thickness_filter,
                1,
                15,
                "thickness filter",
            );
            if changed {
                m.dirty.update = true;
            }
        });
}

fn image(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Image")
        .default_open(true)
        .show(ui, |ui| {
            let mut changed = ui
                .add(
                    Slider::new(&mut m.state.desc.render.exposure_ev, -8.0..=8.0)
                        .text("exposure EV"),
                )
                .changed();
            ui.horizontal(|ui| {
                ui.label("debug view");
                changed |= view_combo(ui, "a view", &mut m.state.a.view);
            });
            ui.label(
                RichText::new("Thickness and irradiance-map views are not in the renderer yet.")
                    .small(),
            );
            if changed {
                m.dirty.update = true;
            }
        });
}

fn compare(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("Compare")
        .default_open(true)
        .show(ui, |ui| {
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
                    m.state.b = m.state.a.clone();
                    m.state.b.sss.method = SssMethod::None;
                    m.state.compare = true;
                    changed = true;
                }
                if ui.button("main | other method").clicked() {
                    let other = if m.state.a.sss.method == SssMethod::Gaussian6 {
                        SssMethod::Separable
                    } else {
                        SssMethod::Gaussian6
                    };
                    m.state.b = m.state.a.clone();
                    m.state.b.sss.method = other;
                    m.state.compare = true;
                    changed = true;
                }
            });
            if m.state.compare {
                changed |= side_settings(ui, "b", &mut m.state.b);
                ui.horizontal(|ui| {
                    ui.label("transmittance");
                    changed |= transmittance_combo(
                        ui,
                        "b transmittance",
                        &mut m.state.b.transmittance.method,
                    );
                });
                changed |= odd_slider(
                    ui,
                    &mut m.state.b.transmittance.thickness_filter,
                    1,
                    15,
                    "thickness filter",
                );
                ui.horizontal(|ui| {
                    ui.label("debug view");
                    changed |= view_combo(ui, "b view", &mut m.state.b.view);
                });
                ui.add(Slider::new(&mut m.state.split, 0.0..=1.0).text("divider"));
            }
            if changed {
                m.dirty.update = true;
            }
        });
}

fn timing_table(ui: &mut Ui, id: &str, t: &[subsurface_render::PassTiming]) {
    if t.is_empty() {
        ui.label("no GPU timestamps (yet)");
        return;
    }
    egui::Grid::new(id).striped(true).show(ui, |ui| {
        for p in t {
            ui.label(&p.name);
            ui.label(format!("{:.3} ms", p.ms));
            ui.end_row();
        }
        ui.label(RichText::new("GPU total").strong());
        ui.label(RichText::new(format!("{:.3} ms", t.iter().map(|p| p.ms).sum::<f64>())).strong());
        ui.end_row();
    });
}

fn timings(ui: &mut Ui, m: &mut Model, actions: &mut Vec<Action>) {
    egui::CollapsingHeader::new("GPU timings")
        .default_open(true)
        .show(ui, |ui| {
            ui.label(RichText::new(&m.stats.adapter).small());
            ui.label(format!("frame {:.2} ms", m.stats.frame_ms));
            if m.state.compare {
                ui.label("left");
            }
            timing_table(ui, "timings a", &m.stats.timings_a);
            if m.state.compare {
                ui.label("right");
                timing_table(ui, "timings b", &m.stats.timings_b);
            }
            ui.collapsing("Diagnostics", |ui| {
                if ui
                    .button("Simulate device loss")
                    .on_hover_text("destroys the GPU device; the viewer recreates it")
                    .clicked()
                {
                    actions.push(Action::LoseDevice);
                }
            });
        });
}

/// Mouse and keys on the 3D view (the window outside the panel).
fn view_input(ui: &mut Ui, rect: egui::Rect, m: &mut Model, vp: &Viewport) {
    let response = ui.interact(rect, ui.scope_id().with("3d view"), Sense::click_and_drag());
    let ppp = vp.pixels_per_point;
    let h = vp.height as f32;
    let fov = m.state.desc.camera.fov_y_deg;

    // The split-screen divider: drawn over the view and dragged on its own.
    if m.state.compare {
        let x = m.state.split * vp.width as f32 / ppp;
        let handle = egui::Rect::from_x_y_ranges(x - 4.0..=x + 4.0, rect.y_range());
        let d = ui.interact(handle, ui.scope_id().with("divider"), Sense::drag());
        if d.dragged() {
            let px = (x + d.drag_delta().x) * ppp;
            m.state.split = (px / vp.width.max(1) as f32).clamp(0.0, 1.0);
        }
        let stroke_color = if d.hovered() || d.dragged() {
            Color32::WHITE
        } else {
            Color32::from_white_alpha(160)
        };
        ui.painter()
            .vline(x, rect.y_range(), egui::Stroke::new(1.5, stroke_color));
        if d.hovered() || d.dragged() {
            ui.ctx().set_cursor_icon(egui::CursorIcon::ResizeHorizontal);
        }
    }

    let delta = response.drag_delta() * ppp;
    let shift = ui.input(|i| i.modifiers.shift);
    if response.dragged() && delta != egui::Vec2::ZERO {
        if shift && response.dragged_by(PointerButton::Primary) {
            m.drag_light(delta.x, delta.y, h);
        } else {
            match m.camera.mode {
                Mode::Orbit => {
                    if response.dragged_by(PointerButton::Primary) {
                        m.camera.orbit.rotate(delta.x, delta.y, h);
                    } else {
                        m.camera.orbit.pan(delta.x, delta.y, h, fov);
                    }
                }
                Mode::Fly => m.camera.fly.look(delta.x, delta.y, h, fov),
            }
            m.camera_moved();
        }
    }
    if response.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            // egui gives points; about 50 points per wheel notch on common mice.
            let steps = scroll / 50.0;
            match m.camera.mode {
                Mode::Orbit => m.camera.orbit.zoom(steps),
                Mode::Fly => {
                    let f = m.camera.fly.forward();
                    m.camera.fly.position += f * m.camera.fly.focus * 0.1 * steps;
                }
            }
            m.camera_moved();
        }
    }
    if m.camera.mode == Mode::Fly && !ui.ctx().egui_wants_keyboard_input() {
        let (input, fast) = ui.input(|i| {
            let axis = |pos: egui::Key, neg: egui::Key| {
                i.key_down(pos) as i32 as f32 - i.key_down(neg) as i32 as f32
            };
            (
                FlyInput {
                    forward: axis(egui::Key::W, egui::Key::S),
                    right: axis(egui::Key::D, egui::Key::A),
                    up: axis(egui::Key::E, egui::Key::Q),
                },
                i.modifiers.shift,
            )
        });
        if input != FlyInput::default() {
            // One focus distance per second: the speed follows the scene's scale.
            let speed = m.camera.fly.focus * if fast { 4.0 } else { 1.0 };
            m.camera.fly.step(input, vp.dt.min(0.1), speed);
            m.camera_moved();
        }
    }
}

/// Mouse and keyboard through egui, as the window delivers them: raw input events into a
/// headless `egui::Context`, the same `show` the viewer runs each frame, and the camera it
/// leaves behind.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::state::ViewerState;
    use egui::{Event, Modifiers, Pos2, RawInput, Rect, Vec2, pos2, vec2};
    use glam::Vec3;
    use std::path::PathBuf;
    use subsurface_render::Scene;
    use subsurface_render::scene::DEFAULT_SCENE_TOML;

    const W: f32 = 800.0;
    const H: f32 = 600.0;

    struct Harness {
        ctx: egui::Context,
        model: Model,
        time: f64,
    }

    impl Harness {
        fn new() -> Self {
            let state =
                ViewerState::from_toml_str(DEFAULT_SCENE_TOML, PathBuf::from("."), "default")
                    .unwrap();
            let mut model = Model::new(state, Scene::default_scene(), None);
            // The whole window is the 3D view, as with the panel hidden (F1).
            model.ui.show_panel = false;
            Self {
                ctx: egui::Context::default(),
                model,
                time: 0.0,
            }
        }

        /// One frame with these events (and keys held, for fly), 1/60 s after the last.
        fn frame(&mut self, events: Vec<Event>) {
            self.time += 1.0 / 60.0;
            let raw = RawInput {
                screen_rect: Some(Rect::from_min_size(Pos2::ZERO, vec2(W, H))),
                time: Some(self.time),
                predicted_dt: 1.0 / 60.0,
                events,
                ..Default::default()
            };
            let vp = Viewport {
                width: W as u32,
                height: H as u32,
                pixels_per_point: 1.0,
                dt: 1.0 / 60.0,
            };
            let model = &mut self.model;
            let mut out = self.ctx.run_ui(raw, |ui| {
                show(ui, model, &vp);
            });
            // No painter here: egui insists that dropped texture updates are acknowledged.
            out.textures_delta.clear();
        }

        /// Press `button` at `from`, move in steps of at most 10 px to `to`, release.
        fn drag(&mut self, button: PointerButton, from: Pos2, to: Pos2, modifiers: Modifiers) {
            // egui-winit reports Shift and co. as ModifiersChanged events.
            self.frame(vec![
                Event::ModifiersChanged(modifiers),
                Event::PointerMoved(from),
            ]);
            self.frame(vec![Event::PointerButton {
                pos: from,
                button,
                pressed: true,
                modifiers,
            }]);
            let steps = ((to - from).length() / 10.0).ceil().max(1.0) as usize;
            for i in 1..=steps {
                let p = from + (to - from) * (i as f32 / steps as f32);
                self.frame(vec![Event::PointerMoved(p)]);
            }
            self.frame(vec![Event::PointerButton {
                pos: to,
                button,
                pressed: false,
                modifiers,
            }]);
            self.frame(vec![Event::ModifiersChanged(Modifiers::NONE)]);
        }

        fn eye(&self) -> (Vec3, Vec3) {
            let c = &self.model.state.desc.camera;
            (Vec3::from(c.position), Vec3::from(c.target))
        }
    }

    fn angle_deg(a: Vec3, b: Vec3) -> f32 {
        a.normalize()
            .dot(b.normalize())
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }

    #[test]
    fn left_drag_of_half_the_height_orbits_a_quarter_turn() {
        let mut h = Harness::new();
        let (eye0, target0) = h.eye();
        h.drag(
            PointerButton::Primary,
            pos2(200.0, 300.0),
            pos2(200.0 + H / 2.0, 300.0),
            Modifiers::NONE,
        );
        let (eye1, target1) = h.eye();
        assert!((target1 - target0).length() < 1e-5, "target moved");
        let a = angle_deg(eye0 - target0, eye1 - target1);
        assert!((a - 90.0).abs() < 0.5, "orbited {a} degrees, want 90");
        assert!(
            ((eye1 - target1).length() - (eye0 - target0).length()).abs() < 1e-5,
            "distance changed"
        );
        assert!(h.model.dirty.update, "no update requested");
    }

    #[test]
    fn middle_drag_pans_and_wheel_zooms() {
        let mut h = Harness::new();
        let (eye0, target0) = h.eye();
        h.drag(
            PointerButton::Middle,
            pos2(400.0, 300.0),
            pos2(460.0, 300.0),
            Modifiers::NONE,
        );
        let (eye1, target1) = h.eye();
        // Pan: eye and target move together, sideways, keeping the view direction.
        assert!((target1 - target0).length() > 1e-4, "no pan");
        assert!(((eye1 - target1) - (eye0 - target0)).length() < 1e-5);
        assert!((target1 - target0).dot(eye0 - target0).abs() < 1e-6);
        // One wheel notch towards the screen moves the eye closer, not the target.
        let d0 = (eye1 - target1).length();
        h.frame(vec![Event::PointerMoved(pos2(400.0, 300.0))]);
        h.frame(vec![Event::MouseWheel {
            unit: egui::MouseWheelUnit::Point,
            delta: Vec2::new(0.0, 50.0),
            phase: egui::TouchPhase::Move,
            source: egui::MouseWheelSource::Unknown,
            modifiers: Modifiers::NONE,
        }]);
        for _ in 0..30 {
            h.frame(vec![]); // egui smooths the wheel over a few frames
        }
        let (eye2, target2) = h.eye();
        assert!((target2 - target1).length() < 1e-5);
        let d2 = (eye2 - target2).length();
        assert!(d2 < 0.99 * d0, "wheel did not zoom in: {d0} -> {d2}");
    }

    #[test]
    fn shift_drag_moves_the_selected_light_not_the_camera() {
        let mut h = Harness::new();
        let (eye0, _) = h.eye();
        let light0 = Vec3::from(h.model.state.desc.lights[0].position);
        h.drag(
            PointerButton::Primary,
            pos2(300.0, 300.0),
            pos2(400.0, 300.0),
            Modifiers::SHIFT,
        );
        let light1 = Vec3::from(h.model.state.desc.lights[0].position);
        assert!((h.eye().0 - eye0).length() < 1e-6, "camera moved");
        assert!((light1 - light0).length() > 1e-3, "light did not move");
    }

    #[test]
    fn fly_mode_w_moves_forward() {
        let mut h = Harness::new();
        h.model.camera.set_mode(Mode::Fly);
        let (eye0, target0) = h.eye();
        let forward = (target0 - eye0).normalize();
        h.frame(vec![Event::Key {
            key: egui::Key::W,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: Modifiers::NONE,
        }]);
        for _ in 0..10 {
            h.frame(vec![]);
        }
        h.frame(vec![Event::Key {
            key: egui::Key::W,
            physical_key: None,
            pressed: false,
            repeat: false,
            modifiers: Modifiers::NONE,
        }]);
        let (eye1, _) = h.eye();
        let moved = eye1 - eye0;
        assert!(moved.dot(forward) > 0.0, "did not move forward: {moved}");
        assert!(
            (moved - forward * moved.dot(forward)).length() < 1e-4 * moved.length().max(1e-3),
            "moved sideways: {moved}"
        );
    }
}
