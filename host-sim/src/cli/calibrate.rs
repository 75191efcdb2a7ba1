//! `roadvo calibrate`.

use super::SequenceArgs;
use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use roadvo_sim::calibrate::{Metric, calibrate};
use roadvo_sim::kitti::read_poses;
use std::path::PathBuf;

/// Refine the mount (pitch, yaw, roll, height, offset ahead of the rear axle) so that the
/// odometry over a section with ground truth matches it.
#[derive(clap::Args)]
pub struct CalibrateArgs {
    #[command(flatten)]
    seq: SequenceArgs,
    /// Ground-truth poses of the sequence (KITTI format).
    #[arg(long)]
    gt: PathBuf,
    /// The section, frames A..B (default: the whole sequence).
    #[arg(long, value_parser = parse_frames)]
    frames: Option<std::ops::Range<usize>>,
    /// Where to write the refined mount file (without [camera]: each sequence's calibration
    /// supplies it).
    #[arg(long)]
    out: PathBuf,
    /// Most mounts tried (each costs five odometry runs over the section, at heights -2..+2 mm).
    #[arg(long, default_value_t = 150)]
    max_runs: usize,
    /// What a mount is scored on: segments of 10..50 m (short) or KITTI's 100..800 m
    /// (kitti, for a section of 100 m or more).
    #[arg(long, value_enum, default_value_t = Metric::Short)]
    metric: Metric,
}

/// Parses a section of frames, `A..B`.
fn parse_frames(s: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?} is not a section: write A..B, e.g. 0..100"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<usize>()
            .map_err(|e| format!("{v:?} in {s:?}: {e}"))
    };
    let (a, b) = (n(a)?, n(b)?);
    if a >= b {
        return Err(format!("{s:?}: the section is empty"));
    }
    Ok(a..b)
}

impl CalibrateArgs {
    pub fn run(self) -> Result<()> {
        let (seq, start) = self.seq.open()?;
        let poses = read_poses(&self.gt)?;
        if poses.len() != seq.frames {
            bail!(
                "{}: {} ground-truth poses but {} holds {} frames: one a frame",
                self.gt.display(),
                poses.len(),
                self.seq.seq_dir.join("image_0").display(),
                seq.frames
            );
        }
        let section = self.frames.unwrap_or(0..seq.frames);
        let bar = ProgressBar::new(self.max_runs as u64).with_style(
            ProgressStyle::with_template("calibrating {bar:40} {pos}/{len} mounts {msg}")
                .expect("valid template"),
        );
        let cal = calibrate(
            &seq,
            &poses,
            section.clone(),
            &start,
            self.seq.method,
            self.metric,
            self.max_runs,
            |n, c| {
                bar.set_position(n as u64);
                bar.set_message(format!("cost {c:.3}"));
            },
        )?;
        bar.finish_and_clear();
        let seq_dir = self.seq.seq_dir.display();
        println!(
            "frames {}..{} of {seq_dir}: cost ({}) {:.3} -> {:.3}, {} mounts tried, {:.1} s",
            section.start,
            section.end,
            self.metric.describe(),
            cal.cost_before,
            cal.cost_after,
            cal.evaluations,
            cal.elapsed.as_secs_f64()
        );
        for (name, unit, before, after) in &cal.changes {
            println!("  {name:>28}: {before:>8.3} -> {after:>8.3} {unit}");
        }
        let note = format!(
            "# Calibrated by `roadvo calibrate` on frames {}..{} of {seq_dir}: cost {:.3} -> {:.3}.\n",
            section.start, section.end, cal.cost_before, cal.cost_after
        );
        cal.mount.write(&self.out, false, &note)?;
        println!("mount written to {}", self.out.display());
        Ok(())
    }
}
