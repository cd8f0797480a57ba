//! Small widgets the panel's sections share: collapsing sections, labelled rows, drop-downs.

use egui::{ComboBox, Ui, WidgetText};
use subsurface_render::DebugView;

use crate::view::model::Model;

/// The renderer's debug views.
pub const VIEWS: [(DebugView, &str); 8] = [
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

pub fn view_name(v: DebugView) -> &'static str {
    VIEWS.iter().find(|(d, _)| *d == v).map_or("?", |(_, n)| n)
}

/// A collapsing section, open at first.
pub fn section(ui: &mut Ui, title: &str, body: impl FnOnce(&mut Ui)) {
    egui::CollapsingHeader::new(title)
        .default_open(true)
        .show(ui, body);
}

/// A section of render settings: `body` says whether it changed any, and then the renderers
/// are brought up to date.
pub fn settings_section(
    ui: &mut Ui,
    title: &str,
    m: &mut Model,
    body: impl FnOnce(&mut Ui, &mut Model) -> bool,
) {
    section(ui, title, |ui| {
        if body(ui, m) {
            m.dirty.update = true;
        }
    });
}

/// `label`, then what `add` puts beside it on the same row.
pub fn labelled<R>(ui: &mut Ui, label: &str, add: impl FnOnce(&mut Ui) -> R) -> R {
    ui.horizontal(|ui| {
        ui.label(label);
        add(ui)
    })
    .inner
}

/// A drop-down of `options`, each shown as `name` gives it; whether the choice changed.
pub fn combo<T: Copy + PartialEq, S: Into<WidgetText>>(
    ui: &mut Ui,
    id: &str,
    value: &mut T,
    options: impl IntoIterator<Item = T>,
    name: impl Fn(T) -> S,
) -> bool {
    let old = *value;
    ComboBox::from_id_salt(id)
        .selected_text(name(old))
        .show_ui(ui, |ui| {
            for k in options {
                ui.selectable_value(value, k, name(k));
            }
        });
    *value != old
}

/// The debug-view drop-down.
pub fn view_combo(ui: &mut Ui, id: &str, v: &mut DebugView) -> bool {
    combo(ui, id, v, VIEWS.map(|(k, _)| k), view_name)
}
