//! Parsing a scene file and checking every value (ranges in `docs/guide.md`).

use glam::Vec3;

use super::desc::{LightKind, MeshDesc, SceneDesc};
use super::error::{SceneError, one_line};

fn line_col(s: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(s.len());
    let before = &s.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let col = s[line_start..offset].chars().count() + 1;
    (line, col)
}

/// A TOML error as a [`SceneError::Toml`] naming the file, `line:col` and the key path.
fn toml_error(s: &str, file: &str, mut e: toml::de::Error) -> SceneError {
    let line_col = e.span().map(|sp| line_col(s, sp.start));
    let msg = one_line(e.message());
    // Without its input, toml's Display appends "in `a.b.c`" (the key path).
    e.set_input(None);
    let keys = e.to_string().lines().rev().find_map(|l| {
        l.strip_prefix("in `")?
            .strip_suffix('`')
            .map(str::to_string)
    });
    SceneError::Toml {
        file: file.to_string(),
        line_col,
        msg: match keys {
            Some(k) if !k.is_empty() => format!("{k}: {msg}"),
            _ => msg,
        },
    }
}

/// A 32-bit field written as `1e39` reads as infinity: "(got inf)" said nothing of what was
/// written, so an infinite value is explained as the overflow it (almost always) is.
pub(crate) fn explain_inf(msg: &str) -> String {
    const OUT: &str = "out of the 32-bit float range, whose largest is 3.4e38";
    msg.replace("(got inf)", &format!("(got inf: {OUT})"))
        .replace("(got -inf)", &format!("(got -inf: {OUT})"))
}

/// The longest target - position a camera or light may have: its square must stay a finite
/// f32 for the direction to normalise.
const MAX_SPAN: f32 = 1.8e19;

struct Check<'a> {
    file: &'a str,
}

impl Check<'_> {
    fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_string(),
            field: field.into(),
            msg: msg.into(),
        }
    }
    /// `x` must be finite and satisfy `ok`; `rule` reads e.g. "> 0".
    fn num(&self, field: &str, x: f32, ok: bool, rule: &str) -> Result<(), SceneError> {
        if x.is_finite() && ok {
            Ok(())
        } else if rule.is_empty() {
            Err(self.err(field, explain_inf(&format!("must be finite (got {x})"))))
        } else {
            Err(self.err(
                field,
                explain_inf(&format!("must be finite and {rule} (got {x})")),
            ))
        }
    }
    fn finite(&self, field: &str, x: f32) -> Result<(), SceneError> {
        self.num(field, x, true, "")
    }
    fn finite3(&self, field: &str, v: [f32; 3]) -> Result<(), SceneError> {
        for (i, x) in v.into_iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), x)?;
        }
        Ok(())
    }
    fn nonneg3(&self, field: &str, v: [f32; 3]) -> Result<(), SceneError> {
        for (i, x) in v.into_iter().enumerate() {
            self.num(&format!("{field}[{i}]"), x, x >= 0.0, ">= 0")?;
        }
        Ok(())
    }
    fn unit3(&self, field: &str, v: [f32; 3]) -> Result<(), SceneError> {
        for (i, x) in v.into_iter().enumerate() {
            self.num(
                &format!("{field}[{i}]"),
                x,
                (0.0..=1.0).contains(&x),
                "in [0, 1]",
            )?;
        }
        Ok(())
    }
    fn positive(&self, field: &str, x: f32) -> Result<(), SceneError> {
        self.num(field, x, x > 0.0, "> 0")
    }
    fn path(&self, field: &str, p: &Option<String>) -> Result<(), SceneError> {
        match p {
            Some(p) if p.trim().is_empty() => Err(self.err(field, "must not be empty")),
            _ => Ok(()),
        }
    }
}

/// A medium's error naming the coefficient in the scene's words:
/// `objects[0].material.medium.sigma_a.r: must be ...`.
fn medium_error(c: &Check, field: &str, e: &subsurface_profile::ProfileError) -> SceneError {
    let e = e.to_string();
    match e.split_once(": ") {
        Some((coeff, msg)) if coeff.starts_with("sigma_") || coeff == "eta" => {
            c.err(format!("{field}.{coeff}"), msg)
        }
        _ => c.err(field, e),
    }
}

