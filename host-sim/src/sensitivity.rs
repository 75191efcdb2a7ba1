//! `roadvo sensitivity`: the paper's calibration study (§3, Figures 12 and 13) and its
//! appendix's kerb and crown cases, on the s-course, for both methods, beside the paper's figures.
//!
//! The calibration cases run the same rendered frames with a mount file that is wrong by one
//! parameter (+1 deg of roll, pitch or yaw, +10 cm of an offset); the road cases render the
//! course again over a non-planar road. Two figures per run, as the paper's Figure 13 gives them
//! at the end of the course:
//! - translation error, percent: the estimated path length against the true one (signed:
//!   positive overestimates the distance travelled);
//! - rotation error, deg/m: the heading error at the end of the course (the sum of the
//!   per-frame heading changes against the true sum) over the true path length, signed;
//!
//! and the end-point error (the distance between the final positions over the path length,
//! percent), where an error that bends the path without lengthening it shows; and, for the
//! pitch vote, the mount it learned in each case ([`format_learned`]).
//!
//! Both are measured on the camera's planar motion (KITTI poses through the mount), so they
//! need no alignment of the trajectories.

use crate::eval::{evaluate, heading_rad};
use crate::kitti::{Pose, Sequence, read_poses};
use crate::mount::MountFile;
use crate::run::{LearnedMount, Preloaded, config_for, mount_for};
use crate::scenario::{Crown, Kerb, Scenario};
use crate::simulate::{poses_path, sequence_dir, simulate};
use anyhow::Result;
use roadvo::Method;
use std::path::Path;

