//! Widgets made from the render crate's table of settings: one row per key, its widget chosen
//! by the value's type (`view::setting::kind`), its unit and doc on hover, every edit applied
//! through `RenderSettings::set`. The "All settings" section lists every key; the method
//! sections list the keys of their effect that change the frame.

use egui::{Color32, ComboBox, DragValue, RichText, TextEdit, Ui};
use subsurface_render::SettingDoc;

use crate::view::model::Model;
use crate::view::setting::{Kind, Value, hover_text, kind};
use crate::view::state::Which;

/// Rows for side `which`'s keys that `show` accepts (given the key and the side's settings),
/// each labelled by its key less `strip`. Edits are applied (or refused, with the error shown
/// under the row) through [`Model::set_setting`].
pub fn rows(
    ui: &mut Ui,
    m: &mut Model,
    which: Which,
    strip: &str,
    show: impl Fn(&str, &subsurface_render::RenderSettings) -> bool,
) {
    let settings = m.state.settings(which);
    let salt = format!("{which:?} {strip}");
    egui::Grid::new(format!("{salt} settings"))
        .num_columns(2)
        .show(ui, |ui| {
            for (doc, current) in Value::entries(&settings) {
                if !show(doc.key, &settings) {
                    continue;
                }
                let rejected = m.rejected(which, doc.key).cloned();
                let mut value = rejected.as_ref().map_or(current, |r| r.value.clone());
                let label = doc.key.strip_prefix(strip).unwrap_or(doc.key);
                let label = if settings.matters(doc.key) {
                    RichText::new(label)
                } else {
                    // Shown, but it does nothing with the other settings as they are.
                    RichText::new(label).weak()
                };
                ui.label(label).on_hover_text(hover_text(doc));
                let id = format!("{salt} {}", doc.key);
                let changed = ui
                    .horizontal(|ui| edit(ui, &id, doc, &kind(doc, &value), &mut value))
                    .inner;
                ui.end_row();
                if let Some(r) = rejected {
                    ui.label("");
                    ui.horizontal(|ui| {
                        ui.colored_label(Color32::LIGHT_RED, RichText::new(&r.error).small());
                        if ui
                            .small_button("revert")
                            .on_hover_text("show the setting's value again")
                            .clicked()
                        {
                            m.forget_rejected(which, doc.key);
                        }
                    });
                    ui.end_row();
                }
                if changed {
                    m.set_setting(which, doc.key, value);
                }
            }
        });
}

/// The widget `kind` for `v`; whether the user changed it.
fn edit(ui: &mut Ui, id: &str, doc: &SettingDoc, kind: &Kind, v: &mut Value) -> bool {
    let hover = || hover_text(doc);
    match (kind, v) {
        (Kind::Check, Value::Bool(b)) => ui.checkbox(b, "").on_hover_text(hover()).changed(),
        (Kind::Int { speed }, Value::Int(i)) => ui
            .add(DragValue::new(i).speed(*speed))
            .on_hover_text(hover())
            .changed(),
        (Kind::Float { speed }, Value::Float(x)) => ui
            .add(DragValue::new(x).speed(*speed).max_decimals(6))
            .on_hover_text(hover())
            .changed(),
        (Kind::Choice(names), Value::Str(s)) => {
            let old = s.clone();
            ComboBox::from_id_salt(id)
                .selected_text(old.as_str())
                .show_ui(ui, |ui| {
                    for n in names {
                        ui.selectable_value(s, n.to_string(), *n);
                    }
                })
                .response
                .on_hover_text(hover());
            *s != old
        }
        (Kind::Text, Value::Str(s)) => text_field(ui, id, s),
        (Kind::Array(kinds), Value::Array(items)) => {
            let mut changed = false;
            for (i, (k, item)) in kinds.iter().zip(items.iter_mut()).enumerate() {
                changed |= edit(ui, &format!("{id}[{i}]"), doc, k, item);
            }
            changed
        }
        (_, v) => {
            ui.label(v.text()).on_hover_text(hover());
            false
        }
    }
}

/// A text field whose text is applied when it loses focus (the value is read again every
/// frame, so the text being typed is kept in egui's memory meanwhile).
fn text_field(ui: &mut Ui, id: &str, s: &mut String) -> bool {
    let key = ui.scope_id().with(id);
    let mut text = ui
        .data(|d| d.get_temp::<String>(key))
        .unwrap_or_else(|| s.clone());
    let r = ui.add(TextEdit::singleline(&mut text).desired_width(120.0));
    if r.lost_focus() {
        ui.data_mut(|d| d.remove::<String>(key));
        if text != *s {
            *s = text;
            return true;
        }
    } else if r.has_focus() {
        ui.data_mut(|d| d.insert_temp(key, text));
    }
    false
}

/// The "All settings" section (closed at first): every key of the main side, with the
/// scene's keys that both sides share.
pub fn all_settings(ui: &mut Ui, m: &mut Model) {
    egui::CollapsingHeader::new("All settings")
        .default_open(false)
        .show(ui, |ui| {
            let note = if m.state.compare {
                "Every [render] key of the left side; the right side's own are under Compare. \
                 Hover a name for its unit and meaning."
            } else {
                "Every [render] key, as in a scene file. Hover a name for its unit and meaning."
            };
            ui.label(RichText::new(note).small());
            rows(ui, m, Which::A, "", |_, _| true);
        });
}
