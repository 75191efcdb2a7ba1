//! `roadvo simulate`.

use super::{Bar, bar};
use anyhow::{Context, Result};
use roadvo_sim::scenario::{BUILT_IN, Scenario};
use roadvo_sim::simulate::{sequence_dir, simulate};
use std::path::{Path, PathBuf};

/// Render a synthetic drive with exact ground truth, in KITTI layout.
#[derive(clap::Args)]
pub struct SimulateArgs {
    /// A built-in scenario (s-course, kitti-like) or a scenario TOML file.
    #[arg(long, default_value = "s-course")]
    scenario: String,
    /// Partial scenarios merged over it, in order: built-in (suspension, traffic, slip,
    /// crossing, wide-lens) or files.
    #[arg(long)]
    overlay: Vec<String>,
    /// Output folder: OUT/sequences/00/..., OUT/poses/00.txt.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Seed of the texture, noise and suspension phases.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Render only the first N frames (default: until the path ends).
    #[arg(long)]
    frames: Option<usize>,
    /// Print the scenario as TOML (a starting point for your own) instead of rendering.
    #[arg(long)]
    print_scenario: bool,
}

impl SimulateArgs {
    pub fn run(self) -> Result<()> {
        let sc = Scenario::load(&self.scenario, &self.overlay)?;
        if self.print_scenario {
            match Scenario::built_in_text(&self.scenario) {
                Ok(text)
                    if self.overlay.is_empty() && BUILT_IN.contains(&self.scenario.as_str()) =>
                {
                    print!("{text}")
                }
                _ => print!("{}", sc.to_toml()?),
            }
            return Ok(());
        }
        let out = self.out.context("--out is required to render")?;
        roadvo_sim::interrupt::install();
        render(&sc, &out, self.seed, self.frames)
    }
}

/// Renders `scenario` into `out` with a progress bar, and says what it did.
pub fn render(scenario: &Scenario, out: &Path, seed: u64, frames: Option<usize>) -> Result<()> {
    let progress = Bar(bar(0, "rendering", "frames"));
    let s = simulate(scenario, out, seed, frames, &progress)?;
    progress.0.finish_and_clear();
    println!(
        "rendered {} frames of {} ({:.1} m) in {:.1} s ({:.1} frames/s) into {}",
        s.frames,
        scenario.name,
        s.distance_m,
        s.render_s,
        s.frames as f64 / s.render_s,
        sequence_dir(out).display()
    );
    Ok(())
}