/// A `[render]` key that moved is named with its new place before serde refuses it as an
/// unknown field.
fn renamed_render_keys(s: &str, name_for_errors: &str) -> Result<(), SceneError> {
    let Ok(table) = toml::from_str::<toml::Table>(s) else {
        return Ok(()); // serde names the syntax error
    };
    let render = table.get("render").and_then(|r| r.as_table());
    for (old, _) in crate::settings::RENAMED {
        let (t, leaf) = old.split_once('.').expect("renamed keys are in a table");
        let used = render
            .and_then(|r| r.get(t))
            .and_then(|t| t.as_table())
            .is_some_and(|t| t.contains_key(leaf));
        if let Some(e) = used.then(|| crate::settings::renamed(old)).flatten() {
            return Err(SceneError::Invalid {
                file: name_for_errors.to_string(),
                field: e.field,
                msg: e.message,
            });
        }
    }
    Ok(())
}

impl SceneDesc {
    /// Parses and validates a scene. `name_for_errors` names the file in errors.
    pub fn from_toml_str(s: &str, name_for_errors: &str) -> Result<Self, SceneError> {
        let toml_err = |e| toml_error(s, name_for_errors, e);
        renamed_render_keys(s, name_for_errors)?;
        let mut desc: SceneDesc = toml::from_str(s).map_err(toml_err)?;
        desc.apply_render_keys(s, name_for_errors)?;
        desc.validate(name_for_errors)?;
        Ok(desc)
    }

    /// The `[render]` table as the file wrote it: its quality preset first, then its own keys
    /// over it (serde filled the keys the file left out with the default preset's).
    fn apply_render_keys(&mut self, s: &str, name_for_errors: &str) -> Result<(), SceneError> {
        let table: toml::Table = toml::from_str(s).unwrap_or_default();
        let Some(toml::Value::Table(render)) = table.get("render") else {
            return Ok(());
        };
        fn leaves(prefix: &str, t: &toml::Table, out: &mut Vec<(String, String)>) {
            for (k, v) in t {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match v {
                    toml::Value::Table(t) => leaves(&key, t, out),
                    v if key != "quality" => {
                        out.push((key, crate::settings::value_text(v)));
                    }
                    _ => {}
                }
            }
        }
        let mut keys = Vec::new();
        leaves("", render, &mut keys);
        self.render_keys = super::desc::RenderKeys(keys);
        let quality = self.render.quality;
        self.set_quality(quality).map_err(|e| SceneError::Invalid {
            file: name_for_errors.to_string(),
            field: format!("render.{}", e.field.trim_start_matches("render.")),
            msg: e.message,
        })
    }

