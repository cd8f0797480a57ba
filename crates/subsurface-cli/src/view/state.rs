//! Everything the viewer lets you change, in one value that converts to what the renderer
//! takes (a scene description and `RenderOptions`) and to a scene file that `subsurface
//! render` reproduces.
//!
//! Material, camera, light and exposure edits go into the scene description itself; each side
//! of a comparison holds a clone of the scene's `[render.sss]` and `[render.transmittance]`
//! settings, and the main side's are saved back into them, so a saved scene is a plain scene
//! file: `subsurface render FILE` reproduces the view with no flags.

use std::path::{Path, PathBuf};

use anyhow::Result;
use subsurface_render::scene::{BUILTIN_HAND, MeshDesc, SceneDesc};
use subsurface_render::settings::InvalidSetting;
use subsurface_render::{
    DebugView, RenderOptions, RenderSettings, Scene, SssMethod, SssSettings, TransmittanceSettings,
};

/// Settings of one side of the comparison (the whole view when not comparing): clones of the
/// scene's settings types, plus the debug view.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Side {
    pub sss: SssSettings,
    pub transmittance: TransmittanceSettings,
    pub view: DebugView,
}

impl Side {
    pub fn of(settings: &RenderSettings) -> Self {
        Self {
            sss: settings.sss.clone(),
            transmittance: settings.transmittance.clone(),
            view: DebugView::Final,
        }
    }
}

/// A side of the split screen: `A` the main settings (the whole view, or left of the
/// divider), `B` the comparison (right of it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Which {
    A,
    B,
}

/// Whether `key` (below `[render]`) is one side's own (a [`Side`] holds it) rather than the
/// scene's, which both sides share.
pub fn per_side(key: &str) -> bool {
    key.starts_with("sss.") || key.starts_with("transmittance.")
}

#[derive(Clone, Debug, PartialEq)]
pub struct ViewerState {
    pub desc: SceneDesc,
    /// Directory that relative asset paths in `desc` are resolved against.
    pub base_dir: PathBuf,
    /// The main settings: the whole view, or the left side of a comparison. Saved.
    pub a: Side,
    /// Split screen: `a` left of the divider, `b` right of it. Not saved.
    pub compare: bool,
    pub b: Side,
    /// Divider position as a fraction of the view width.
    pub split: f32,
}

impl ViewerState {
    pub fn new(desc: SceneDesc, base_dir: PathBuf) -> Self {
        let a = Side::of(&desc.render);
        let mut b = a.clone();
        b.sss.method = SssMethod::None;
        Self {
            desc,
            base_dir,
            a,
            compare: false,
            b,
            split: 0.5,
        }
    }

    /// Parses a scene file's text.
    pub fn from_toml_str(text: &str, base_dir: PathBuf, name_for_errors: &str) -> Result<Self> {
        let desc = SceneDesc::from_toml_str(text, name_for_errors)?;
        let state = Self::new(desc, base_dir);
        state
            .options(&state.a)
            .map_err(|e| anyhow::anyhow!("{name_for_errors}: {e:#}"))?;
        Ok(state)
    }

    /// The command that renders a scene saved to `path` exactly as side `a` shows it.
    pub fn render_command(path: &Path) -> String {
        format!("subsurface render {}", path.display())
    }

    /// Scene file text: a one-line header, then the scene. Relative asset
    /// paths are kept when the file goes to the directory they are relative to, and made
    /// absolute otherwise, so the saved scene loads from wherever it is written.
    pub fn to_toml(&self, dest: &Path) -> String {
        let dest_dir = dest
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let same_dir = same_path(dest_dir, &self.base_dir);
        let desc = if same_dir {
            self.desc_for_save()
        } else {
            Self {
                desc: self.desc_for_save(),
                ..self.clone()
            }
            .desc_with_absolute_paths()
        };
        let header =
            "# Scene saved by `subsurface view`; `subsurface render FILE` reproduces the view.\n";
        format!("{header}\n{}", desc.to_toml_string())
    }

    /// `desc` with the main side's settings in `[render]`.
    pub fn desc_for_save(&self) -> SceneDesc {
        let mut d = self.desc.clone();
        d.render.sss = self.a.sss.clone();
        d.render.transmittance = self.a.transmittance.clone();
        d
    }

