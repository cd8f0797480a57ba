//! `subsurface`: real-time subsurface scattering for skin, from the command line.

mod bench;
mod cmd_profile;
mod compare;
mod export_mitsuba;
mod output;
mod plot;
mod render;
mod settings_args;
mod view;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "subsurface",
    version,
    about = "Real-time subsurface scattering for human skin (screen-space diffusion, transmittance) on wgpu",
    long_about = "Real-time subsurface scattering for human skin on wgpu.\n\n\
        Run `subsurface render` to render the embedded default scene (a backlit hand and a wedge) \
        to subsurface.png. The GPU adapter is chosen with wgpu's environment variables \
        WGPU_BACKEND (vulkan, gl, metal, dx12) and WGPU_ADAPTER_NAME (substring of the adapter name)."
)]
struct Cli {
    /// More output: -v prints the adapter and per-pass timings, -vv debug logs.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the embedded default scene if none is given) to a PNG.
    Render(render::RenderArgs),
    /// Measure GPU time per pass (timestamp queries) for each SSS method and image size.
    Bench(bench::BenchArgs),
    /// Print the separable SSS kernel (Jimenez et al. 2015) for N taps.
    Kernel(cmd_profile::KernelArgs),
    /// Show a material's diffusion profile, its sum-of-Gaussians fit and T(s); optionally plot them.
    Profile(cmd_profile::ProfileArgs),
    /// Write the scene as a Mitsuba 3 scene (XML + PLY meshes) to path-trace a reference.
    ExportMitsuba(export_mitsuba::ExportArgs),
    /// Render a scene and report its errors against a path-traced reference EXR.
    Compare(compare::CompareArgs),
    /// List every setting of the [render] table by key (as --set and bench --vary take it),
    /// with the scene's value (the default without a scene), its unit and what it does.
    Settings(settings_args::SettingsListArgs),
    /// Interactive viewer: orbit/fly cameras, light controls, every parameter live, split-screen
    /// comparisons and per-pass GPU timings.
    View(view::ViewArgs),
}

fn main() -> ExitCode {
    output::ignore_file_size_signal();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_exit(&e),
    };
    // wgpu_hal reports adapters it could not open (e.g. EGL without a display) as errors
    // even when another backend works; they are noise unless debugging (-vv). winit's X11
    // backend warns about properties a headless X server lacks (XSETTINGS, a 0 mm screen):
    // noise too, and it came before the viewer's one `error:` line.
    let level = match cli.verbose {
        0 => "warn,wgpu_hal=off,winit=error",
        1 => "info,wgpu_hal=off,naga=warn,wgpu_core=warn",
        _ => "debug",
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_timestamp(None)
        .init();
    // The GPU commands check the memory limit's variable before any work (the viewer's
    // renderer is created only after its window opens).
    let gpu = matches!(
        cli.command,
        Command::Render(_) | Command::Bench(_) | Command::Compare(_) | Command::View(_)
    );
    if gpu && let Err(e) = subsurface_render::budget::limit_bytes() {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let result = match &cli.command {
        Command::Render(a) => render::run(a, cli.verbose),
        Command::Bench(a) => bench::run(a),
        Command::Kernel(a) => cmd_profile::run_kernel(a),
        Command::Profile(a) => cmd_profile::run_profile(a),
        Command::ExportMitsuba(a) => export_mitsuba::run(a),
        Command::Compare(a) => compare::run(a),
        Command::View(a) => view::run(a),
        Command::Settings(a) => settings_args::list(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// `--help` and `--version` print as usual; every other parse error becomes the same single
/// `error:` line and exit status 1 as errors found after parsing, without clap's usage block.
fn clap_exit(e: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            ExitCode::SUCCESS
        }
        // Its rendering is the whole help text, which has no error line to keep.
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            eprintln!("error: a subcommand is required (see --help)");
            ExitCode::FAILURE
        }
        _ => {
            eprintln!("error: {}", clap_message(&e.render().to_string()));
            ExitCode::FAILURE
        }
    }
}

/// The first paragraph of clap's rendered error, on one line. Usually that is its first line,
/// but "the following required arguments were not provided:" lists them on the next ones.
fn clap_message(rendered: &str) -> String {
    let first = rendered.trim_start();
    let first = first.strip_prefix("error:").unwrap_or(first);
    first
        .lines()
        .map(str::trim)
        .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The context chain joined with ": " on one line, never a backtrace. A part whose text is
/// already there is skipped: errors that print their source (`{file}: {field}: {source}`)
/// would otherwise repeat it once for themselves and once as the next link of the chain.
fn one_line(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for part in e.chain() {
        let part = part.to_string().replace('\n', " ");
        let part = part.trim();
        // Contained as whole ": "-separated parts, so "0" is not lost inside "--width: 10".
        if part.is_empty() || format!(": {msg}:").contains(&format!(": {part}:")) {
            continue;
        }
        if msg.is_empty() || part.starts_with(msg.as_str()) {
            // A cause that begins with everything said so far says it all.
            msg = part.to_string();
        } else {
            msg = format!("{msg}: {part}");
        }
    }
    msg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_context_is_printed_once() {
        let inner = anyhow::anyhow!("x.png: cannot read: No such file");
        let e = inner.context("s.toml: objects[0].mesh: x.png: cannot read: No such file");
        assert_eq!(
            one_line(&e),
            "s.toml: objects[0].mesh: x.png: cannot read: No such file"
        );
        let e = anyhow::anyhow!("x.png: cannot read: No such file").context("x.png: cannot read");
        assert_eq!(one_line(&e), "x.png: cannot read: No such file");
        let e = anyhow::anyhow!("No such file (os error 2)").context("x.png: cannot write here");
        assert_eq!(
            one_line(&e),
            "x.png: cannot write here: No such file (os error 2)"
        );
        let e = anyhow::anyhow!("0").context("--width: 10");
        assert_eq!(one_line(&e), "--width: 10: 0");
    }

    #[test]
    fn clap_errors_keep_their_first_paragraph() {
        let m = clap_message(
            "error: the following required arguments were not provided:\n  --out <DIR>\n\n\
             Usage: subsurface export-mitsuba --out <DIR>\n\nFor more information, try '--help'.\n",
        );
        assert_eq!(
            m,
            "the following required arguments were not provided: --out <DIR>"
        );
        let m = clap_message(
            "error: unexpected argument '--x' found\n\n  tip: to pass '--x' as a value, use \
             '-- --x'\n\nUsage: subsurface kernel [OPTIONS]\n",
        );
        assert_eq!(m, "unexpected argument '--x' found");
    }
}
