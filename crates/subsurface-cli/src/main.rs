//! `subsurface`: real-time subsurface scattering for skin, from the command line.

mod bench;
mod cmd_profile;
mod compare;
mod export_mitsuba;
mod output;
mod render;
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
    /// Interactive viewer: orbit/fly cameras, light controls, every parameter live, split-screen
    /// comparisons and per-pass GPU timings.
    View(view::ViewArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // wgpu_hal reports adapters it could not open (e.g. EGL without a display) as errors
    // even when another backend works; they are noise unless debugging (-vv).
    let level = match cli.verbose {
        0 => "warn,wgpu_hal=off",
        1 => "info,wgpu_hal=off,naga=warn,wgpu_core=warn",
        _ => "debug",
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_timestamp(None)
        .init();
    let result = match &cli.command {
        Command::Render(a) => render::run(a, cli.verbose),
        Command::Bench(a) => bench::run(a),
        Command::Kernel(a) => cmd_profile::run_kernel(a),
        Command::Profile(a) => cmd_profile::run_profile(a),
        Command::ExportMitsuba(a) => export_mitsuba::run(a),
        Command::Compare(a) => compare::run(a),
        Command::View(a) => view::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined with ": ", never a backtrace.
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}
