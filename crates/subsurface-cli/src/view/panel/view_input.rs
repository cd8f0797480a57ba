//! Mouse and keyboard on the 3D view (the window outside the panel): camera, light and the
//! split-screen divider.

use egui::{Color32, PointerButton, Sense, Ui};

use crate::view::camera::{FlyInput, Mode};
use crate::view::model::Model;

/// Size of the 3D view in physical pixels and pixels per egui point.
pub struct Viewport {
    pub width: u32,
    pub height: u32,
    pub pixels_per_point: f32,
    /// Seconds since the previous frame (fly speed).
    pub dt: f32,
}

/// Mouse and keys on the 3D view (the window outside the panel).
pub fn view_input(ui: &mut Ui, rect: egui::Rect, m: &mut Model, vp: &Viewport) {
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
/// headless `egui::Context`, `view_input` over the whole window as the viewer's `show` runs it
/// with the panel hidden (F1), and the camera it leaves behind.
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
            let model = Model::new(state, Scene::default_scene(), None);
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
                view_input(ui, ui.available_rect_before_wrap(), model, &vp);
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

        /// A new harness after a drag with no modifier keys, with its [`eye`](Self::eye)
        /// before and after the drag.
        fn dragged(
            button: PointerButton,
            from: Pos2,
            to: Pos2,
        ) -> (Self, (Vec3, Vec3), (Vec3, Vec3)) {
            let mut h = Self::new();
            let before = h.eye();
            h.drag(button, from, to, Modifiers::NONE);
            let after = h.eye();
            (h, before, after)
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
        let (h, (eye0, target0), (eye1, target1)) = Harness::dragged(
            PointerButton::Primary,
            pos2(200.0, 300.0),
            pos2(200.0 + H / 2.0, 300.0),
        );
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
        let (mut h, (eye0, target0), (eye1, target1)) = Harness::dragged(
            PointerButton::Middle,
            pos2(400.0, 300.0),
            pos2(460.0, 300.0),
        );
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
        let w = |pressed| Event::Key {
            key: egui::Key::W,
            physical_key: None,
            pressed,
            repeat: false,
            modifiers: Modifiers::NONE,
        };
        h.frame(vec![w(true)]);
        for _ in 0..10 {
            h.frame(vec![]);
        }
        h.frame(vec![w(false)]);
        let (eye1, _) = h.eye();
        let moved = eye1 - eye0;
        assert!(moved.dot(forward) > 0.0, "did not move forward: {moved}");
        assert!(
            (moved - forward * moved.dot(forward)).length() < 1e-4 * moved.length().max(1e-3),
            "moved sideways: {moved}"
        );
    }
}
