//! `roadvo eval`.

use anyhow::{Context, Result, bail};
use roadvo_sim::ape::{Alignment, Ape, PairsFrom, Rpe, ape, format_ape_rpe, rpe};
use roadvo_sim::associate::{Association, DEFAULT_MAX_DIFF_S, by_line, by_timestamp};
use roadvo_sim::eval::{Report, evaluate, evaluate_planar, first_non_rotation, format_report};
use roadvo_sim::kitti::Pose;
use roadvo_sim::output::check_outputs;
use roadvo_sim::plot::{Figure, Scored, check_format, plot_figure};
use roadvo_sim::pose_file::{PoseFormat, TimedPoses, read_trajectory};
use roadvo_sim::quality::read_quality;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Compare an estimated trajectory with ground truth (KITTI or TUM pose files).
#[derive(clap::Args)]
pub struct EvalArgs {
    /// Ground-truth poses: KITTI (12 numbers a line) or TUM (8: timestamp tx ty tz qx qy qz qw).
    gt: PathBuf,
    /// Estimated poses, KITTI or TUM.
    est: PathBuf,
    /// The format of both files (default: by the number of numbers on a line, 12 or 8).
    #[arg(long, value_enum)]
    format: Option<PoseFormat>,
    /// The largest timestamp difference of a pair of poses, seconds, when both files are TUM
    /// (evo's --t_max_diff); otherwise poses are paired line by line.
    #[arg(long, default_value_t = DEFAULT_MAX_DIFF_S)]
    t_max_diff: f64,
    /// How the estimate is aligned to the ground truth for the APE and RPE (evo: none, -a, -as).
    #[arg(long, value_enum, default_value = "none")]
    align: Alignment,
    /// Section length of the RPE along the aligned estimate's path, metres.
    #[arg(long, default_value_t = 100.0)]
    delta: f64,
    /// Cut the RPE's sections along the ground truth's path instead (evo's
    /// --pairs_from_reference).
    #[arg(long)]
    pairs_from_reference: bool,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Draw the top view, the errors per segment length and the APE over the distance, in one
    /// figure (.png or .svg).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// A quality file of the run (`roadvo run --quality`, .jsonl or .csv) to draw in the plot.
    #[arg(long, requires = "plot")]
    quality: Option<PathBuf>,
    /// Also score both trajectories in the ground plane only (x-z positions and heading),
    /// and report the ground truth's planar floors: the first camera level, and in the
    /// estimate's own ground plane.
    #[arg(long)]
    planar: bool,
}

/// What `eval --json` prints: the KITTI report's figures, then how the poses were paired, the
/// APE and the RPE.
#[derive(Serialize)]
struct EvalJson<'a> {
    #[serde(flatten)]
    report: &'a Report,
    association: &'a Association,
    ape: &'a Ape,
    rpe: &'a Rpe,
}

/// Two pose files and how they compare.
struct Evaluated {
    report: Report,
    association: Association,
    /// The paired ground-truth poses.
    gt: Vec<Pose>,
    /// The paired estimated poses, aligned.
    aligned: Vec<Pose>,
    ape: Ape,
    ape_m: Vec<f64>,
    rpe: Rpe,
}

/// A pose file's poses, refused if any rotation is not one.
fn read_rotations(path: &Path, format: Option<PoseFormat>) -> Result<TimedPoses> {
    let poses = read_trajectory(path, format)?;
    if let Some((i, what)) = first_non_rotation(&poses.poses) {
        bail!("{} line {}: {what}", path.display(), poses.lines[i]);
    }
    Ok(poses)
}

impl EvalArgs {
    fn evaluate(&self) -> Result<Evaluated> {
        let g = read_rotations(&self.gt, self.format)?;
        let e = read_rotations(&self.est, self.format)?;
        let association = match (&g.times_s, &e.times_s) {
            (Some(gt_s), Some(est_s)) => {
                let a = by_timestamp(gt_s, est_s, self.t_max_diff);
                if a.matched < 2 {
                    bail!(
                        "{} and {}: {} poses have timestamps within {} s of each other (--t-max-diff); \
                         two or more are needed",
                        self.gt.display(),
                        self.est.display(),
                        a.matched,
                        self.t_max_diff
                    );
                }
                a
            }
            _ => by_line(g.poses.len(), e.poses.len()),
        };
        let comparing = || {
            format!(
                "comparing {} with {}",
                self.est.display(),
                self.gt.display()
            )
        };
        let (gt, est): (Vec<Pose>, Vec<Pose>) = if association.by == "line" {
            // The KITTI metric refuses files of different lengths, as evo does.
            (g.poses, e.poses)
        } else {
            association
                .pairs
                .iter()
                .map(|&(i, j)| (g.poses[i], e.poses[j]))
                .unzip()
        };
        let report = if self.planar {
            evaluate_planar(&gt, &est)
        } else {
            evaluate(&gt, &est)
        }
        .with_context(comparing)?;
        let aligned = ape(&gt, &est, self.align).with_context(comparing)?;
        let pairs_from = if self.pairs_from_reference {
            PairsFrom::GroundTruth
        } else {
            PairsFrom::Estimate
        };
        let rpe = rpe(&gt, &aligned.poses, self.delta, pairs_from);
        Ok(Evaluated {
            report,
            association,
            gt,
            aligned: aligned.poses,
            ape: aligned.ape,
            ape_m: aligned.errors_m,
            rpe,
        })
    }

    pub fn run(self) -> Result<()> {
        if !(self.delta > 0.0 && self.t_max_diff >= 0.0) {
            bail!("--delta must be above 0 m and --t-max-diff 0 s or more");
        }
        if let Some(p) = &self.plot {
            roadvo_sim::interrupt::install();
            check_format(p)?;
            let mut inputs = vec![self.gt.as_path(), self.est.as_path()];
            inputs.extend(self.quality.as_deref());
            check_outputs(&inputs, &[], &[("--plot", p)])?;
        }
        let quality = self.quality.as_deref().map(read_quality).transpose()?;
        let ev = self.evaluate()?;
        if self.json {
            let json = EvalJson {
                report: &ev.report,
                association: &ev.association,
                ape: &ev.ape,
                rpe: &ev.rpe,
            };
            println!("{}", serde_json::to_string_pretty(&json)?);
        } else {
            print!("{}", format_report(&ev.report));
            let a = &ev.association;
            match a.max_diff_s {
                Some(d) => print!(
                    "\nPaired by timestamp (within {d} s): {} of {} ground-truth and {} estimated poses\n",
                    a.matched, a.gt_poses, a.est_poses
                ),
                None => print!("\nPaired line by line: {} poses\n", a.matched),
            }
            print!("{}", format_ape_rpe(&ev.ape, &ev.rpe));
        }
        if let Some(p) = &self.plot {
            let label = match self.align {
                Alignment::None => "estimate".to_string(),
                Alignment::Se3 => "estimate (SE(3)-aligned)".to_string(),
                Alignment::Sim3 => format!("estimate (Sim(3)-aligned, scale {:.3})", ev.ape.scale),
            };
            let estimates = [Scored {
                label: &label,
                poses: &ev.aligned,
                report: Some(&ev.report),
                ape_m: Some(&ev.ape_m),
            }];
            let title = self.est.display().to_string();
            plot_figure(
                p,
                &Figure {
                    title: &title,
                    ground_truth: Some(&ev.gt),
                    estimates: &estimates,
                    quality: quality.as_deref(),
                },
            )?;
            eprintln!("plot written to {}", p.display());
        }
        Ok(())
    }
}
