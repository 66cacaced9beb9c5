//! `avatar-studio`: the studio (no subcommand) and the headless command line.

mod cli;

use clap::Parser;

fn main() -> std::process::ExitCode {
    let started = std::time::Instant::now();
    let args = cli::Cli::parse();
    let result = match args.command {
        None => open_studio(args.studio, started),
        Some(command) => cli::run(command),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// No subcommand: the studio window, with the demo capture (or the given capture/project).
fn open_studio(args: cli::StudioArgs, started: std::time::Instant) -> anyhow::Result<()> {
    use avatar_studio::studio::{StudioOptions, run};
    let screenshot = args.screenshot.or_else(|| {
        std::env::var_os("AVATAR_STUDIO_SCREENSHOT").filter(|v| !v.is_empty()).map(Into::into)
    });
    let (project, capture) = match args.open {
        Some(p) if p.to_string_lossy().ends_with(".studio.json") => (Some(p), None),
        Some(p) => (None, Some(p)),
        None => (None, None),
    };
    run(StudioOptions {
        load_demo: true,
        capture,
        project,
        screenshot,
        started: Some(started),
        timing: args.timing || std::env::var_os("AVATAR_STUDIO_TIMING").is_some(),
        auto_fit: args.quick_fit.then(avatar_studio::studio::fit_config::FitConfig::tiny),
        measure_playback: args.measure_playback,
    })?;
    Ok(())
}
