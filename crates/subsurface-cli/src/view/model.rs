//! The viewer's state and every edit on it, without a GPU: the panel and the input handlers
//! change a `Model`, the app turns its `Dirty` flags into renderer updates.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::Vec3;
use subsurface_render::scene::{CameraDesc, LightDesc, LightKind, MaterialDesc};
use subsurface_render::{PassTiming, Scene};

use super::camera::{Basis, Controller, ORBIT_RADIANS_PER_HEIGHT};
use super::setting::{Rejected, Value};
use super::state::{ViewerState, Which};

/// What the renderers must do before the next frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dirty {
    /// Camera, lights, materials, sizes or settings changed: `Renderer::update`.
    pub update: bool,
    /// Meshes changed (a new model or scene): new `Renderer`s.
    pub rebuild: bool,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Level {
    Info,
    Error,
}

/// Panel fields that are not settings.
pub struct UiFields {
    pub show_panel: bool,
    pub light: usize,
    pub object: usize,
    /// Material edits go to every object (the SSS kernel is one per frame anyway).
    pub edit_all_objects: bool,
    pub open_path: String,
    pub save_path: String,
    pub screenshot_path: String,
    /// Setting edits `RenderSettings::set` refused, shown with their errors.
    pub rejected: Vec<super::setting::Rejected>,
}

/// Frame statistics shown in the panel.
#[derive(Default)]
pub struct Stats {
    pub adapter: String,
    pub frame_ms: f64,
    pub timings_a: Vec<PassTiming>,
    pub timings_b: Vec<PassTiming>,
    pub frames: u64,
}

pub struct Model {
    pub state: ViewerState,
    pub scene: Scene,
    pub camera: Controller,
    /// The scene file's camera, for "reset".
    pub home_camera: CameraDesc,
    pub dirty: Dirty,
    pub log: Vec<(Level, String)>,
    /// Set while the last edit could not be applied; cleared by the next good update.
    pub error: Option<String>,
    pub ui: UiFields,
    pub stats: Stats,
}

impl Model {
    pub fn new(state: ViewerState, scene: Scene, source: Option<&Path>) -> Self {
        let home_camera = state.desc.camera.clone();
        let save_path = source
            .map(|p| p.with_extension("").display().to_string() + "-view.toml")
            .unwrap_or_else(|| "scene-view.toml".into());
        Self {
            camera: Controller::new(&home_camera),
            home_camera,
            ui: UiFields {
                show_panel: true,
                light: 0,
                object: 0,
                edit_all_objects: true,
                open_path: String::new(),
                save_path,
                screenshot_path: "screenshot.png".into(),
                rejected: Vec::new(),
            },
            state,
            scene,
            dirty: Dirty::default(),
            log: Vec::new(),
            error: None,
            stats: Stats::default(),
        }
    }

    pub fn info(&mut self, msg: impl Into<String>) {
        let msg = msg.into();
        log::info!("{msg}");
        self.log.push((Level::Info, msg));
        self.trim_log();
    }

    pub fn error(&mut self, msg: impl Into<String>) {
        let msg = msg.into().replace('\n', " ");
        // A failure that repeats every frame is shown (and logged) once.
        if self
            .log
            .last()
            .is_some_and(|(l, m)| *l == Level::Error && *m == msg)
        {
            return;
        }
        log::warn!("{msg}");
        self.log.push((Level::Error, msg));
        self.trim_log();
    }

    fn trim_log(&mut self) {
        let n = self.log.len();
        if n > 50 {
            self.log.drain(..n - 50);
        }
    }

    /// The controller moved: write its eye and target into the scene.
    pub fn camera_moved(&mut self) {
        self.state.desc.camera = self.camera.camera(&self.state.desc.camera);
        self.dirty.update = true;
    }

    pub fn reset_camera(&mut self) {
        let mode = self.camera.mode;
        let fov = self.state.desc.camera.fov_y_deg;
        self.state.desc.camera = self.home_camera.clone();
        self.state.desc.camera.fov_y_deg = fov;
        self.camera = Controller::new(&self.home_camera);
        self.camera.set_mode(mode);
        self.dirty.update = true;
    }

