//! `roadvo calibrate`: refines the camera mount (pitch, yaw, roll, height, distance ahead of the
//! rear axle) so that the odometry over a section with ground truth matches it, as the paper's §3
//! does by hand.
//!
//! A mount's cost is the 10..50 m metric of the odometry over the section against the ground truth
//! (or, with [`Metric::Kitti`], KITTI's 100..800 m metric): translation in percent plus rotation in
//! hundredths of a degree per metre, averaged over runs at heights -2..+2 mm
//! ([`HEIGHT_SPREAD_MM`]), since on real frames one run is one draw between near-equal vote peaks.
//! The odometry is not smooth in the mount, so the search is a pattern search: each parameter in
//! turn stepped up and down, the best improvement kept, every step halved when a sweep improves
//! nothing. Pitch and height scale distances, yaw biases rotation, roll biases it on straights, the
//! offset splits a turn between rotation and sideways motion; on a straight a yaw and a roll error
//! act alike, so a section with bends calibrates better (`docs/experiments.md`, "KITTI's mount").

use crate::eval::evaluate;
use crate::kitti::{Pose, Sequence};
use crate::mount::MountFile;
use crate::run::{Preloaded, config_for};
use anyhow::{Result, bail};
use rayon::prelude::*;
use roadvo::Method;
use std::ops::Range;
use std::time::{Duration, Instant};

/// One refined parameter: its name, its key in the mount file, its first and last step.
struct Parameter {
    name: &'static str,
    unit: &'static str,
    /// Its key in `[mount]`: varied in the file's unit (degrees for angles).
    key: &'static str,
    first_step: f32,
    last_step: f32,
}

const PARAMETERS: [Parameter; 5] = [
    Parameter {
        name: "pitch",
        unit: "deg",
        key: "pitch_deg",
        first_step: 0.4,
        last_step: 0.025,
    },
    Parameter {
        name: "yaw",
        unit: "deg",
        key: "yaw_deg",
        first_step: 0.4,
        last_step: 0.025,
    },
    Parameter {
        name: "roll",
        unit: "deg",
        key: "roll_deg",
        first_step: 0.4,
        last_step: 0.025,
    },
    Parameter {
        name: "height",
        unit: "m",
        key: "height_m",
        first_step: 0.08,
        last_step: 0.005,
    },
    Parameter {
        name: "x (ahead of the rear axle)",
        unit: "m",
        key: "x_m",
        first_step: 0.4,
        last_step: 0.025,
    },
];

/// Which segments of the section a mount is scored on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Metric {
    /// Segments of 10..50 m: any section of 50 m or more; weighs the frame-to-frame motion.
    #[default]
    Short,
    /// KITTI's segments of 100..800 m: a section of 100 m or more; weighs the drift over the
    /// lengths the KITTI figures are quoted on.
    Kitti,
}

impl Metric {
    /// What the cost is, for the report.
    pub fn describe(self) -> &'static str {
        match self {
            Metric::Short => "short-segment t_err % + 100 x r_err deg/m, mean of 5 heights",
            Metric::Kitti => "KITTI t_err % + 100 x r_err deg/m, mean of 5 heights",
        }
    }
}

/// What a calibration found.
pub struct Calibration {
    /// The refined mount.
    pub mount: MountFile,
    /// Cost of the starting mount (see the module docs).
    pub cost_before: f64,
    /// Cost of the refined mount.
    pub cost_after: f64,
    /// Odometry runs over the section.
    pub evaluations: usize,
    /// Wall time, decoding the section's frames included.
    pub elapsed: Duration,
    /// Per parameter: name, unit, start value, refined value.
    pub changes: Vec<(&'static str, &'static str, f32, f32)>,
}

/// Mount heights, millimetres from a candidate's, at which the cost runs the odometry.
pub const HEIGHT_SPREAD_MM: [f32; 5] = [-2.0, -1.0, 0.0, 1.0, 2.0];

