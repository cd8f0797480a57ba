//! The egui side panel and the 3D view's mouse and keyboard input.
//!
//! Layout: this file lays the panel out and holds its Files and GPU timings sections (the two
//! that ask the app for GPU work, [`Action`]); `scene` (camera, lights), `material`, `settings`
//! (SSS, transmittance, image, split screen), `generated` (the rows made from the render
//! crate's table of settings, and "All settings"), `view_input` (the 3D view) and `widgets`
//! (what they share) hold the rest.

mod generated;
mod material;
mod scene;
mod settings;
mod view_input;
mod widgets;

use egui::{Color32, RichText, Ui};

use super::model::{Level, Model, typed_path};
pub use view_input::Viewport;
use widgets::{labelled, section};

/// The panel's width at first, in points: the window opens this much wider than the scene's
/// image (`view::run`), so that the panel covers none of the scene on the first frame.
/// Labels wrap and widgets stay within it; the user may drag it wider.
pub const PANEL_WIDTH: f32 = 330.0;

/// What the panel asks of the app that needs the GPU.
#[derive(Debug)]
pub enum Action {
    Screenshot(std::path::PathBuf),
    /// Diagnostics: destroy the device to exercise the recovery path.
    LoseDevice,
}

/// The whole UI for one frame; returns the GPU actions requested.
pub fn show(ui: &mut Ui, m: &mut Model, vp: &Viewport) -> Vec<Action> {
    let mut actions = Vec::new();
    if ui.input(|i| i.key_pressed(egui::Key::F1)) {
        m.ui.show_panel = !m.ui.show_panel;
    }
    if m.ui.show_panel {
        egui::Panel::left("settings")
            .default_size(PANEL_WIDTH)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    panel(ui, m, &mut actions);
                });
            });
    }
    let rect = ui.available_rect_before_wrap();
    view_input::view_input(ui, rect, m, vp);
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
    scene::camera(ui, m);
    scene::lights(ui, m);
    settings::sss(ui, m);
    material::material(ui, m);
    settings::transmittance(ui, m);
    settings::image(ui, m);
    settings::compare(ui, m);
    generated::all_settings(ui, m);
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
    labelled(ui, label, |ui| {
        let edit = ui.add(egui::TextEdit::singleline(path).desired_width(170.0));
        let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        ui.button(button).clicked() || enter
    })
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
    section(ui, "GPU timings", |ui| {
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
