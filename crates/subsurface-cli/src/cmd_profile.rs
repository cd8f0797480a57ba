//! `subsurface kernel` and `subsurface profile`: the no-GPU side of the tool,
//! printing blur kernels, Gaussian fits of diffusion profiles and their plots.

use std::path::PathBuf;

use anyhow::{Context, Result, anyhow, bail};
use plotters::prelude::*;
use subsurface_profile::{
    DEFAULT_FALLOFF, DEFAULT_SAMPLES, DEFAULT_STRENGTH, GaussianFit, KernelParams, Material,
    ProfileError, SlabSolver, SumOfGaussians, material, separable_kernel, separable_kernel_for,
    separable_kernel_projected, separable_range_for, separable_range_projected,
};

use crate::output::{PendingFile, print_summary};
use crate::plot;

/// Print the separable subsurface-scattering blur kernel (Jimenez et al. 2015).
#[derive(Debug, Clone, clap::Args)]
#[command(
    after_help = "Each tap is [r, g, b, offset_mm]; the centre tap (offset 0) comes first, \
the others follow in increasing offset. Channels sum to 1. The shader scales offsets by the \
on-screen size of a millimetre."
)]
pub struct KernelArgs {
    #[command(flatten)]
    params: KernelParamArgs,

    /// Build the kernel from this material's Gaussian fit (all of its terms, per-channel weights)
    /// instead of the skin profile of Separable SSS. See `subsurface profile --help` for names.
    #[arg(long, value_name = "NAME")]
    material: Option<String>,

    /// Gaussians to fit to --material (1 to 12).
    #[arg(long, value_name = "K", default_value_t = 6, requires = "material")]
    gaussians: usize,

    /// Print the kernel as JSON, [[r, g, b, offset_mm], ...], instead of a table.
    #[arg(long)]
    json: bool,
}

/// The flags that make the kernel's [`KernelParams`].
#[derive(Debug, Clone, clap::Args)]
struct KernelParamArgs {
    /// Number of taps: odd, from 3 to 63. Offsets reach 2 mm up to 19 taps and 3 mm above.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_SAMPLES)]
    samples: u32,

    /// Per-channel share of light that is scattered, each in 0..=1, as "R,G,B" or one value
    /// for all channels. 0 keeps the pixel sharp. [default: 0.48,0.41,0.28, or 1,1,1 with --material]
    #[arg(long, value_name = "R,G,B")]
    kernel_strength: Option<String>,

    /// Per-channel width factor, each >= 0, as "R,G,B" or one value: the profile radius is
    /// divided by 0.001 + falloff, so smaller values blur that channel less.
    /// [default: 1.0,0.37,0.3, or 1,1,1 with --material]
    #[arg(long, value_name = "R,G,B")]
    falloff: Option<String>,
}

impl KernelParamArgs {
    /// The parameters, checked. A material's fit carries its own colour, so `for_material`
    /// defaults strength and falloff to 1 where the skin kernel has its own.
    fn params(&self, for_material: bool) -> Result<KernelParams> {
        let (strength0, falloff0) = if for_material {
            ([1.0; 3], [1.0; 3])
        } else {
            (DEFAULT_STRENGTH, DEFAULT_FALLOFF)
        };
        let strength = match &self.kernel_strength {
            Some(s) => parse_rgb("kernel-strength", s)?,
            None => strength0,
        };
        let falloff = match &self.falloff {
            Some(s) => parse_rgb("falloff", s)?,
            None => falloff0,
        };
        let params = KernelParams {
            samples: self.samples,
            strength,
            falloff,
        };
        params.validate().map_err(flag_error)?;
        Ok(params)
    }
}

/// Show a material's diffusion profile R(r), its sum-of-Gaussians fit and the transmittance T(s).
#[derive(Debug, Clone, clap::Args)]
#[command(
    after_help = "Materials: \"skin\" is d'Eon's six-Gaussian skin profile; the others use \
the dipole of Jensen et al. 2001 with their measured coefficients (mm^-1) and eta 1.3: apple, \
chicken1, chicken2, cream, ketchup, marble, potato, skimmilk, skin1, skin2, wholemilk."
)]
pub struct ProfileArgs {
    /// Material preset; case, spaces, '-' and '_' are ignored ("whole milk").
    #[arg(long, value_name = "NAME", default_value = "skin")]
    material: String,

