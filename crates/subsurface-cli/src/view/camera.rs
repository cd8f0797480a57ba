//! Orbit and free-fly camera controllers: pure math on pixel deltas, no window, so the
//! mapping from input to motion is unit-tested.
//!
//! Both controllers share one angle parametrisation (yaw about the scene's up axis, pitch
//! above the horizontal plane) so that switching modes keeps the view exactly.

use std::f32::consts::{FRAC_PI_2, PI};

use glam::Vec3;
use subsurface_render::scene::CameraDesc;

/// Orbit rotation in radians per pixel of drag, per pixel of view height: a drag across the
/// whole height turns the model half way round, fine enough to tune a highlight.
pub const ORBIT_RADIANS_PER_HEIGHT: f32 = PI;
/// Pitch stops this short of the poles, where yaw would become ambiguous.
const PITCH_LIMIT: f32 = FRAC_PI_2 - 0.01;
/// Distance factor per wheel notch.
pub const ZOOM_PER_STEP: f32 = 0.85;

/// Orthonormal frame around the scene's up axis: `e1` x `e2` spans the horizontal plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Basis {
    pub up: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
}

impl Basis {
    pub fn new(up: Vec3) -> Self {
        let up = up.normalize_or(Vec3::Y);
        // With up = +Y this gives e2 = +Z, e1 = +X: yaw 0 looks down -Z like the scenes do.
        let seed = if up.z.abs() < 0.9 { Vec3::Z } else { Vec3::X };
        let e2 = (seed - up * seed.dot(up)).normalize();
        let e1 = up.cross(e2);
        Self { up, e1, e2 }
    }

    /// Unit vector from the orbit centre to the eye.
    pub fn offset(&self, yaw: f32, pitch: f32) -> Vec3 {
        (self.e1 * yaw.sin() + self.e2 * yaw.cos()) * pitch.cos() + self.up * pitch.sin()
    }

    /// (yaw, pitch) of a direction from the centre to the eye.
    pub fn angles(&self, offset: Vec3) -> (f32, f32) {
        let n = offset.normalize_or(self.e2);
        let pitch = n.dot(self.up).clamp(-1.0, 1.0).asin();
        let yaw = n.dot(self.e1).atan2(n.dot(self.e2));
        (yaw, pitch.clamp(-PITCH_LIMIT, PITCH_LIMIT))
    }
}

/// Camera right and up vectors for a view direction.
fn right_up(forward: Vec3, up: Vec3) -> (Vec3, Vec3) {
    let right = forward.cross(up).normalize_or(Vec3::X);
    (right, right.cross(forward))
}

/// World units per pixel at `distance` in front of a camera of vertical fov `fov_y_deg`.
pub fn world_per_pixel(distance: f32, fov_y_deg: f32, view_height_px: f32) -> f32 {
    2.0 * distance * (0.5 * fov_y_deg.to_radians()).tan() / view_height_px.max(1.0)
}

/// Turntable camera around a target point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub basis: Basis,
    pub target: Vec3,
    pub distance: f32,
    pub yaw: f32,
    pub pitch: f32,
}

impl Orbit {
    pub fn from_camera(c: &CameraDesc) -> Self {
        let basis = Basis::new(Vec3::from(c.up));
        let target = Vec3::from(c.target);
        let offset = Vec3::from(c.position) - target;
        let (yaw, pitch) = basis.angles(offset);
        Self {
            basis,
            target,
            distance: offset.length().max(1e-6),
            yaw,
            pitch,
        }
    }

    pub fn position(&self) -> Vec3 {
        self.target + self.basis.offset(self.yaw, self.pitch) * self.distance
    }

    pub fn forward(&self) -> Vec3 {
        -self.basis.offset(self.yaw, self.pitch)
    }

    /// Left-drag by (dx, dy) pixels (y down) in a view `view_height_px` tall. Dragging right
    /// swings the eye to the left so the model turns with the cursor; dragging down raises
    /// the eye (as three.js's OrbitControls do).
    pub fn rotate(&mut self, dx: f32, dy: f32, view_height_px: f32) {
        let k = ORBIT_RADIANS_PER_HEIGHT / view_height_px.max(1.0);
        self.yaw = wrap_angle(self.yaw - dx * k);
        self.pitch = (self.pitch + dy * k).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Middle-drag: moves the target in the view plane so the point at the target's depth
    /// stays under the cursor.
    pub fn pan(&mut self, dx: f32, dy: f32, view_height_px: f32, fov_y_deg: f32) {
        let s = world_per_pixel(self.distance, fov_y_deg, view_height_px);
        let (right, up) = right_up(self.forward(), self.basis.up);
        self.target += (-right * dx + up * dy) * s;
    }

    /// Wheel: `steps` > 0 moves closer, each step by [`ZOOM_PER_STEP`].
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * ZOOM_PER_STEP.powf(steps)).clamp(1e-5, 1e6);
    }
}

