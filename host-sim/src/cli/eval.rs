//! `roadvo eval`.

use anyhow::{Context, Result, bail};
use roadvo_sim::eval::{Report, evaluate, evaluate_planar, first_non_rotation, format_report};
use roadvo_sim::kitti::{Pose, read_poses};
use roadvo_sim::output::check_outputs;
use roadvo_sim::plot::{Track, check_format, plot_trajectories};
use std::path::{Path, PathBuf};

/// Compare an estimated trajectory with ground truth (KITTI pose files).
#[derive(clap::Args)]
pub struct EvalArgs {
    /// Ground-truth poses.
    gt: PathBuf,
    /// Estimated poses.
    est: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Draw the top view and the error per segment length (.png or .svg).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Also score both trajectories in the ground plane only (x-z positions and heading),
    /// and report the ground truth's planar floors: the first camera level, and in the
    /// estimate's own ground plane.
    #[arg(long)]
    planar: bool,
}

/// Two pose files and how they compare.
struct Evaluated {
    report: Report,
    gt: Vec<Pose>,
    est: Vec<Pose>,
}

/// A pose file's poses, refused if any rotation is not one.
fn read_rotations(path: &Path) -> Result<Vec<Pose>> {
    let poses = read_poses(path)?;
    if let Some((i, what)) = first_non_rotation(&poses) {
        bail!("{} line {}: {what}", path.display(), i + 1);
    }
    Ok(poses)
}

fn eval_files(gt: &Path, est: &Path, planar: bool) -> Result<Evaluated> {
    let g = read_rotations(gt)?;
    let e = read_rotations(est)?;
    let report = if planar {
        evaluate_planar(&g, &e)
    } else {
        evaluate(&g, &e)
    };
    let report =
        report.with_context(|| format!("comparing {} with {}", est.display(), gt.display()))?;
    Ok(Evaluated {
        report,
        gt: g,
        est: e,
    })
}

impl EvalArgs {
    pub fn run(self) -> Result<()> {
        if let Some(p) = &self.plot {
            roadvo_sim::interrupt::install();
            check_format(p)?;
            check_outputs(&[&self.gt, &self.est], &[], &[("--plot", p)])?;
        }
        let Evaluated { report, gt, est } = eval_files(&self.gt, &self.est, self.planar)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            print!("{}", format_report(&report));
        }
        if let Some(p) = self.plot {
            let tracks = [
                Track {
                    label: "ground truth",
                    poses: &gt,
                },
                Track {
                    label: "estimate",
                    poses: &est,
                },
            ];
            let title = self.est.display().to_string();
            plot_trajectories(&p, &title, &tracks, Some(&report))?;
            eprintln!("plot written to {}", p.display());
        }
        Ok(())
    }
}