/// The cost of `mount` over `frames` against `gt` (the section's poses): the `metric`'s cost
/// of runs at each of [`HEIGHT_SPREAD_MM`] (in parallel), their mean; infinite where the mount
/// does not make a valid configuration.
fn cost(
    seq: &Sequence,
    frames: &Preloaded,
    gt: &[Pose],
    mount: &MountFile,
    method: Option<Method>,
    metric: Metric,
) -> Result<f64> {
    let costs = HEIGHT_SPREAD_MM
        .par_iter()
        .map(|mm| {
            let mut moved = *mount;
            moved.mount.height_m += mm * 1e-3;
            // The mount as given: the reference the online calibration is compared with. And
            // the image's heading where it stands: weighed with the ground's on road alone, the
            // heading answers to the mount twice, through a running weight, and on the s-course
            // a yaw error's cost then falls as far with the roll turned the wrong way.
            moved.settings.learn_yaw = false;
            moved.settings.learn_pitch = false;
            moved.settings.learn_roll = false;
            moved.settings.learn_x = false;
            moved.settings.weigh_road_heading = false;
            let Ok(config) = config_for(seq, &moved, method) else {
                return Ok(f64::INFINITY);
            };
            let report = evaluate(gt, &frames.poses(config)?.0)?;
            let figures = match metric {
                Metric::Short => (report.short_t_err_pct, report.short_r_err_deg_per_m),
                Metric::Kitti => (report.t_err_pct, report.r_err_deg_per_m),
            };
            match (figures, metric) {
                ((Some(t), Some(r)), _) => Ok(t + 100.0 * r),
                (_, Metric::Short) => {
                    bail!("the section is too short: it needs at least 10 m of ground-truth path")
                }
                (_, Metric::Kitti) => bail!(
                    "the section is too short for the KITTI metric: it needs at least 100 m of \
                     ground-truth path (--metric short takes 10 m)"
                ),
            }
        })
        .collect::<Result<Vec<f64>>>()?;
    Ok(costs.iter().sum::<f64>() / costs.len() as f64)
}

/// Refines `start` over `section` of `seq` against its ground truth `gt` (poses of the whole
/// sequence), scored on `metric`, in at most `max_evaluations` runs; `progress` sees each
/// run's cost.
#[allow(clippy::too_many_arguments)]
pub fn calibrate(
    seq: &Sequence,
    gt: &[Pose],
    section: Range<usize>,
    start: &MountFile,
    method: Option<Method>,
    metric: Metric,
    max_evaluations: usize,
    mut progress: impl FnMut(usize, f64),
) -> Result<Calibration> {
    let began = Instant::now();
    if gt.len() < seq.frames {
        bail!(
            "the ground truth has {} poses for {} frames",
            gt.len(),
            seq.frames
        );
    }
    if section.start >= section.end || section.end > seq.frames {
        bail!(
            "frames {}..{} are not a section of the sequence's {} frames",
            section.start,
            section.end,
            seq.frames
        );
    }
    let frames = Preloaded::load(seq, section.clone())?;
    let gt = &gt[section];
    let mut best = *start;
    let mut best_cost = cost(seq, &frames, gt, &best, method, metric)?;
    if !best_cost.is_finite() {
        bail!("the starting mount does not make a valid configuration for this sequence");
    }
    let cost_before = best_cost;
    let mut evaluations = 1;
    progress(evaluations, best_cost);
    let mut steps: Vec<f32> = PARAMETERS.iter().map(|p| p.first_step).collect();
    'search: while PARAMETERS
        .iter()
        .zip(&steps)
        .any(|(p, &s)| s >= p.last_step)
    {
        let mut improved = false;
        for (p, &step) in PARAMETERS.iter().zip(&steps) {
            if step < p.last_step {
                continue;
            }
            let mut round_best: Option<(f64, MountFile)> = None;
            for sign in [1.0, -1.0] {
                if evaluations >= max_evaluations {
                    break 'search;
                }
                let mut candidate = best;
                candidate.set_mount_value(p.key, best.mount_value(p.key) + sign * step);
                let c = cost(seq, &frames, gt, &candidate, method, metric)?;
                evaluations += 1;
                progress(evaluations, c);
                if c < round_best.as_ref().map_or(best_cost, |r| r.0) {
                    round_best = Some((c, candidate));
                }
            }
            if let Some((c, m)) = round_best {
                best_cost = c;
                best = m;
                improved = true;
            }
        }
        if !improved {
            steps.iter_mut().for_each(|s| *s *= 0.5);
        }
    }
    let changes = PARAMETERS
        .iter()
        .map(|p| {
            (
                p.name,
                p.unit,
                start.mount_value(p.key),
                best.mount_value(p.key),
            )
        })
        .collect();
    Ok(Calibration {
        mount: best,
        cost_before,
        cost_after: best_cost,
        evaluations,
        elapsed: began.elapsed(),
        changes,
    })
}