/// Free-fly camera: WASD moves, mouse drag looks around.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fly {
    pub basis: Basis,
    pub position: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    /// Distance of the point looked at, kept so switching back to orbit keeps the centre.
    pub focus: f32,
}

/// Keys held in fly mode, each -1, 0 or 1.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlyInput {
    /// W = +1, S = -1.
    pub forward: f32,
    /// D = +1, A = -1.
    pub right: f32,
    /// E = +1, Q = -1 (along the scene's up axis).
    pub up: f32,
}

impl Fly {
    pub fn forward(&self) -> Vec3 {
        -self.basis.offset(self.yaw, self.pitch)
    }

    /// Drag by (dx, dy) pixels: a drag of the view's height turns by the vertical field of
    /// view, so the scene point under the cursor roughly stays under it.
    pub fn look(&mut self, dx: f32, dy: f32, view_height_px: f32, fov_y_deg: f32) {
        let k = fov_y_deg.to_radians() / view_height_px.max(1.0);
        self.yaw = wrap_angle(self.yaw - dx * k);
        self.pitch = (self.pitch + dy * k).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Moves for `dt` seconds at `speed` scene units per second.
    pub fn step(&mut self, input: FlyInput, dt: f32, speed: f32) {
        let forward = self.forward();
        let (right, _) = right_up(forward, self.basis.up);
        let dir = forward * input.forward + right * input.right + self.basis.up * input.up;
        self.position += dir * speed * dt;
    }
}

fn wrap_angle(a: f32) -> f32 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Orbit,
    Fly,
}

/// The viewer's camera: one of the two controllers, converted to the scene's camera on demand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controller {
    pub mode: Mode,
    pub orbit: Orbit,
    pub fly: Fly,
}

impl Controller {
    pub fn new(c: &CameraDesc) -> Self {
        let orbit = Orbit::from_camera(c);
        Self {
            mode: Mode::Orbit,
            orbit,
            fly: fly_from_orbit(&orbit),
        }
    }

    /// Switches mode keeping the eye, the view direction and the focus distance.
    pub fn set_mode(&mut self, mode: Mode) {
        if mode == self.mode {
            return;
        }
        match mode {
            Mode::Fly => self.fly = fly_from_orbit(&self.orbit),
            Mode::Orbit => {
                let f = &self.fly;
                self.orbit = Orbit {
                    basis: f.basis,
                    target: f.position + f.forward() * f.focus,
                    distance: f.focus,
                    yaw: f.yaw,
                    pitch: f.pitch,
                };
            }
        }
        self.mode = mode;
    }

    /// `base` with this controller's eye and target (up, fov and clip planes kept).
    pub fn camera(&self, base: &CameraDesc) -> CameraDesc {
        let (position, target) = match self.mode {
            Mode::Orbit => (self.orbit.position(), self.orbit.target),
            Mode::Fly => (
                self.fly.position,
                self.fly.position + self.fly.forward() * self.fly.focus,
            ),
        };
        CameraDesc {
            position: position.to_array(),
            target: target.to_array(),
            ..base.clone()
        }
    }
}