    /// Centre of the scene's bounds: lights orbit it.
    pub fn centre(&self) -> Vec3 {
        let (lo, hi) = self.scene.bounds();
        (lo + hi) * 0.5
    }

    fn basis(&self) -> Basis {
        Basis::new(Vec3::from(self.state.desc.camera.up))
    }

    /// (azimuth deg, elevation deg, distance) of a light around the scene centre, in the
    /// camera's up frame (azimuth 0 = +Z for a Y-up scene).
    pub fn light_spherical(&self, i: usize) -> (f32, f32, f32) {
        let Some(l) = self.state.desc.lights.get(i) else {
            return (0.0, 0.0, 1.0);
        };
        let off = Vec3::from(l.position) - self.centre();
        let (yaw, pitch) = self.basis().angles(off);
        (yaw.to_degrees(), pitch.to_degrees(), off.length())
    }

    pub fn set_light_spherical(&mut self, i: usize, az_deg: f32, el_deg: f32, dist: f32) {
        let centre = self.centre();
        let offset = self
            .basis()
            .offset(az_deg.to_radians(), el_deg.to_radians());
        if let Some(l) = self.state.desc.lights.get_mut(i) {
            l.position = (centre + offset * dist.max(1e-6)).to_array();
            self.dirty.update = true;
        }
    }

    /// Shift-drag in the view: swings the selected light around the scene centre like the
    /// orbit camera (a drag across the view height = half a turn).
    pub fn drag_light(&mut self, dx: f32, dy: f32, view_height_px: f32) {
        let i = self.ui.light;
        if i >= self.state.desc.lights.len() {
            return;
        }
        let (az, el, dist) = self.light_spherical(i);
        let k = ORBIT_RADIANS_PER_HEIGHT.to_degrees() / view_height_px.max(1.0);
        let el = (el + dy * k).clamp(-89.0, 89.0);
        self.set_light_spherical(i, az - dx * k, el, dist);
    }

    pub fn aim_light_at_centre(&mut self, i: usize) {
        let c = self.centre().to_array();
        if let Some(l) = self.state.desc.lights.get_mut(i)
            && l.position != c
        {
            l.target = c;
            self.dirty.update = true;
        }
    }

    /// A copy of the selected light swung 40 degrees round (or a light at the eye).
    pub fn add_light(&mut self) {
        if self.state.desc.lights.len() >= subsurface_render::uniforms::MAX_LIGHTS {
            self.error(format!(
                "lights: at most {} are supported",
                subsurface_render::uniforms::MAX_LIGHTS
            ));
            return;
        }
        let i = self.ui.light;
        let new = match self.state.desc.lights.get(i) {
            Some(l) => l.clone(),
            None => LightDesc {
                kind: LightKind::Point,
                position: self.state.desc.camera.position,
                target: self.state.desc.camera.target,
                ..Default::default()
            },
        };
        self.state.desc.lights.push(new);
        let j = self.state.desc.lights.len() - 1;
        if i < j {
            let (az, el, d) = self.light_spherical(j);
            self.set_light_spherical(j, az + 40.0, el, d);
        }
        self.ui.light = j;
        self.dirty.update = true;
    }

    pub fn remove_light(&mut self, i: usize) {
        if i < self.state.desc.lights.len() {
            self.state.desc.lights.remove(i);
            self.ui.light = i.min(self.state.desc.lights.len().saturating_sub(1));
            self.dirty.update = true;
        }
    }

    /// Applies a material edit made on object `ui.object` (`before` is its material before
    /// the edit) to every object when `edit_all_objects` is on: only the changed fields.
    pub fn material_edited(&mut self, before: &MaterialDesc) {
        let i = self.ui.object;
        let Some(after) = self.state.desc.objects.get(i).map(|o| o.material.clone()) else {
            return;
        };
        if &after == before {
            return;
        }
        self.dirty.update = true;
        if !self.ui.edit_all_objects {
            return;
        }
        for (j, o) in self.state.desc.objects.iter_mut().enumerate() {
            if j != i {
                copy_changed(before, &after, &mut o.material);
            }
        }
    }