    /// Serialises to TOML; `from_toml_str` of the result gives back `self`.
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("a SceneDesc always serialises to TOML")
    }

    /// Checks every number (see `docs/guide.md` for the ranges).
    pub fn validate(&self, name_for_errors: &str) -> Result<(), SceneError> {
        let c = Check {
            file: name_for_errors,
        };
        // camera
        let cam = &self.camera;
        c.finite3("camera.position", cam.position)?;
        c.finite3("camera.target", cam.target)?;
        c.finite3("camera.up", cam.up)?;
        c.num(
            "camera.fov_y_deg",
            cam.fov_y_deg,
            cam.fov_y_deg > 0.0 && cam.fov_y_deg < 180.0,
            "in (0, 180)",
        )?;
        c.positive("camera.near", cam.near)?;
        c.num("camera.far", cam.far, cam.far > cam.near, "> camera.near")?;
        // The z-buffer and linear depth are 32-bit floats: past a far/near ratio of 1e6 the
        // depth test and the SSS depth edges lose all precision (near = 1e-30 drew garbage).
        c.num(
            "camera.near",
            cam.near,
            cam.near >= cam.far * 1e-6,
            "at least camera.far / 1e6",
        )?;
        let dir = Vec3::from(cam.target) - Vec3::from(cam.position);
        if dir.length_squared() == 0.0 {
            return Err(c.err("camera.target", "must differ from camera.position"));
        }
        // The view direction is normalised in f32: past |d|^2 = f32::MAX it became (0, 0, 0)
        // or NaN, and the frame was garbage.
        if !dir.length_squared().is_finite() {
            return Err(c.err(
                "camera.target",
                format!("must be within {MAX_SPAN:e} units of camera.position"),
            ));
        }
        let up = Vec3::from(cam.up);
        if up.cross(dir).length_squared() <= 1e-12 * up.length_squared() * dir.length_squared() {
            return Err(c.err(
                "camera.up",
                "must be non-zero and not parallel to the view direction",
            ));
        }
        // render
        self.render
            .validate()
            .map_err(|e| c.err(format!("render.{}", e.field), explain_inf(&e.message)))?;
        // lights
        let max_lights = crate::uniforms::MAX_LIGHTS;
        if self.lights.len() > max_lights {
            return Err(c.err(
                "lights",
                format!(
                    "at most {max_lights} lights are supported (got {})",
                    self.lights.len()
                ),
            ));
        }
        for (i, l) in self.lights.iter().enumerate() {
            let f = |k: &str| format!("lights[{i}].{k}");
            c.finite3(&f("position"), l.position)?;
            c.finite3(&f("target"), l.target)?;
            c.nonneg3(&f("color"), l.color)?;
            c.num(&f("intensity"), l.intensity, l.intensity >= 0.0, ">= 0")?;
            c.finite(&f("inner_angle_deg"), l.inner_angle_deg)?;
            c.finite(&f("outer_angle_deg"), l.outer_angle_deg)?;
            if l.kind == LightKind::Spot {
                c.num(
                    &f("inner_angle_deg"),
                    l.inner_angle_deg,
                    l.inner_angle_deg > 0.0 && l.inner_angle_deg <= l.outer_angle_deg,
                    "> 0 and <= outer_angle_deg",
                )?;
                c.num(
                    &f("outer_angle_deg"),
                    l.outer_angle_deg,
                    l.outer_angle_deg < 90.0,
                    "< 90",
                )?;
            }
            if l.kind != LightKind::Point && l.position == l.target {
                return Err(c.err(
                    f("target"),
                    "must differ from position (it gives the light direction)",
                ));
            }
            let span = Vec3::from(l.target) - Vec3::from(l.position);
            if l.kind != LightKind::Point && !span.length_squared().is_finite() {
                return Err(c.err(
                    f("target"),
                    format!("must be within {MAX_SPAN:e} units of position"),
                ));
            }
            let s = l.shadow_map_size;
            if s != 0 && !(16..=8192).contains(&s) {
                return Err(c.err(
                    f("shadow_map_size"),
                    format!("must be 0 (no shadow) or in 16..=8192 (got {s})"),
                ));
            }
            c.num(
                &f("shadow_bias"),
                l.shadow_bias,
                l.shadow_bias >= 0.0,
                ">= 0",
            )?;
        }
        // objects
        for (i, o) in self.objects.iter().enumerate() {
            let f = |k: &str| format!("objects[{i}].{k}");
            if let MeshDesc::Gltf { path } = &o.mesh {
                c.path(&f("mesh.gltf"), &Some(path.clone()))?;
            }
            for (name, size) in o.mesh.sizes() {
                c.positive(&f(&format!("mesh.{name}")), size)?;
            }
            if let MeshDesc::Sphere { segments, .. } | MeshDesc::Cylinder { segments, .. } = o.mesh
                && !(3..=1024).contains(&segments)
            {
                return Err(c.err(
                    f("mesh.segments"),
                    format!("must be in 3..=1024 (got {segments})"),
                ));
            }
            let max = crate::mesh::MAX_TESSELLATION;
            if !(1..=max).contains(&o.tessellate) {
                return Err(c.err(
                    f("tessellate"),
                    format!("must be in 1..={max} (got {})", o.tessellate),
                ));
            }
            c.positive(&f("mm_per_unit"), o.mm_per_unit)?;
            c.finite3(&f("translation"), o.translation)?;
            c.finite3(&f("rotation_deg"), o.rotation_deg)?;
            c.positive(&f("scale"), o.scale)?;
            let m = &o.material;
            let f = |k: &str| format!("objects[{i}].material.{k}");
            c.nonneg3(&f("albedo"), m.albedo)?;
            c.path(&f("albedo_texture"), &m.albedo_texture)?;
            c.path(&f("normal_texture"), &m.normal_texture)?;
            c.path(&f("specular_texture"), &m.specular_texture)?;
            c.num(
                &f("roughness"),
                m.roughness,
                m.roughness > 0.0 && m.roughness <= 1.0,
                "in (0, 1]",
            )?;
            c.num(&f("specular"), m.specular, m.specular >= 0.0, ">= 0")?;
            c.num(
                &f("sss_strength"),
                m.sss_strength,
                (0.0..=1.0).contains(&m.sss_strength),
                "in [0, 1]",
            )?;
            c.positive(&f("sss_width"), m.sss_width)?;
            c.num(
                &f("translucency"),
                m.translucency,
                m.translucency >= 0.0,
                ">= 0",
            )?;
            // The medium is checked here, not when the GPU scene is built: a scene that
            // validates also loads (unknown preset, coefficient <= 0 or NaN, bad eta).
            m.medium
                .material()
                .map_err(|e| medium_error(&c, &f("medium"), &e))?;
            if let Some(k) = m.kernel_strength {
                c.unit3(&f("kernel_strength"), k)?;
            }
            if let Some(k) = m.falloff {
                c.unit3(&f("falloff"), k)?;
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------- loaded scene