fn fly_from_orbit(o: &Orbit) -> Fly {
    Fly {
        basis: o.basis,
        position: o.position(),
        yaw: o.yaw,
        pitch: o.pitch,
        focus: o.distance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> CameraDesc {
        CameraDesc {
            position: [0.0, 0.0, 2.0],
            target: [0.0, 0.0, 0.0],
            ..Default::default()
        }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn orbit_reproduces_the_scene_camera() {
        let c = CameraDesc {
            position: [0.3, 0.4, 1.2],
            target: [0.1, -0.1, 0.2],
            ..Default::default()
        };
        let o = Orbit::from_camera(&c);
        assert!(close(o.position(), Vec3::from(c.position)));
        let out = Controller::new(&c).camera(&c);
        assert!(close(Vec3::from(out.position), Vec3::from(c.position)));
        assert_eq!(out.target, c.target);
    }

    #[test]
    fn horizontal_drag_of_half_the_height_turns_a_quarter() {
        let mut o = Orbit::from_camera(&cam());
        // 240 px of drag in a 480 px tall view = pi/2 at pi per view height.
        o.rotate(240.0, 0.0, 480.0);
        assert!((o.yaw + FRAC_PI_2).abs() < 1e-6, "yaw {}", o.yaw);
        // Dragging right swings the eye from +Z to -X: the model turns with the cursor.
        assert!(
            close(o.position(), Vec3::new(-2.0, 0.0, 0.0)),
            "{}",
            o.position()
        );
        assert_eq!(o.target, Vec3::ZERO);
        assert!((o.distance - 2.0).abs() < 1e-6);
    }

    #[test]
    fn vertical_drag_raises_the_eye_and_stops_at_the_pole() {
        let mut o = Orbit::from_camera(&cam());
        o.rotate(0.0, 80.0, 480.0); // pi/6
        assert!((o.pitch - PI / 6.0).abs() < 1e-6);
        let p = o.position();
        assert!((p.y - 2.0 * (PI / 6.0).sin()).abs() < 1e-5, "{p}");
        o.rotate(0.0, 10_000.0, 480.0);
        assert!((o.pitch - PITCH_LIMIT).abs() < 1e-6);
        assert!(o.position().is_finite());
    }

    #[test]
    fn pan_keeps_the_target_depth_point_under_the_cursor() {
        let c = cam();
        let mut o = Orbit::from_camera(&c);
        // fov 30 deg, 2 units away, 400 px tall: 2*2*tan(15 deg)/400 units per pixel.
        o.pan(100.0, -50.0, 400.0, c.fov_y_deg);
        let s = 4.0 * (15f32).to_radians().tan() / 400.0;
        // Dragging right/up moves the content right/up, i.e. the target left/down.
        assert!(
            close(o.target, Vec3::new(-100.0 * s, -50.0 * s, 0.0)),
            "{}",
            o.target
        );
        assert!((o.distance - 2.0).abs() < 1e-6);
    }

    #[test]
    fn wheel_zooms_geometrically() {
        let mut o = Orbit::from_camera(&cam());
        o.zoom(2.0);
        assert!((o.distance - 2.0 * ZOOM_PER_STEP * ZOOM_PER_STEP).abs() < 1e-6);
        o.zoom(-2.0);
        assert!((o.distance - 2.0).abs() < 1e-5);
    }

    #[test]
    fn fly_moves_and_looks() {
        let mut c = Controller::new(&cam());
        c.set_mode(Mode::Fly);
        assert!(close(c.fly.position, Vec3::new(0.0, 0.0, 2.0)));
        assert!(close(c.fly.forward(), -Vec3::Z));
        c.fly.step(
            FlyInput {
                forward: 1.0,
                right: 1.0,
                up: 0.0,
            },
            0.5,
            2.0,
        );
        assert!(
            close(c.fly.position, Vec3::new(1.0, 0.0, 1.0)),
            "{}",
            c.fly.position
        );
        // A drag of the whole view height turns by the field of view (30 degrees).
        c.fly.look(400.0, 0.0, 400.0, 30.0);
        let f = c.fly.forward();
        assert!((f.angle_between(-Vec3::Z) - 30f32.to_radians()).abs() < 1e-5);
        assert!(f.x > 0.0, "looking right turns toward +x: {f}");
    }

    #[test]
    fn switching_modes_keeps_the_view() {
        let base = CameraDesc {
            position: [0.5, 0.2, 1.0],
            target: [0.0, 0.1, 0.0],
            ..Default::default()
        };
        let mut c = Controller::new(&base);
        c.orbit.rotate(30.0, 20.0, 300.0);
        let before = c.camera(&base);
        c.set_mode(Mode::Fly);
        let fly = c.camera(&base);
        c.set_mode(Mode::Orbit);
        let after = c.camera(&base);
        for (a, b) in [(&before, &fly), (&before, &after)] {
            assert!(close(Vec3::from(a.position), Vec3::from(b.position)));
            assert!(close(Vec3::from(a.target), Vec3::from(b.target)));
        }
    }

    #[test]
    fn z_up_scenes_orbit_about_z() {
        let c = CameraDesc {
            position: [0.0, -2.0, 0.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            ..Default::default()
        };
        let mut o = Orbit::from_camera(&c);
        assert!(close(o.position(), Vec3::new(0.0, -2.0, 0.0)));
        o.rotate(100.0, 0.0, 200.0);
        assert!(o.position().z.abs() < 1e-5, "turning keeps the eye level");
    }
}