    /// Copies the scene description's edits into the loaded scene the renderer reads.
    /// Errors (a value out of range) leave the renderer on the last good state.
    pub fn sync_scene(&mut self) -> Result<()> {
        self.state.desc = self.state.desc_for_save();
        self.state.desc.validate("viewer")?;
        self.scene.desc = self.state.desc.clone();
        for (o, d) in self.scene.objects.iter_mut().zip(&self.state.desc.objects) {
            // Albedo holds the glTF colour factor, which edits never touch.
            o.material = d.material.clone();
            o.transform = d.transform();
            o.mm_per_unit = d.mm_per_unit;
        }
        Ok(())
    }

    /// Opens a dropped or typed path: a scene file, or a glTF/GLB model that replaces the
    /// scene's objects (lights and camera refitted as `render --model` does).
    pub fn open(&mut self, path: &Path) {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let result = match ext.as_str() {
            "toml" => self.open_scene(path),
            "glb" | "gltf" => self.open_model(path),
            _ => Err(anyhow::anyhow!(
                "{}: not a scene (.toml) or model (.glb, .gltf)",
                path.display()
            )),
        };
        match result {
            Ok(()) => self.info(format!("opened {}", path.display())),
            Err(e) => self.error(format!("{e:#}")),
        }
    }

    fn open_scene(&mut self, path: &Path) -> Result<()> {
        let (state, scene) = ViewerState::load_with_scene(path)?;
        let size = (self.state.desc.render.width, self.state.desc.render.height);
        let (compare, b, split) = (self.state.compare, self.state.b.clone(), self.state.split);
        *self = Model {
            log: std::mem::take(&mut self.log),
            stats: std::mem::take(&mut self.stats),
            ..Model::new(state, scene, Some(path))
        };
        // The window keeps its size and comparison; the file's size is only its aspect.
        self.state.desc.render.width = size.0;
        self.state.desc.render.height = size.1;
        self.state.compare = compare;
        self.state.b = b;
        self.state.split = split;
        self.dirty.rebuild = true;
        Ok(())
    }

    fn open_model(&mut self, path: &Path) -> Result<()> {
        let mut scene = self.scene.clone();
        scene
            .replace_model(path)
            .with_context(|| format!("{}: cannot load the model", path.display()))?;
        self.state.desc = scene.desc.clone();
        self.scene = scene;
        self.home_camera = self.state.desc.camera.clone();
        self.camera = Controller::new(&self.home_camera);
        self.ui.object = 0;
        self.ui.light = self
            .ui
            .light
            .min(self.state.desc.lights.len().saturating_sub(1));
        self.dirty.rebuild = true;
        Ok(())
    }

    pub fn save_scene(&mut self, path: &Path) {
        match self.state.save(path) {
            Ok(()) => self.info(format!(
                "saved {}; render it with: {}",
                path.display(),
                ViewerState::render_command(path)
            )),
            Err(e) => self.error(format!("{e:#}")),
        }
    }
}

/// Copies each field that differs between `before` and `after` into `dst`.
fn copy_changed(before: &MaterialDesc, after: &MaterialDesc, dst: &mut MaterialDesc) {
    macro_rules! fields {
        ($($f:ident),*) => {$(
            if before.$f != after.$f {
                dst.$f = after.$f.clone();
            }
        )*};
    }
    fields!(
        albedo,
        roughness,
        specular,
        sss_strength,
        sss_width,
        translucency,
        medium,
        kernel_strength,
        falloff
    );
}

/// The path of a file given on the command line or typed in the panel: `~` is not expanded
/// by a text field, so do it here.
pub fn typed_path(s: &str) -> PathBuf {
    let s = s.trim();
    match (s.strip_prefix("~/"), std::env::var_os("HOME")) {
        (Some(rest), Some(home)) => PathBuf::from(home).join(rest),
        _ => PathBuf::from(s),
    }
}

