//! `roadvo sensitivity`.

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};
use roadvo_sim::sensitivity::{format_learned, format_rows, sensitivity};
use std::path::PathBuf;

/// The paper's sensitivity study on the s-course.
#[derive(clap::Args)]
pub struct SensitivityArgs {
    /// Folder to render into (default: a temporary folder, removed afterwards); drives
    /// already there are reused.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Seed of the texture and noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Render only the first N frames of each drive (default: the whole course).
    #[arg(long)]
    frames: Option<usize>,
    /// Change one value of every case's mount file (after the case's own change), as its
    /// line would: KEY=VALUE in [odometer], or SECTION.KEY=VALUE.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    settings: Vec<String>,
}

impl SensitivityArgs {
    pub fn run(self) -> Result<()> {
        let tmp = tempfile::Builder::new()
            .prefix("roadvo-sensitivity-")
            .tempdir()?;
        let out = self.out.unwrap_or_else(|| tmp.path().to_owned());
        let bar = ProgressBar::new_spinner().with_style(
            ProgressStyle::with_template("{spinner} {elapsed} {msg}").expect("valid template"),
        );
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        let rows = sensitivity(&out, self.seed, self.frames, &self.settings, |what| {
            bar.set_message(what.to_string())
        })?;
        bar.finish_and_clear();
        println!(
            "s-course, seed {}: translation = path length error (positive: too long), \
             rotation = final heading error over the path length",
            self.seed
        );
        for s in &self.settings {
            println!("every case with --set {s}");
        }
        println!();
        print!("{}", format_rows(&rows));
        println!(
            "\nThe mount the pitch vote learned (corrections to the case's mount file, with their \
             standard errors; a roll, pitch, yaw or longitudinal case's should reverse its \
             change, the lateral and vertical offsets are not learned, and a road case's mount \
             file is exact):\n"
        );
        print!("{}", format_learned(&rows));
        Ok(())
    }
}
