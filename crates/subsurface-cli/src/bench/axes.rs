//! `bench`'s settings axes: each a key of the `[render]` table and the values it takes, from
//! `--vary KEY=V1,V2` or the method flags that stand for it; every combination of them, less
//! those that only repeat another (a value of a key that does not matter in that
//! combination, such as the lateral taps of `paper`).

use anyhow::Result;
use subsurface_render::RenderSettings;

/// One axis: a key below `[render]` and its values as written (TOML syntax).
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub(super) key: String,
    pub(super) values: Vec<String>,
    /// The flag that stands for it (`--lateral-taps`), for errors; `None` for `--vary`.
    pub(super) flag: Option<&'static str>,
}

/// `KEY=V1,V2,..`: the values split at commas outside brackets and quotes, so that an array
/// value (`ambient=[0,0,0],[0.1,0.1,0.1]`) stays whole.
pub(super) fn parse_axis(s: &str) -> Result<Axis, String> {
    let (key, values) = crate::settings_args::parse_key_value(s)?;
    let mut out = Vec::new();
    let (mut depth, mut quoted, mut current) = (0i32, false, String::new());
    for c in values.chars() {
        match c {
            '"' => quoted = !quoted,
            '[' if !quoted => depth += 1,
            ']' if !quoted => depth -= 1,
            ',' if !quoted && depth == 0 => {
                out.push(std::mem::take(&mut current).trim().to_string());
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    out.push(current.trim().to_string());
    if out.iter().any(String::is_empty) {
        return Err(format!("an empty value in {s:?}"));
    }
    Ok(Axis {
        key,
        values: out,
        flag: None,
    })
}

/// An axis for `key` from a flag's list (`--sss none,separable`); none for an empty list (the
/// scene's own value).
pub(super) fn flag_axis<T: ToString>(flag: &'static str, key: &str, values: &[T]) -> Option<Axis> {
    (!values.is_empty()).then(|| Axis {
        key: key.to_string(),
        values: values.iter().map(ToString::to_string).collect(),
        flag: Some(flag),
    })
}

/// One combination: the settings it renders with and each axis's value.
#[derive(Clone, Debug)]
pub(super) struct Combination {
    pub(super) settings: RenderSettings,
    pub(super) values: Vec<(String, String)>,
}

/// Every combination of `axes` over `base`, the last axis varying fastest; a combination is
/// left out where an axis's key does not matter to its settings and takes other than its first
/// value. An axis value the settings refuse is an error naming `--vary` and the key. A quality
/// preset sets its bundle and then `keep` again (the scene's own keys, `--set`'s).
pub(super) fn combinations(
    base: &RenderSettings,
    axes: &[Axis],
    keep: &[(String, String)],
) -> Result<Vec<Combination>> {
    let mut out = vec![Combination {
        settings: base.clone(),
        values: Vec::new(),
    }];
    for axis in axes {
        let mut next = Vec::new();
        for c in &out {
            for v in &axis.values {
                let mut settings = c.settings.clone();
                let error = |e: subsurface_render::settings::InvalidSetting| match axis.flag {
                    Some(flag) => anyhow::anyhow!("{flag}: {}", e.message),
                    None => anyhow::anyhow!("--vary {e}"),
                };
                settings.set(&axis.key, v).map_err(error)?;
                if axis.key.strip_prefix("render.").unwrap_or(&axis.key) == "quality" {
                    for (k, v) in keep {
                        settings.set(k, v).map_err(error)?;
                    }
                }
                let mut values = c.values.clone();
                values.push((axis.key.clone(), v.clone()));
                next.push(Combination { settings, values });
            }
        }
        out = next;
    }
    out.retain(|c| {
        axes.iter()
            .zip(&c.values)
            .all(|(axis, (_, v))| c.settings.matters(&axis.key) || *v == axis.values[0])
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_split_at_top_level_commas() {
        let a = parse_axis("render.ambient=[0,0,0],[0.1, 0.1, 0.1]").unwrap();
        assert_eq!(a.values, ["[0,0,0]", "[0.1, 0.1, 0.1]"]);
        let a = parse_axis("sss.samples=7,17").unwrap();
        assert_eq!((a.key.as_str(), a.values.len()), ("sss.samples", 2));
        assert!(parse_axis("sss.samples=7,,17").is_err());
        assert!(parse_axis("sss.samples").is_err());
    }

    /// The lateral taps vary `diffusion` only: `paper` runs once.
    #[test]
    fn keys_that_do_not_matter_add_no_runs() {
        let axes = [
            parse_axis("transmittance.method=paper,diffusion").unwrap(),
            parse_axis("transmittance.lateral_taps=0,12").unwrap(),
        ];
        let c = combinations(&RenderSettings::default(), &axes, &[]).unwrap();
        let got: Vec<_> = c
            .iter()
            .map(|c| (c.values[0].1.as_str(), c.values[1].1.as_str()))
            .collect();
        assert_eq!(
            got,
            [("paper", "0"), ("diffusion", "0"), ("diffusion", "12")]
        );
        let e = combinations(
            &RenderSettings::default(),
            &[parse_axis("sss.samples=4").unwrap()],
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("--vary render.sss.samples: must be odd"),
            "{e}"
        );
    }
}