    /// `desc` with every relative asset path resolved against `base_dir`.
    pub fn desc_with_absolute_paths(&self) -> SceneDesc {
        let abs = |p: &str| -> String {
            let path = Path::new(p);
            if p == BUILTIN_HAND || path.is_absolute() {
                return p.to_string();
            }
            let joined = self.base_dir.join(path);
            std::path::absolute(&joined)
                .unwrap_or(joined)
                .display()
                .to_string()
        };
        let mut d = self.desc.clone();
        for o in &mut d.objects {
            if let MeshDesc::Gltf { path } = &mut o.mesh {
                *path = abs(path);
            }
            let m = &mut o.material;
            for p in [
                &mut m.albedo_texture,
                &mut m.normal_texture,
                &mut m.specular_texture,
            ]
            .into_iter()
            .flatten()
            {
                *p = abs(p);
            }
        }
        d
    }

    pub fn side(&self, which: Which) -> &Side {
        match which {
            Which::A => &self.a,
            Which::B => &self.b,
        }
    }

    /// The settings one side renders with (unchecked): its own over the scene's.
    pub fn settings(&self, which: Which) -> RenderSettings {
        Self::compose(&self.desc.render, self.side(which))
    }

    fn compose(scene: &RenderSettings, side: &Side) -> RenderSettings {
        RenderSettings {
            sss: side.sss.clone(),
            transmittance: side.transmittance.clone(),
            ..scene.clone()
        }
    }

    /// Sets `key` (TOML text, as `--set KEY=VALUE` takes it) for side `which`, with the scene
    /// file's checks: a side's own keys ([`per_side`]) change that side, the others the scene
    /// and so both sides. A refused value changes nothing.
    pub fn set(&mut self, which: Which, key: &str, value: &str) -> Result<(), InvalidSetting> {
        let mut s = self.settings(which);
        s.set(key, value)?;
        let side = match which {
            Which::A => &mut self.a,
            Which::B => &mut self.b,
        };
        side.sss = s.sss.clone();
        side.transmittance = s.transmittance.clone();
        let scene = &mut self.desc.render;
        *scene = RenderSettings {
            sss: scene.sss.clone(),
            transmittance: scene.transmittance.clone(),
            ..s
        };
        Ok(())
    }

    /// Render options for one side, at the scene's size (the viewer keeps that at the
    /// window's size).
    pub fn options(&self, side: &Side) -> Result<RenderOptions> {
        let settings = Self::compose(&self.desc.render, side);
        settings
            .validate()
            .map_err(|e| anyhow::anyhow!("render.{e}"))?;
        Ok(RenderOptions {
            settings,
            view: side.view,
            baseline_copy: false,
        })
    }

    /// Writes the scene file atomically.
    pub fn save(&self, dest: &Path) -> Result<()> {
        let mut pending = crate::output::PendingFile::create(dest)?;
        pending.write_bytes(self.to_toml(dest).as_bytes())?;
        pending.commit()
    }

    /// Reads a scene file saved by the viewer (or any scene file).
    pub fn load(path: &Path) -> Result<Self> {
        let name = path.display().to_string();
        let text = subsurface_render::input::read_regular_text(
            path,
            subsurface_render::input::MAX_TEXT_BYTES,
        )
        .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let base = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        Self::from_toml_str(&text, base, &name)
    }

    /// [`load`](Self::load), and the scene the file describes (meshes and textures loaded).
    pub fn load_with_scene(path: &Path) -> Result<(Self, Scene)> {
        let state = Self::load(path)?;
        let scene = Scene::from_desc(
            state.desc.clone(),
            &state.base_dir,
            &path.display().to_string(),
        )?;
        Ok((state, scene))
    }

    /// Split screen with side `a`'s settings on both sides, but `method` on the right.
    pub fn compare_with(&mut self, method: SssMethod) {
        self.b = self.a.clone();
        self.b.sss.method = method;
        self.compare = true;
    }
}

