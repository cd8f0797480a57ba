//! Two `Subsurface` cameras in one app, with different settings (scale and field of view),
//! must each give the image they give alone: per-camera state must not leak between them
//! (uniforms written for one camera must not be read by the other's passes).

use crate::common;

use bevy::prelude::*;
use common::*;
use subsurface_bevy::{Subsurface, SubsurfacePlugin};

/// The second camera: from the right, a narrower field of view, twice the skin scale.
fn second() -> (Transform, impl Bundle) {
    (
        Transform::from_xyz(4.0, 1.0, 3.0).looking_at(Vec3::new(0.0, -0.2, 0.0), Vec3::Y),
        (
            Projection::Perspective(PerspectiveProjection {
                fov: 0.6,
                ..default()
            }),
            Subsurface {
                units_per_mm: 0.002,
                ..default()
            },
        ),
    )
}

fn skin_scene(h: &mut Headless) {
    let base = StandardMaterial {
        base_color: Color::linear_rgb(0.8, 0.5, 0.4),
        ..default()
    };
    let skin = add_skin(h.app.world_mut(), base, "skin1", 40.0);
    spawn_scene(&mut h.app, MeshMaterial3d(skin));
}

/// Frames until both cameras' images are stable.
fn render_both(h: &mut Headless, other: &Slot) -> (Vec<u8>, Vec<u8>) {
    let mut last: (Option<Vec<u8>>, Option<Vec<u8>>) = (None, None);
    for _ in 0..600 {
        h.app.update();
        let a = h.readback.lock().unwrap().take();
        let b = other.lock().unwrap().take();
        if let (Some(a), Some(b)) = (a, b) {
            if last.0.as_ref() == Some(&a) && last.1.as_ref() == Some(&b) {
                return (a, b);
            }
            last = (Some(a), Some(b));
        }
    }
    panic!("no stable pair of images");
}

#[test]
fn two_cameras_render_as_they_do_alone() {
    if !gpu_available() {
        return;
    }
    let alone_first = {
        let mut app = app();
        app.add_plugins(SubsurfacePlugin);
        let mut h = setup(app, Subsurface::default());
        skin_scene(&mut h);
        render_until_stable(&mut h, 600)
    };
    let alone_second = {
        let mut app = app();
        app.add_plugins(SubsurfacePlugin);
        let (transform, extra) = second();
        // The harness's camera, moved and given the second camera's settings.
        let mut h = setup(app, extra);
        let camera = h.camera;
        h.app.world_mut().entity_mut(camera).insert(transform);
        skin_scene(&mut h);
        render_until_stable(&mut h, 600)
    };
    let mut app = app();
    app.add_plugins(SubsurfacePlugin);
    let mut h = setup(app, Subsurface::default());
    let (transform, extra) = second();
    let other = add_camera(&mut h, transform, extra);
    skin_scene(&mut h);
    let (first, second) = render_both(&mut h, &other);
    assert!(first == alone_first, "the first camera's image changed");
    assert!(second == alone_second, "the second camera's image changed");
    assert!(first != second, "the cameras see the same image");
}