    /// Number of Gaussians to fit (1 to 12).
    #[arg(long, value_name = "K", default_value_t = 6)]
    gaussians: usize,

    /// Treat the material as a slab this thick (mm), using the multipole of Donner and Jensen
    /// 2005 instead of the semi-infinite dipole. Not available for "skin".
    #[arg(long, value_name = "MM")]
    thickness: Option<f64>,

    /// Also draw R(r) (log scale) with its fit and T(s), per channel, into this PNG file;
    /// `-` writes it to standard output and the text to standard error.
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,

    /// Print the fit as JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Prefixes a library error, whose message starts with the field name, with `--`.
fn flag_error(e: ProfileError) -> anyhow::Error {
    // The kernel's `strength` is the materials' `kernel_strength`: one name everywhere.
    let msg = e.to_string();
    match msg.strip_prefix("strength") {
        Some(rest) => anyhow!("--kernel-strength{rest}"),
        None => anyhow!("--{msg}"),
    }
}

/// Parses "R,G,B" (or a single value for all three) for `--flag`.
fn parse_rgb(flag: &str, text: &str) -> Result<[f32; 3]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let values: Vec<f32> = parts
        .iter()
        .map(|p| p.parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow!("--{flag}: expected R,G,B or one number (got {text:?})"))?;
    match values[..] {
        [v] => Ok([v; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => bail!("--{flag}: expected R,G,B or one number (got {text:?})"),
    }
}

fn load_material(name: &str, thickness: Option<f64>) -> Result<Material> {
    let m = material(name).map_err(flag_error)?;
    match thickness {
        None => Ok(m),
        Some(t) => m.with_thickness(t).map_err(|e| {
            anyhow!(
                "--thickness: {}",
                e.to_string().trim_start_matches("thickness_mm: ")
            )
        }),
    }
}

fn fit_material(m: &Material, k: usize) -> Result<GaussianFit> {
    m.fit(k).map_err(|e| match e {
        ProfileError::Count { ref field, .. } if field == "gaussians" => flag_error(e),
        other => anyhow!("--material {}: {other}", m.name()),
    })
}

/// Builds the kernel `args` ask for.
pub fn build_kernel(args: &KernelArgs) -> Result<Vec<[f32; 4]>> {
    let params = args.params.params(args.material.is_some())?;
    match &args.material {
        None => separable_kernel(&params).map_err(flag_error),
        Some(name) => {
            let material = load_material(name, None)?;
            let fit = fit_material(&material, args.gaussians)?;
            // As the renderer builds it: measured materials take the profile's projection.
            if matches!(material, Material::Gaussians { .. }) {
                let range = separable_range_for(&fit.profile, params.samples);
                separable_kernel_for(&fit.profile, &params, range).map_err(flag_error)
            } else {
                let range = separable_range_projected(&fit.profile, params.samples);
                separable_kernel_projected(&fit.profile, &params, range).map_err(flag_error)
            }
        }
    }
}

/// `subsurface kernel`.
pub fn run_kernel(args: &KernelArgs) -> Result<()> {
    let kernel = build_kernel(args)?;
    if args.json {
        println!("{}", serde_json::to_string(&kernel)?);
    } else {
        println!(
            "{:>4} {:>11} {:>10} {:>10} {:>10}",
            "tap", "offset_mm", "r", "g", "b"
        );
        for (i, t) in kernel.iter().enumerate() {
            println!(
                "{i:>4} {:>11.5} {:>10.6} {:>10.6} {:>10.6}",
                t[3], t[0], t[1], t[2]
            );
        }
    }
    Ok(())
}

/// Text description of the material's physical parameters.
fn describe_material(m: &Material) -> String {
    let mut out = String::new();
    let rgb = |v: [f64; 3]| format!("{:>10.5} {:>10.5} {:>10.5}", v[0], v[1], v[2]);
    let dipole = match m {
        Material::Gaussians { profile, .. } => {
            out += &format!(
                "material: {} (sum of {} Gaussians, d'Eon's skin profile; no dipole parameters)\n",
                m.name(),
                profile.terms().len()
            );
            None
        }
        Material::Dipole { dipole, .. } => {
            out += &format!("material: {} (dipole, Jensen et al. 2001)\n", m.name());
            Some(*dipole)
        }
        Material::Multipole { multipole, .. } => {
            out += &format!(
                "material: {} (multipole slab, Donner and Jensen 2005: thickness {} mm, {} dipoles)\n",
                m.name(),
                multipole.thickness_mm,
                2 * multipole.pairs + 1
            );
            Some(multipole.dipole)
        }
    };
    if let Some(d) = dipole {
        let ch = [0, 1, 2].map(|c| d.channel(c));
        out += &format!("{:<28} {:>10} {:>10} {:>10}\n", "", "R", "G", "B");
        out += &format!("{:<28} {}\n", "sigma_a (1/mm)", rgb(d.sigma_a));
        out += &format!("{:<28} {}\n", "sigma_s' (1/mm)", rgb(d.sigma_s_prime));
        out += &format!(
            "{:<28} {}\n",
            "sigma_t' (1/mm)",
            rgb(ch.map(|c| c.sigma_t_prime))
        );
        out += &format!(
            "{:<28} {}\n",
            "reduced albedo alpha'",
            rgb(ch.map(|c| c.alpha_prime))
        );
        out += &format!(
            "{:<28} {}\n",
            "sigma_tr (1/mm)",
            rgb(ch.map(|c| c.sigma_tr))
        );
        out += &format!("{:<28} {}\n", "z_r (mm)", rgb(ch.map(|c| c.z_r)));
        out += &format!("{:<28} {}\n", "z_v (mm)", rgb(ch.map(|c| c.z_v)));
        out += &format!("eta {}  A {:.5}\n", d.eta, d.boundary_a());
    }
    if let Material::Multipole { multipole, .. } = m {
        out += &format!(
            "{:<28} {}\n",
            "total transmittance",
            rgb(multipole.total_transmittance())
        );
    }
    out += &format!(
        "{:<28} {}\n",
        "total diffuse reflectance",
        rgb(m.total_reflectance())
    );
    if let Some(t) = exact_transport(m) {
        out +=
            "exact transport (adding-doubling; what the renderer's colour and `diffusion` use):\n";
        out += &format!("{:<28} {}\n", "  diffuse albedo", rgb(t.albedo));
        if let Some(s) = t.slab {
            // Thick slabs pass 1e-6 of blue: scientific notation.
            let sci = |v: [f64; 3]| format!("{:>10.3e} {:>10.3e} {:>10.3e}", v[0], v[1], v[2]);
            out += &format!("{:<28} {}\n", "  transmitted, scattered", sci(s[0]));
            out += &format!("{:<28} {}\n", "  of which scattered once", sci(s[1]));
            out += &format!("{:<28} {}\n", "  unscattered", sci(s[2]));
        }
    }
    out
}

/// Exact transport through the material's medium: its half-space's diffuse albedo and, for a
/// slab, what crosses it (scattered, scattered once, unscattered). None for the Gaussian
/// preset, which is no medium.
#[derive(Debug, serde::Serialize)]
struct ExactTransport {
    albedo: [f64; 3],
    /// [scattered, scattered once, unscattered] per channel.
    slab: Option<[[f64; 3]; 3]>,
}

fn exact_transport(m: &Material) -> Option<ExactTransport> {
    let (dipole, thickness) = match m {
        Material::Gaussians { .. } => return None,
        Material::Dipole { dipole, .. } => (*dipole, None),
        Material::Multipole { multipole, .. } => (multipole.dipole, Some(multipole.thickness_mm)),
    };
    let solver = SlabSolver::new(dipole.eta).ok()?;
    let ch = [0, 1, 2].map(|c| dipole.channel(c));
    let albedo = ch.map(|c| {
        solver
            .diffuse_reflectance(c.sigma_t_prime, c.alpha_prime)
            .unwrap_or(f64::NAN)
    });
    let slab = thickness.and_then(|s| {
        let r: Vec<_> = ch
            .iter()
            .map(|c| solver.slab(c.sigma_t_prime, c.alpha_prime, s).ok())
            .collect::<Option<_>>()?;
        Some([
            [0, 1, 2].map(|c| r[c].transmitted),
            [0, 1, 2].map(|c| r[c].transmitted_once),
            [0, 1, 2].map(|c| r[c].unscattered),
        ])
    });
    Some(ExactTransport { albedo, slab })
}

fn describe_fit(fit: &GaussianFit) -> String {
    let e = fit.rel_l2_error;
    let mut out = format!(
        "fit: {} Gaussians to r*R(r) over 0..{:.3} mm, relative L2 error R {:.3e} G {:.3e} B {:.3e}\n",
        fit.profile.terms().len(),
        fit.r_max_mm,
        e[0],
        e[1],
        e[2]
    );
    out += &format!(
        "{:>14} {:>10} {:>10} {:>10}\n",
        "variance_mm2", "w_r", "w_g", "w_b"
    );
    for t in fit.profile.terms() {
        out += &format!(
            "{:>14.6} {:>10.6} {:>10.6} {:>10.6}\n",
            t.variance, t.weight[0], t.weight[1], t.weight[2]
        );
    }
    let w = fit.profile.total_weight();
    out += &format!(
        "{:>14} {:>10.6} {:>10.6} {:>10.6}\n",
        "sum", w[0], w[1], w[2]
    );
    out
}

/// `subsurface profile`.
pub fn run_profile(args: &ProfileArgs) -> Result<()> {
    let plot = args.plot.as_deref().map(plot::create_plot).transpose()?;
    let m = load_material(&args.material, args.thickness)?;
    let fit = fit_material(&m, args.gaussians)?;
    // With the plot on stdout (`--plot -`), the text goes to stderr.
    let stdout_taken = plot.as_ref().is_some_and(PendingFile::writes_to_stdout);
    let text = if args.json {
        let json = serde_json::json!({
            "material": m,
            "total_reflectance": m.total_reflectance(),
            "exact_transport": exact_transport(&m),
            "fit": fit,
        });
        format!("{}\n", serde_json::to_string_pretty(&json)?)
    } else {
        describe_material(&m) + &describe_fit(&fit)
    };
    print_summary(stdout_taken, &text);
    if let (Some(pending), Some(path)) = (plot, &args.plot) {
        write_plot(pending, &m, &fit)?;
        if !args.json {
            print_summary(stdout_taken, &format!("plot: {}\n", path.display()));
        }
    }
    Ok(())
}

/// Checks `--plot` before any work: a PNG file name (or standard output) that can be written.
const PLOT_SIZE: (u32, u32) = (1400, 560);

/// Draws the plot and writes it; nothing is left behind if either fails.
fn write_plot(pending: PendingFile, m: &Material, fit: &GaussianFit) -> Result<()> {
    let img = plot::draw_image(PLOT_SIZE, |root| draw_plot(root, m, fit)).context("--plot")?;
    pending.write_png(&img).context("--plot")
}

/// Left: R(r) and the fit on a log axis, over the fitted range. Right: T(s) of the fit.
fn draw_plot(root: &plot::Area, m: &Material, fit: &GaussianFit) -> plot::DrawResult {
    let (left, right) = root.split_horizontally(PLOT_SIZE.0 / 2);
    let n = 400;
    let r_max = fit.r_max_mm;
    let rs: Vec<f64> = (0..=n).map(|i| r_max * i as f64 / n as f64).collect();
    let exact: Vec<[f64; 3]> = rs.iter().map(|&r| m.profile(r)).collect();
    let fitted: Vec<[f64; 3]> = rs.iter().map(|&r| fit.profile.eval(r)).collect();
    let y_max = exact
        .iter()
        .flat_map(|v| v.iter().copied())
        .fold(0.0, f64::max)
        .max(1e-12)
        * 2.0;
    let y_min = y_max * 1e-7;
    let caption = format!(
        "{}: R(r) (solid) and {}-Gaussian fit (dashed)",
        m.name(),
        fit.profile.terms().len()
    );
    let mut chart = plot::chart_builder(&left, caption, 70)
        .build_cartesian_2d(0.0..r_max, (y_min..y_max).log_scale())?;
    plot::axes(&mut chart, "r (mm)", "R(r) (1/mm^2)", true)?;
    for (c, color) in plot::CHANNEL_COLORS.into_iter().enumerate() {
        let channel = |v: &[[f64; 3]]| -> Vec<(f64, f64)> {
            rs.iter()
                .zip(v)
                .map(|(&r, v)| (r, v[c].max(y_min)))
                .collect()
        };
        let label = format!("{} profile", plot::CHANNEL_NAMES[c]);
        plot::line(&mut chart, channel(&exact), color, label)?;
        plot::dashed(&mut chart, channel(&fitted), color, (8, 5))?;
    }
    plot::legend(&mut chart, 14)?;

    // Right: T(s) of the fit, normalised so T(0) = 1 as the skin shader uses it.
    let t_profile: SumOfGaussians = fit
        .profile
        .normalized()
        .unwrap_or_else(|_| fit.profile.clone());
    let v_max = t_profile
        .terms()
        .iter()
        .map(|t| t.variance)
        .fold(0.0, f64::max);
    let s_max = (2.5 * v_max.sqrt()).clamp(1.0, r_max.max(1.0));
    let ss: Vec<f64> = (0..=n).map(|i| s_max * i as f64 / n as f64).collect();
    let mut chart = plot::chart_builder(&right, "transmittance T(s) of the fit, T(0) = 1", 60)
        .build_cartesian_2d(0.0..s_max, 0.0..1.05)?;
    plot::axes(&mut chart, "thickness s (mm)", "T(s)", false)?;
    for (c, color) in plot::CHANNEL_COLORS.into_iter().enumerate() {
        let points = ss.iter().map(|&s| (s, t_profile.transmittance(s)[c]));
        plot::line(&mut chart, points, color, plot::CHANNEL_NAMES[c])?;
    }
    plot::legend(&mut chart, 14)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kernel_args(samples: u32) -> KernelArgs {
        KernelArgs {
            params: KernelParamArgs {
                samples,
                kernel_strength: None,
                falloff: None,
            },
            material: None,
            gaussians: 6,
            json: true,
        }
    }

    #[test]
    fn kernel_defaults_match_the_library() {
        let k = build_kernel(&kernel_args(17)).unwrap();
        assert_eq!(k, separable_kernel(&KernelParams::default()).unwrap());
        assert_eq!(k[0][3], 0.0);
        let json = serde_json::to_string(&k).unwrap();
        let back: Vec<[f32; 4]> = serde_json::from_str(&json).unwrap();
        assert_eq!(back, k);
    }

    #[test]
    fn kernel_flags_are_parsed_and_checked() {
        let mut a = kernel_args(9);
        a.params.kernel_strength = Some("1, 1,1".into());
        a.params.falloff = Some("0.5".into());
        let k = build_kernel(&a).unwrap();
        let s: f32 = k.iter().map(|t| t[1]).sum();
        assert!((s - 1.0).abs() < 1e-5);

        let e = build_kernel(&kernel_args(4)).unwrap_err().to_string();
        assert_eq!(e, "--samples: must be odd and in 3..=63 (got 4)");
        a.params.kernel_strength = Some("1,2".into());
        let e = build_kernel(&a).unwrap_err().to_string();
        assert!(e.starts_with("--kernel-strength: expected R,G,B"), "{e}");
        a.params.kernel_strength = Some("0.5,1.5,0.5".into());
        let e = build_kernel(&a).unwrap_err().to_string();
        assert!(
            e.starts_with("--kernel-strength.g: must be in 0..=1"),
            "{e}"
        );
        a.params.kernel_strength = None;
        a.params.falloff = Some("nan,1,1".into());
        assert!(
            build_kernel(&a)
                .unwrap_err()
                .to_string()
                .starts_with("--falloff.r: ")
        );
    }

    #[test]
    fn material_kernel_and_bad_material() {
        let mut a = kernel_args(11);
        a.material = Some("skin".into());
        let k = build_kernel(&a).unwrap();
        assert_eq!(k.len(), 11);
        a.material = Some("granite".into());
        let e = build_kernel(&a).unwrap_err().to_string();
        assert!(e.starts_with("--material: unknown name"), "{e}");
        assert!(!e.contains('\n'));
    }

    /// `profile` reports exact transport beside diffusion: skin1's albedo as random walks of
    /// the same medium give it (0.439 / 0.213 / 0.116, docs/lab/fidelity.md), and through 10 mm
    /// about twice diffusion's green; nothing for the Gaussian preset, which is no medium.
    #[test]
    fn profile_reports_exact_transport_for_a_medium() {
        let m = load_material("skin1", Some(10.0)).unwrap();
        let t = exact_transport(&m).unwrap();
        for (c, walk) in [0.439, 0.213, 0.116].iter().enumerate() {
            assert!((t.albedo[c] - walk).abs() < 0.008, "{c}: {}", t.albedo[c]);
        }
        let Material::Multipole { multipole, .. } = &m else {
            panic!("a thickness makes a slab")
        };
        let diffusion = multipole.total_transmittance();
        let s = t.slab.unwrap();
        assert!((1.6..2.3).contains(&(s[0][1] / diffusion[1])), "{s:?}");
        assert!(s[1][0] < 0.01 * s[0][0] && s[2][0] > 0.0);
        let text = describe_material(&m);
        assert!(
            text.contains("exact transport") && text.contains("diffuse albedo"),
            "{text}"
        );
        let skin = load_material("skin", None).unwrap();
        assert!(exact_transport(&skin).is_none());
    }

    #[test]
    fn profile_bad_flags_are_one_line_errors() {
        let args = |material: &str,
                    gaussians: usize,
                    thickness: Option<f64>,
                    plot: Option<&str>| ProfileArgs {
            material: material.into(),
            gaussians,
            thickness,
            plot: plot.map(PathBuf::from),
            json: false,
        };
        let e = run_profile(&args("skin", 0, None, None))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--gaussians: "), "{e}");
        let e = run_profile(&args("skin", 6, Some(2.0), None))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--thickness: "), "{e}");
        let e = run_profile(&args("marble", 6, Some(-1.0), None))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--thickness: must be > 0"), "{e}");
        let e = run_profile(&args("skin", 6, None, Some("out.jpg")))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--plot: "), "{e}");
    }

    #[test]
    fn plot_is_written_atomically() {
        let dir = std::env::temp_dir().join(format!("subsurface-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("skin.png");
        let m = material("skin").unwrap();
        let fit = m.fit(6).unwrap();
        write_plot(plot::create_plot(&path).unwrap(), &m, &fit).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let img = image::open(&path).unwrap();
        assert_eq!((img.width(), img.height()), PLOT_SIZE);
        // Only the final file is left.
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        // A missing directory fails before any work, without leaving anything behind.
        let bad = dir.join("missing").join("x.png");
        let e = format!("{:#}", plot::create_plot(&bad).err().unwrap());
        assert!(
            e.starts_with("--plot: ") && e.ends_with("does not exist"),
            "{e}"
        );
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn plot_may_go_to_stdout_but_a_file_must_be_a_png() {
        assert!(
            plot::create_plot(std::path::Path::new("-"))
                .unwrap()
                .writes_to_stdout()
        );
        if cfg!(target_os = "linux") {
            let p = plot::create_plot(std::path::Path::new("/dev/stdout")).unwrap();
            assert!(p.writes_to_stdout());
        }
        let e = plot::create_plot(std::path::Path::new("plot.jpg"))
            .err()
            .unwrap()
            .to_string();
        assert_eq!(e, "--plot: file name must end in .png (got plot.jpg)");
    }
}