/// Edits of the generated settings (view/setting.rs).
impl Model {
    /// Sets `key` of side `which` to `value` with the scene file's checks; a refused value
    /// is kept, with its one-line error, until the next edit of the key. Whether it applied.
    pub fn set_setting(&mut self, which: Which, key: &'static str, value: Value) -> bool {
        self.forget_rejected(which, key);
        match self.state.set(which, key, &value.text()) {
            Ok(()) => {
                self.dirty.update = true;
                true
            }
            Err(e) => {
                let error = e.to_string().replace('\n', " ");
                self.ui.rejected.push(Rejected {
                    which,
                    key,
                    value,
                    error,
                });
                false
            }
        }
    }

    /// The refused edit of `key` on side `which`, if its error is showing.
    pub fn rejected(&self, which: Which, key: &str) -> Option<&Rejected> {
        self.ui
            .rejected
            .iter()
            .find(|r| r.which == which && r.key == key)
    }

    /// Drops a refused edit: the value shown is the setting's again.
    pub fn forget_rejected(&mut self, which: Which, key: &str) {
        self.ui
            .rejected
            .retain(|r| !(r.which == which && r.key == key));
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::path::PathBuf;
    use subsurface_render::scene::DEFAULT_SCENE_TOML;

    /// A model of the default scene, without a window.
    pub(crate) fn model() -> Model {
        let state =
            ViewerState::from_toml_str(DEFAULT_SCENE_TOML, PathBuf::from("."), "default").unwrap();
        Model::new(state, Scene::default_scene(), None)
    }

    #[test]
    fn light_sliders_round_trip() {
        let mut m = model();
        let (az, el, d) = m.light_spherical(0);
        m.set_light_spherical(0, az, el, d);
        let p = Vec3::from(m.state.desc.lights[0].position);
        let want = Vec3::from(Scene::default_scene().desc.lights[0].position);
        assert!((p - want).length() < 1e-5, "{p} vs {want}");
        m.set_light_spherical(0, 90.0, 0.0, 0.5);
        let p = Vec3::from(m.state.desc.lights[0].position) - m.centre();
        assert!((p - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-5, "{p}");
        assert!(m.dirty.update);
    }

    #[test]
    fn light_drag_keeps_distance() {
        let mut m = model();
        let (_, _, d) = m.light_spherical(1);
        m.ui.light = 1;
        m.drag_light(50.0, -20.0, 400.0);
        let (_, _, d2) = m.light_spherical(1);
        assert!((d - d2).abs() < 1e-5);
    }

    #[test]
    fn material_edits_spread_only_changed_fields() {
        let mut m = model();
        let before = m.state.desc.objects[0].material.clone();
        let other_translucency = m.state.desc.objects[1].material.translucency;
        m.state.desc.objects[0].material.sss_width = 2.0;
        m.material_edited(&before);
        assert_eq!(m.state.desc.objects[1].material.sss_width, 2.0);
        assert_eq!(
            m.state.desc.objects[1].material.translucency,
            other_translucency
        );
        m.sync_scene().unwrap();
        assert_eq!(m.scene.objects[1].material.sss_width, 2.0);
    }

    #[test]
    fn invalid_edits_are_errors_not_panics() {
        let mut m = model();
        m.state.desc.objects[0].material.sss_width = -1.0;
        let e = m.sync_scene().unwrap_err().to_string();
        assert!(e.contains("sss_width"), "{e}");
    }

    #[test]
    fn add_and_remove_lights() {
        let mut m = model();
        let n = m.state.desc.lights.len();
        m.add_light();
        assert_eq!(m.state.desc.lights.len(), n + 1);
        assert_eq!(m.ui.light, n);
        m.remove_light(n);
        assert_eq!(m.state.desc.lights.len(), n);
        for _ in 0..20 {
            m.add_light();
        }
        assert_eq!(
            m.state.desc.lights.len(),
            subsurface_render::uniforms::MAX_LIGHTS
        );
        assert!(m.log.iter().any(|(l, _)| *l == Level::Error));
    }
}