fn same_path(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => std::path::absolute(a).ok() == std::path::absolute(b).ok(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use subsurface_render::TransmittanceMethod;
    use subsurface_render::scene::{DEFAULT_SCENE_TOML, LightDesc, LightKind};

    fn edited() -> ViewerState {
        let mut s =
            ViewerState::from_toml_str(DEFAULT_SCENE_TOML, PathBuf::from("."), "default").unwrap();
        s.a = Side {
            sss: SssSettings {
                method: SssMethod::Gaussian6,
                samples: 25,
                follow_surface: false,
                gaussians: [true, false, true, true, false],
                ..Default::default()
            },
            transmittance: TransmittanceSettings {
                method: TransmittanceMethod::Beer,
                thickness_filter: 5,
                normal_shrink: 0.0007,
                lateral_taps: 7,
                ..Default::default()
            },
            view: DebugView::Final,
        };
        let d = &mut s.desc;
        d.render.transmitted_map = subsurface_render::TransmittedMapSettings {
            texel_mm: 3.5,
            pass: subsurface_render::MapEvaluation::Fragment,
            outlines: subsurface_render::OutlineChords::Pass,
        };
        d.render.exposure_ev = 1.25;
        d.render.width = 333;
        d.render.height = 211;
        d.camera.position = [0.1, 0.2, 0.45];
        d.lights[0].position = [0.05, 0.1, -0.3];
        d.lights[1].color = [0.3, 0.6, 0.9];
        d.lights[1].shadow_map_size = 0;
        d.lights.push(LightDesc {
            kind: LightKind::Point,
            position: [0.0, 0.3, 0.3],
            intensity: 0.07,
            ..Default::default()
        });
        let m = &mut d.objects[0].material;
        m.sss_width = 1.7;
        m.translucency = 2.5;
        m.medium = subsurface_profile::Medium::Preset("marble".into());
        m.kernel_strength = Some([0.5, 0.3, 0.2]);
        m.falloff = Some([0.9, 0.4, 0.35]);
        s
    }

    #[test]
    fn defaults_match_render_without_flags() {
        let s =
            ViewerState::from_toml_str(DEFAULT_SCENE_TOML, PathBuf::from("."), "default").unwrap();
        let o = s.options(&s.a).unwrap();
        let scene = subsurface_render::Scene::default_scene();
        let r = RenderOptions::from_scene(&scene);
        assert_eq!(o.settings, r.settings);
    }

    #[test]
    fn saved_scene_reads_back_to_the_same_state() {
        let dir = std::env::temp_dir().join(format!("subsurface-view-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("saved.toml");
        let s = edited();
        s.save(&file).unwrap();
        let back = ViewerState::load(&file).unwrap();
        let saved = ViewerState {
            desc: s.desc_for_save(),
            ..s.clone()
        };
        assert_eq!(back.desc, saved.desc_with_absolute_paths());
        assert_eq!(back.a, s.a);
        assert_eq!(
            back.options(&back.a).unwrap().settings,
            s.options(&s.a).unwrap().settings
        );
        // Saving the loaded state again gives the same file.
        let file2 = dir.join("again.toml");
        back.save(&file2).unwrap();
        assert_eq!(
            std::fs::read_to_string(&file).unwrap(),
            std::fs::read_to_string(&file2).unwrap()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn saved_scene_renders_the_same_options_without_flags() {
        let s = edited();
        let text = s.to_toml(Path::new("x.toml"));
        // `render`'s own argument parser with no flags at all, on the saved text.
        #[derive(clap::Parser)]
        struct R {
            #[command(flatten)]
            settings: crate::settings_args::SettingsArgs,
        }
        let r = <R as clap::Parser>::try_parse_from(["render"]).unwrap();
        let mut scene = subsurface_render::Scene::from_desc(
            SceneDesc::from_toml_str(&text, "x.toml").unwrap(),
            Path::new("."),
            "x.toml",
        )
        .unwrap();
        let want = s.options(&s.a).unwrap();
        r.settings.apply(&mut scene).unwrap();
        assert_eq!(RenderOptions::from_scene(&scene).settings, want.settings);
        // The switches that used to live only in the viewer are scene keys now.
        assert!(text.contains("follow_surface = false"), "{text}");
        assert!(
            text.contains("gaussians = [true, false, true, true, false]"),
            "{text}"
        );
    }

    #[test]
    fn relative_paths_become_absolute_elsewhere() {
        let text = DEFAULT_SCENE_TOML.replace("builtin:hand", "models/hand.glb");
        let s = ViewerState::from_toml_str(&text, PathBuf::from("/data/scenes"), "t").unwrap();
        let there = s.to_toml(Path::new("/elsewhere/out.toml"));
        assert!(there.contains("/data/scenes/models/hand.glb"), "{there}");
        let d = s.desc_with_absolute_paths();
        assert!(
            matches!(&d.objects[0].mesh, MeshDesc::Gltf { path } if path == "/data/scenes/models/hand.glb")
        );
    }

    #[test]
    fn bad_scene_keys_are_one_line_errors() {
        let text =
            DEFAULT_SCENE_TOML.replace("[render]", "[render.sss]\ngaussians = [true, 1]\n[render]");
        let e = ViewerState::from_toml_str(&text, PathBuf::from("."), "s.toml").unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.starts_with("s.toml") && msg.contains("gaussians"),
            "{msg}"
        );
        assert!(!msg.contains('\n'), "{msg}");
    }
}