/// How a case departs from the best case.
enum Departure {
    /// None: the exact mount on a flat road.
    None,
    /// The mount file is wrong by this change.
    Mount(fn(&mut MountFile)),
    /// The road is not flat: the scenario is changed so before rendering.
    Road(&'static str, fn(&mut Scenario)),
}

/// One case of the study.
struct Case {
    name: &'static str,
    departure: Departure,
    /// The paper's (translation %, rotation deg/m), where it gives them.
    paper: (Option<f64>, Option<f64>),
}

impl Case {
    /// The folder of the case's drive, and how its scenario departs from the s-course.
    fn drive(&self) -> (&'static str, Option<fn(&mut Scenario)>) {
        match self.departure {
            Departure::Road(folder, change) => (folder, Some(change)),
            _ => ("flat", None),
        }
    }
}

/// The appendix's worst case: features only at the road's edges, none within 2 m of the centre.
const BARE_CENTRE_M: f64 = 2.0;

fn cases() -> [Case; 11] {
    [
        Case {
            name: "best case",
            departure: Departure::None,
            paper: (None, None),
        },
        Case {
            name: "roll +1 deg",
            departure: Departure::Mount(|m| {
                m.set_mount_value("roll_deg", m.mount_value("roll_deg") + 1.0)
            }),
            paper: (None, Some(0.04)),
        },
        Case {
            name: "pitch +1 deg",
            departure: Departure::Mount(|m| {
                m.set_mount_value("pitch_deg", m.mount_value("pitch_deg") + 1.0)
            }),
            paper: (Some(13.0), None),
        },
        Case {
            name: "yaw +1 deg",
            departure: Departure::Mount(|m| {
                m.set_mount_value("yaw_deg", m.mount_value("yaw_deg") + 1.0)
            }),
            paper: (None, Some(0.11)),
        },
        Case {
            name: "longitudinal offset +10 cm",
            departure: Departure::Mount(|m| m.mount.x_m += 0.1),
            paper: (Some(6.0), None),
        },
        Case {
            name: "lateral offset +10 cm",
            departure: Departure::Mount(|m| m.mount.y_m += 0.1),
            paper: (None, None),
        },
        Case {
            name: "vertical offset +10 cm",
            departure: Departure::Mount(|m| m.mount.height_m += 0.1),
            paper: (Some(6.0), None),
        },
        Case {
            name: "kerb 15 cm at 2-3 m right, no centre points",
            departure: Departure::Road("kerb-bare", |s| {
                s.kerb = Some(KERB);
                s.render.bare_half_width_m = BARE_CENTRE_M;
            }),
            paper: (Some(6.3), Some(0.078)),
        },
        Case {
            name: "kerb 15 cm at 2-3 m right, centre points",
            departure: Departure::Road("kerb", |s| s.kerb = Some(KERB)),
            paper: (Some(0.1), Some(0.004)),
        },
        Case {
            name: "4% slope beyond 1 m left, no centre points",
            departure: Departure::Road("slope-bare", |s| {
                s.crown = Some(Crown {
                    left_from_m: 1.0,
                    left_slope: 0.04,
                    ..Crown::default()
                });
                s.render.bare_half_width_m = BARE_CENTRE_M;
            }),
            paper: (Some(-0.5), Some(0.013)),
        },
        Case {
            name: "single-lane crown, 2% each side",
            departure: Departure::Road("crown", |s| {
                s.crown = Some(Crown {
                    left_from_m: 0.0,
                    left_slope: 0.02,
                    right_from_m: 0.0,
                    right_slope: 0.02,
                })
            }),
            paper: (Some(-2.6), None),
        },
    ]
}

const KERB: Kerb = Kerb {
    from_m: -3.0,
    to_m: -2.0,
    height_m: 0.15,
};

/// One run of the study.
pub struct Row {
    /// The case.
    pub case: &'static str,
    /// The method.
    pub method: Method,
    /// Path length error, percent (positive: too long).
    pub translation_pct: f64,
    /// Final heading error over the path length, deg/m.
    pub rotation_deg_per_m: f64,
    /// Distance between the final positions over the path length, percent.
    pub end_drift_pct: f64,
    /// The paper's translation error, percent, where it gives one.
    pub paper_translation_pct: Option<f64>,
    /// The paper's rotation error, deg/m, where it gives one.
    pub paper_rotation_deg_per_m: Option<f64>,
    /// The corrections to the case's mount file learned over the course: on a roll, pitch, yaw
    /// or longitudinal case its change reversed (the lateral and vertical offsets are not
    /// learned), on a road case (whose mount file is exact) what the road taught.
    pub learned: LearnedMount,
}

/// Planar camera motion of a KITTI trajectory: (path length, sum of heading changes in
/// degrees), heading about the camera's vertical.
fn path_and_turn(poses: &[Pose]) -> (f64, f64) {
    poses.windows(2).fold((0.0, 0.0), |(len, turn), w| {
        let (a, b) = (&w[0], &w[1]);
        let step = (b[3] - a[3]).hypot(b[11] - a[11]);
        let d = (heading_rad(b) - heading_rad(a) + std::f64::consts::PI)
            .rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        (len + step, turn + d.to_degrees())
    })
}

/// The two figures of an estimate against the truth: (translation %, rotation deg/m).
pub fn errors(truth: &[Pose], est: &[Pose]) -> (f64, f64) {
    let (len_t, turn_t) = path_and_turn(truth);
    let (len_e, turn_e) = path_and_turn(est);
    if len_t <= 0.0 {
        return (0.0, 0.0);
    }
    (100.0 * (len_e - len_t) / len_t, (turn_e - turn_t) / len_t)
}

/// Runs the study on the s-course rendered with `seed` (`frames` of it, or all) into folders
/// under `out`, every case's mount file changed by `settings` (as [`MountFile::set`] takes
/// them) after the case's own change; `progress` hears what is being done.
pub fn sensitivity(
    out: &Path,
    seed: u64,
    frames: Option<usize>,
    settings: &[String],
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>> {
    // The settings are checked on the course's own mount before anything is rendered.
    let mut mount = Scenario::built_in("s-course")?.mount_file(true);
    for s in settings {
        mount.set(s)?;
    }
    mount
        .to_config()
        .validate()
        .map_err(crate::run::config_error)?;
    let mut rows = Vec::new();
    // Cases that share a drive come together: each drive is rendered and decoded once.
    for group in cases().chunk_by(|a, b| a.drive().0 == b.drive().0) {
        let (folder, change) = group[0].drive();
        let dir = out.join(folder);
        if !poses_path(&dir).exists() {
            progress(&format!("rendering the s-course ({folder})"));
            let mut sc = Scenario::built_in("s-course")?;
            if let Some(change) = change {
                change(&mut sc);
            }
            simulate(&sc, &dir, seed, frames, &())?;
        }
        let seq = Sequence::open(&sequence_dir(&dir))?;
        let truth = read_poses(&poses_path(&dir))?;
        let frames = Preloaded::load(&seq, 0..seq.frames)?;
        for case in group {
            let mut mount = mount_for(&seq, None)?;
            if let Departure::Mount(change) = &case.departure {
                change(&mut mount);
            }
            for s in settings {
                mount.set(s)?;
            }
            for method in Method::ALL {
                progress(&format!("{} ({})", case.name, method.name()));
                let (est, learned) = frames.poses(config_for(&seq, &mount, Some(method))?)?;
                let (t, r) = errors(&truth, &est);
                rows.push(Row {
                    case: case.name,
                    method,
                    translation_pct: t,
                    rotation_deg_per_m: r,
                    end_drift_pct: evaluate(&truth, &est)?.end_drift_pct,
                    paper_translation_pct: case.paper.0,
                    paper_rotation_deg_per_m: case.paper.1,
                    learned,
                });
            }
        }
    }
    Ok(rows)
}

/// The study as a Markdown table, both methods side by side.
pub fn format_rows(rows: &[Row]) -> String {
    let paper =
        |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |x| format!("{x:.digits$}"));
    let mut s = String::from(
        "| case | default: translation %, rotation deg/m, end point % | paper's method: translation %, rotation deg/m, end point % | the paper: translation %, rotation deg/m |\n|---|---|---|---|\n",
    );
    for pair in rows.chunks(2) {
        let [d, p] = pair else { continue };
        s += &format!(
            "| {} | {:+.2}, {:+.4}, {:.2} | {:+.2}, {:+.4}, {:.2} | {}, {} |\n",
            d.case,
            d.translation_pct,
            d.rotation_deg_per_m,
            d.end_drift_pct,
            p.translation_pct,
            p.rotation_deg_per_m,
            p.end_drift_pct,
            paper(d.paper_translation_pct, 1),
            paper(d.paper_rotation_deg_per_m, 3),
        );
    }
    s
}

/// The mount the default method learned in each case, as a Markdown table: the corrections
/// to the case's mount file, each with its standard error ("-" where nothing measured it).
pub fn format_learned(rows: &[Row]) -> String {
    let deg = |e: Option<roadvo::AngleEstimate>| {
        e.map_or("-".to_string(), |e| {
            format!(
                "{:+.2} (+-{:.2})",
                e.rad.to_degrees(),
                e.sd_rad.to_degrees()
            )
        })
    };
    let mut s = String::from(
        "| case | yaw deg | pitch deg | roll deg | distance ahead of the axle m |\n|---|---|---|---|---|\n",
    );
    for r in rows.iter().filter(|r| r.method == Method::PitchVote) {
        let l = &r.learned;
        let x = l
            .x_m
            .map_or("-".to_string(), |(m, sd)| format!("{m:+.3} (+-{sd:.3})"));
        s += &format!(
            "| {} | {} | {} | {} | {x} |\n",
            r.case,
            deg(l.yaw),
            deg(l.pitch),
            deg(l.roll)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::eval::level_pose as pose;

    #[test]
    fn a_longer_path_and_an_extra_turn_show_as_their_errors() {
        let truth: Vec<Pose> = (0..=100).map(|i| pose(0.0, f64::from(i), 0.0)).collect();
        // 10% too far, and turning 0.01 deg a frame (1 m) too much.
        let est: Vec<Pose> = (0..=100)
            .map(|i| pose(0.0, 1.1 * f64::from(i), (0.01 * f64::from(i)).to_radians()))
            .collect();
        let (t, r) = errors(&truth, &est);
        assert!((t - 10.0).abs() < 0.1, "{t}");
        assert!((r - 0.01).abs() < 1e-6, "{r}");
        assert_eq!(errors(&truth, &truth), (0.0, 0.0));
    }

    #[test]
    fn the_learned_mount_table_has_the_pitch_vote_s_rows_and_a_dash_where_nothing_was_measured() {
        let row = |case, method, roll_deg: Option<f32>| Row {
            case,
            method,
            translation_pct: 0.0,
            rotation_deg_per_m: 0.0,
            end_drift_pct: 0.0,
            paper_translation_pct: None,
            paper_rotation_deg_per_m: None,
            learned: LearnedMount {
                roll: roll_deg.map(|d| roadvo::AngleEstimate {
                    rad: d.to_radians(),
                    sd_rad: 0.05f32.to_radians(),
                }),
                x_m: Some((-0.1, 0.02)),
                ..LearnedMount::default()
            },
        };
        let rows = [
            row("roll +1 deg", Method::PitchVote, Some(-0.98)),
            row("roll +1 deg", Method::Paper, None),
        ];
        let table = format_learned(&rows);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 3, "{table}");
        assert_eq!(
            lines[2],
            "| roll +1 deg | - | - | -0.98 (+-0.05) | -0.100 (+-0.020) |"
        );
    }

    #[test]
    fn headings_wrap_through_the_back() {
        // Half a turn and on, across +-180 deg: the sum of changes keeps counting.
        let truth: Vec<Pose> = (0..=40)
            .map(|i| pose(0.0, 0.0, (10.0 * f64::from(i)).to_radians()))
            .collect();
        let (_, turn) = path_and_turn(&truth);
        assert!((turn - 400.0).abs() < 1e-9, "{turn}");
    }
}
