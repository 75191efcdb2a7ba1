//! The KITTI odometry devkit metric (`evaluate_odometry.cpp`), plus short-segment and end-point
//! figures for drives too short for it.
//!
//! For every first frame (every 10th) and every segment length, the segment ends at the first
//! frame whose ground-truth path length from the first frame exceeds the length. The error of the
//! segment is `E = (P'_first^-1 P'_last)^-1 (P_first^-1 P_last)`; its translation norm and
//! rotation angle, divided by the segment length, are pooled over all segments.
//!
//! Beside it, not KITTI figures: the estimated path length over the true one and the translation
//! errors at the true scale (a monocular error is often mostly scale); and with [`evaluate_planar`]
//! the same metric in the ground plane with two planar floors, the ground truth's own planar motion
//! scored with the first camera level and in the estimate's own ground plane ([`OwnPlaneFloor`]).
//! Which floor a figure answers to: `docs/method.md`, "Measuring".

use crate::kitti::Pose;
use anyhow::{Result, bail};
use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, UnitQuaternion, Vector3};
use serde::Serialize;

/// The devkit's segment lengths, metres.
pub const LENGTHS_M: [f64; 8] = [100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0];
/// Lengths for drives too short for the devkit's, metres (not a KITTI figure).
pub const SHORT_LENGTHS_M: [f64; 5] = [10.0, 20.0, 30.0, 40.0, 50.0];
/// The devkit's step between first frames.
const STEP_FRAMES: usize = 10;

/// Errors of the segments of one length.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LengthRow {
    /// Segment length, metres.
    pub length_m: f64,
    /// Segments of this length.
    pub segments: usize,
    /// Mean translation error, percent of the length.
    pub t_err_pct: f64,
    /// Mean rotation error, degrees per metre.
    pub r_err_deg_per_m: f64,
}

/// The pooled metric over a set of lengths.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Metric {
    /// Segments evaluated.
    pub segments: usize,
    /// Mean translation error over all segments, percent; `None` without segments.
    pub t_err_pct: Option<f64>,
    /// Mean rotation error over all segments, deg/m; `None` without segments.
    pub r_err_deg_per_m: Option<f64>,
    /// The same per length (lengths without segments are left out).
    pub per_length: Vec<LengthRow>,
}

/// Everything `roadvo eval` reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    /// Poses compared.
    pub frames: usize,
    /// Ground-truth path length, metres.
    pub path_length_m: f64,
    /// KITTI translation error, percent (segments of 100..800 m).
    pub t_err_pct: Option<f64>,
    /// KITTI rotation error, deg/m.
    pub r_err_deg_per_m: Option<f64>,
    /// KITTI segments evaluated.
    pub segments: usize,
    /// KITTI metric per length.
    pub per_length: Vec<LengthRow>,
    /// The same metric over 10..50 m segments (not a KITTI figure), percent.
    pub short_t_err_pct: Option<f64>,
    /// The same metric over 10..50 m segments, deg/m.
    pub short_r_err_deg_per_m: Option<f64>,
    /// Short segments evaluated.
    pub short_segments: usize,
    /// Short metric per length.
    pub short_per_length: Vec<LengthRow>,
    /// Estimated path length over the ground truth's (1: the right scale); `None` when the
    /// ground truth does not move.
    pub path_ratio: Option<f64>,
    /// KITTI translation error with the estimate's positions divided by `path_ratio`, percent.
    pub scaled_t_err_pct: Option<f64>,
    /// Short-segment translation error with the positions divided by `path_ratio`, percent.
    pub scaled_short_t_err_pct: Option<f64>,
    /// Distance between the final positions over the path length, percent.
    pub end_drift_pct: f64,
    /// Rotation angle between the final orientations, degrees.
    pub end_heading_err_deg: f64,
    /// With `--planar`: the same report in the ground plane only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planar: Option<Box<Report>>,
    /// With `--planar`: the 3D metric of the ground truth's own planar motion, the first camera
    /// taken as level, (t_err %, r_err deg/m); `None` where the drive is too short for KITTI
    /// segments.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planar_floor: Option<(f64, f64)>,
    /// With `--planar`: the same in the estimate's own ground plane; `None` where the drive is
    /// too short for KITTI segments or the estimate never turns by [`MIN_AXIS_TURN_DEG`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub own_plane_floor: Option<OwnPlaneFloor>,
}

/// The planar floor in a planar estimate's own ground plane: the plane its positions keep to,
/// whose normal is the axis it turns about.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct OwnPlaneFloor {
    /// How far the first camera looks down at that plane, degrees.
    pub pitch_down_deg: f64,
    /// How far the first camera's left side is up against that plane, degrees.
    pub roll_left_up_deg: f64,
    /// The ground truth's motion in that plane (positions in it, heading about its normal) on
    /// the KITTI metric: translation error, percent.
    pub t_err_pct: f64,
    /// The same: rotation error, deg/m.
    pub r_err_deg_per_m: f64,
}

/// Smallest turn from the first frame, degrees, whose axis is taken as an estimate's vertical:
/// a straight drive shows none.
pub const MIN_AXIS_TURN_DEG: f64 = 5.0;

/// How far a pose's rotation may be from orthonormal with determinant +1 (the largest entry of
/// `R Rᵀ - I`, and `|det R - 1|`): a pose file's nine digits leave about 1e-8.
pub const ROTATION_TOLERANCE: f64 = 1e-3;

/// The first pose whose 3x3 part is not a rotation within [`ROTATION_TOLERANCE`]: its index
/// and what is wrong.
pub fn first_non_rotation(poses: &[Pose]) -> Option<(usize, String)> {
    poses.iter().enumerate().find_map(|(i, p)| {
        let r = Matrix3::from_fn(|row, col| p[4 * row + col]);
        let off = (r * r.transpose() - Matrix3::identity()).amax();
        let det = r.determinant();
        (!(off <= ROTATION_TOLERANCE && (det - 1.0).abs() <= ROTATION_TOLERANCE)).then(|| {
            (
                i,
                format!(
                    "the rotation is not orthonormal (R Rt departs from I by {off:.3e}, det R = \
                     {det:.6}; at most {ROTATION_TOLERANCE:e} is allowed)"
                ),
            )
        })
    })
}

/// The heading of a camera-0 pose about the vertical: the yaw of its optical axis, radians.
pub fn heading_rad(p: &Pose) -> f64 {
    p[2].atan2(p[10])
}

/// A camera-0 pose in the ground plane: its position in x-z (y, down, set to 0) and its heading
/// about the vertical (the yaw of its optical axis), the first frame's camera taken as level.
pub fn planar_pose(p: &Pose) -> Pose {
    level_pose(p[3], p[11], heading_rad(p))
}

/// A level camera-0 pose at `x_m` (right) and `z_m` (forward) of the first frame's camera,
/// turned by `heading_rad` about the vertical.
pub fn level_pose(x_m: f64, z_m: f64, heading_rad: f64) -> Pose {
    let (s, c) = heading_rad.sin_cos();
    [c, 0.0, s, x_m, 0.0, 1.0, 0.0, 0.0, -s, 0.0, c, z_m]
}

/// Per-frame heading-change errors of an odometer's own estimates against the ground truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HeadingChangeErrors {
    /// Frames compared (all but the first).
    pub frames: usize,
    /// Root mean square of the error, degrees a frame.
    pub rms_deg: f64,
    /// Mean error (estimate minus truth), degrees a frame.
    pub mean_deg: f64,
}

/// The distance between the camera centres of frames `i - 1` and `i` of `gt`, metres.
pub fn true_step_m(gt: &[Pose], i: usize) -> f64 {
    let (a, b) = (&gt[i - 1], &gt[i]);
    ((b[3] - a[3]).powi(2) + (b[7] - a[7]).powi(2) + (b[11] - a[11]).powi(2)).sqrt()
}

/// The true heading change into each frame `i >= 1`: the vehicle's turn about its own vertical,
/// the ground truth's camera rotation from frame `i - 1` to `i` seen through
/// `vehicle_from_camera` (the mount's rotation, body level), radians counter-clockwise.
pub fn true_heading_changes_rad(gt: &[Pose], vehicle_from_camera: &Matrix3<f64>) -> Vec<f64> {
    let rotation = |p: &Pose| Matrix3::new(p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]);
    gt.windows(2)
        .map(|w| {
            let rel = rotation(&w[0]).transpose() * rotation(&w[1]);
            let q = vehicle_from_camera * rel * vehicle_from_camera.transpose();
            q[(1, 0)].atan2(q[(0, 0)])
        })
        .collect()
}

/// [`HeadingChangeErrors`] of `estimated_rad` (the heading change of each frame, the first
/// frame's ignored) against [`true_heading_changes_rad`].
pub fn heading_change_errors(
    gt: &[Pose],
    estimated_rad: &[f64],
    vehicle_from_camera: &Matrix3<f64>,
) -> Result<HeadingChangeErrors> {
    if gt.len() != estimated_rad.len() || gt.len() < 2 {
        bail!(
            "{} ground-truth poses for {} estimates: need as many, and two or more",
            gt.len(),
            estimated_rad.len()
        );
    }
    let errors: Vec<f64> = true_heading_changes_rad(gt, vehicle_from_camera)
        .iter()
        .zip(&estimated_rad[1..])
        .map(|(t, e)| (e - t).to_degrees())
        .collect();
    let n = errors.len() as f64;
    Ok(HeadingChangeErrors {
        frames: errors.len(),
        rms_deg: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        mean_deg: errors.iter().sum::<f64>() / n,
    })
}

/// [`evaluate`], plus the same metric in the ground plane only and the planar floors, level and
/// in the estimate's own plane.
pub fn evaluate_planar(gt: &[Pose], est: &[Pose]) -> Result<Report> {
    let mut report = evaluate(gt, est)?;
    let (gt_p, est_p): (Vec<Pose>, Vec<Pose>) = (
        gt.iter().map(planar_pose).collect(),
        est.iter().map(planar_pose).collect(),
    );
    let floor = evaluate(gt, &gt_p)?;
    report.planar_floor = floor.t_err_pct.zip(floor.r_err_deg_per_m);
    report.own_plane_floor = match vertical_of(est) {
        Some(up) => {
            let first = gt.first().map(matrix).unwrap_or_else(Matrix4::identity);
            let in_plane: Vec<Pose> = gt.iter().map(|p| in_plane(p, &first, &up)).collect();
            let floor = evaluate(gt, &in_plane)?;
            floor
                .t_err_pct
                .zip(floor.r_err_deg_per_m)
                .map(|(t, r)| OwnPlaneFloor {
                    pitch_down_deg: (-up.z).asin().to_degrees(),
                    roll_left_up_deg: (-up.x).asin().to_degrees(),
                    t_err_pct: t,
                    r_err_deg_per_m: r,
                })
        }
        None => None,
    };
    report.planar = Some(Box::new(evaluate(&gt_p, &est_p)?));
    Ok(report)
}

/// The rotation part of a pose.
fn rotation(m: &Matrix4<f64>) -> Rotation3<f64> {
    Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into())
}

/// The vertical a planar estimate turns about, in its first camera's axes (pointing up, where
/// the camera's y points down): the mean axis of its turns from the first frame of at least
/// [`MIN_AXIS_TURN_DEG`], weighted by their angles. `None` if it never turns that far.
fn vertical_of(est: &[Pose]) -> Option<Unit<Vector3<f64>>> {
    let from_first = rotation(&matrix(est.first()?)).inverse();
    let mut sum = Vector3::zeros();
    for p in est {
        let Some((axis, angle)) = (from_first * rotation(&matrix(p))).axis_angle() else {
            continue;
        };
        if angle.to_degrees() >= MIN_AXIS_TURN_DEG {
            let up = if axis.y > 0.0 {
                -axis.into_inner()
            } else {
                axis.into_inner()
            };
            sum += up * angle;
        }
    }
    Unit::try_new(sum, 1e-9)
}

/// Pose `p` as its planar motion from `first` in the plane through `first`'s camera normal to
/// `up` (in `first`'s axes): its position projected onto the plane, its rotation the part of it
/// about `up` (the twist of its quaternion).
fn in_plane(p: &Pose, first: &Matrix4<f64>, up: &Unit<Vector3<f64>>) -> Pose {
    let rel = rigid_inverse(first) * matrix(p);
    let q = UnitQuaternion::from_rotation_matrix(&rotation(&rel));
    let twist = 2.0 * q.vector().dot(up).atan2(q.scalar());
    let t: Vector3<f64> = rel.fixed_view::<3, 1>(0, 3).into();
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(Rotation3::from_axis_angle(up, twist).matrix());
    m.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(t - up.into_inner() * t.dot(up)));
    let m = first * m;
    // The top three rows, row-major.
    std::array::from_fn(|k| m[(k / 4, k % 4)])
}

fn matrix(p: &Pose) -> Matrix4<f64> {
    Matrix4::new(
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], 0.0, 0.0, 0.0,
        1.0,
    )
}

/// Inverse of a rigid transform `[R | t]`.
fn rigid_inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into();
    let t: Vector3<f64> = m.fixed_view::<3, 1>(0, 3).into();
    let rt = r.transpose();
    let mut out = Matrix4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&rt);
    out.fixed_view_mut::<3, 1>(0, 3).copy_from(&(-(rt * t)));
    out
}

/// Rotation angle of the 3x3 part. The devkit takes `acos((trace - 1) / 2)`; near zero that
/// turns a 1e-8 departure from orthonormality (poses written from f32) into 0.01 deg. The angle
/// from cos and sin (the skew part) is the same for true rotations and stays accurate.
fn rotation_angle_rad(m: &Matrix4<f64>) -> f64 {
    let cos = 0.5 * (m[(0, 0)] + m[(1, 1)] + m[(2, 2)] - 1.0);
    let axis = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    );
    (0.5 * axis.norm()).atan2(cos)
}

fn translation_norm(m: &Matrix4<f64>) -> f64 {
    m.fixed_view::<3, 1>(0, 3).norm()
}

/// Cumulative ground-truth path length at each frame, metres.
fn distances(gt: &[Matrix4<f64>]) -> Vec<f64> {
    let mut d = Vec::with_capacity(gt.len());
    let mut acc = 0.0;
    for (i, m) in gt.iter().enumerate() {
        if i > 0 {
            acc += (m.fixed_view::<3, 1>(0, 3) - gt[i - 1].fixed_view::<3, 1>(0, 3)).norm();
        }
        d.push(acc);
    }
    d
}

fn metric(gt: &[Matrix4<f64>], est: &[Matrix4<f64>], dist: &[f64], lengths: &[f64]) -> Metric {
    // (t error / length, r error / length) per segment, grouped by length.
    let mut per: Vec<Vec<(f64, f64)>> = vec![Vec::new(); lengths.len()];
    for first in (0..gt.len()).step_by(STEP_FRAMES) {
        for (k, &len) in lengths.iter().enumerate() {
            let Some(last) = (first..gt.len()).find(|&i| dist[i] > dist[first] + len) else {
                continue;
            };
            let q_gt = rigid_inverse(&gt[first]) * gt[last];
            let q_est = rigid_inverse(&est[first]) * est[last];
            let err = rigid_inverse(&q_est) * q_gt;
            per[k].push((translation_norm(&err) / len, rotation_angle_rad(&err) / len));
        }
    }
    let mean = |v: &[(f64, f64)]| {
        let n = v.len() as f64;
        let (t, r) = v.iter().fold((0.0, 0.0), |a, e| (a.0 + e.0, a.1 + e.1));
        (100.0 * t / n, (r / n).to_degrees())
    };
    let per_length: Vec<LengthRow> = lengths
        .iter()
        .zip(&per)
        .filter(|(_, v)| !v.is_empty())
        .map(|(&length_m, v)| {
            let (t, r) = mean(v);
            LengthRow {
                length_m,
                segments: v.len(),
                t_err_pct: t,
                r_err_deg_per_m: r,
            }
        })
        .collect();
    let all: Vec<(f64, f64)> = per.concat();
    let pooled = (!all.is_empty()).then(|| mean(&all));
    Metric {
        segments: all.len(),
        t_err_pct: pooled.map(|p| p.0),
        r_err_deg_per_m: pooled.map(|p| p.1),
        per_length,
    }
}

/// Compares an estimated trajectory with ground truth, both as KITTI poses of the same frames.
pub fn evaluate(gt: &[Pose], est: &[Pose]) -> Result<Report> {
    if gt.len() != est.len() {
        bail!(
            "ground truth has {} poses and the estimate {}: they must cover the same frames",
            gt.len(),
            est.len()
        );
    }
    if gt.len() < 2 {
        bail!("need at least two poses to evaluate");
    }
    let gt: Vec<Matrix4<f64>> = gt.iter().map(matrix).collect();
    let est: Vec<Matrix4<f64>> = est.iter().map(matrix).collect();
    let dist = distances(&gt);
    let kitti = metric(&gt, &est, &dist, &LENGTHS_M);
    let short = metric(&gt, &est, &dist, &SHORT_LENGTHS_M);
    let path_length_m = *dist.last().expect("two poses");
    let est_path_m = *distances(&est).last().expect("two poses");
    let path_ratio = (path_length_m > 0.0).then(|| est_path_m / path_length_m);
    let (scaled_kitti, scaled_short) = if let Some(ratio) = path_ratio.filter(|&r| r > 0.0) {
        let scaled: Vec<Matrix4<f64>> = est
            .iter()
            .map(|m| {
                let mut m = *m;
                m.fixed_view_mut::<3, 1>(0, 3).unscale_mut(ratio);
                m
            })
            .collect();
        (
            metric(&gt, &scaled, &dist, &LENGTHS_M).t_err_pct,
            metric(&gt, &scaled, &dist, &SHORT_LENGTHS_M).t_err_pct,
        )
    } else {
        (None, None)
    };
    let (g, e) = (
        gt.last().expect("two poses"),
        est.last().expect("two poses"),
    );
    let end_gap = (g.fixed_view::<3, 1>(0, 3) - e.fixed_view::<3, 1>(0, 3)).norm();
    let end_rot = rigid_inverse(e) * g;
    Ok(Report {
        frames: gt.len(),
        path_length_m,
        t_err_pct: kitti.t_err_pct,
        r_err_deg_per_m: kitti.r_err_deg_per_m,
        segments: kitti.segments,
        per_length: kitti.per_length,
        short_t_err_pct: short.t_err_pct,
        short_r_err_deg_per_m: short.r_err_deg_per_m,
        short_segments: short.segments,
        short_per_length: short.per_length,
        path_ratio,
        scaled_t_err_pct: scaled_kitti,
        scaled_short_t_err_pct: scaled_short,
        end_drift_pct: if path_length_m > 0.0 {
            100.0 * end_gap / path_length_m
        } else {
            0.0
        },
        end_heading_err_deg: rotation_angle_rad(&end_rot).to_degrees(),
        planar: None,
        planar_floor: None,
        own_plane_floor: None,
    })
}

/// Formats a report as the table `roadvo eval` prints.
pub fn format_report(r: &Report) -> String {
    let opt =
        |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |x| format!("{x:.digits$}"));
    let mut s = format!(
        "frames {}, ground-truth path {:.1} m\n\nKITTI metric (segments of 100..800 m): t_err {} %, r_err {} deg/m over {} segments\n",
        r.frames,
        r.path_length_m,
        opt(r.t_err_pct, 2),
        opt(r.r_err_deg_per_m, 4),
        r.segments
    );
    let table = |rows: &[LengthRow]| {
        let mut t = String::from("  length_m  segments  t_err_%  r_err_deg/m\n");
        for row in rows {
            t += &format!(
                "  {:>8.0}  {:>8}  {:>7.2}  {:>11.4}\n",
                row.length_m, row.segments, row.t_err_pct, row.r_err_deg_per_m
            );
        }
        t
    };
    if !r.per_length.is_empty() {
        s += &table(&r.per_length);
    }
    s += &format!(
        "\nShort segments (10..50 m; not a KITTI figure): t_err {} %, r_err {} deg/m over {} segments\n",
        opt(r.short_t_err_pct, 2),
        opt(r.short_r_err_deg_per_m, 4),
        r.short_segments
    );
    if !r.short_per_length.is_empty() {
        s += &table(&r.short_per_length);
    }
    s += &format!(
        "\nScale: the estimated path is {} of the true one; with its positions divided by that: \
         KITTI t_err {} %, short t_err {} % (not KITTI figures)\n",
        opt(r.path_ratio, 3),
        opt(r.scaled_t_err_pct, 2),
        opt(r.scaled_short_t_err_pct, 2)
    );
    s += &format!(
        "\nEnd point: drift {:.2} % of the path, heading error {:.2} deg\n",
        r.end_drift_pct, r.end_heading_err_deg
    );
    if let Some(p) = &r.planar {
        s += &format!(
            "\nIn the ground plane only (x-z positions, heading): KITTI t_err {} % ({} % at the true \
             scale), r_err {} deg/m; short t_err {} %, r_err {} deg/m; end drift {:.2} %, heading \
             error {:.2} deg\n",
            opt(p.t_err_pct, 2),
            opt(p.scaled_t_err_pct, 2),
            opt(p.r_err_deg_per_m, 4),
            opt(p.short_t_err_pct, 2),
            opt(p.short_r_err_deg_per_m, 4),
            p.end_drift_pct,
            p.end_heading_err_deg
        );
        if let Some((t, r)) = r.planar_floor {
            s += &format!(
                "Planar floor (the ground truth's own planar motion on the 3D metric, the first camera level): t_err {t:.2} %, r_err {r:.4} deg/m\n"
            );
        }
        if let Some(f) = r.own_plane_floor {
            s += &format!(
                "Planar floor in the estimate's own ground plane (the first camera looking {:.2} deg down at it, its left side {:.2} deg up): t_err {:.2} %, r_err {:.4} deg/m\n",
                f.pitch_down_deg, f.roll_left_up_deg, f.t_err_pct, f.r_err_deg_per_m
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A planar KITTI-camera pose: camera z forward, x right, turning about -y (left turn).
    fn planar(x_fwd: f64, y_left: f64, heading: f64) -> Pose {
        let (s, c) = heading.sin_cos();
        // Vehicle (x fwd, y left, z up) to camera (x right, y down, z fwd): x_c = -y, z_c = x.
        [c, 0.0, -s, -y_left, 0.0, 1.0, 0.0, 0.0, s, 0.0, c, x_fwd]
    }

    fn straight(n: usize, step: f64) -> Vec<Pose> {
        (0..n).map(|i| planar(i as f64 * step, 0.0, 0.0)).collect()
    }

    #[test]
    fn a_true_step_is_the_distance_between_camera_centres() {
        let gt = straight(3, 0.8);
        assert!((true_step_m(&gt, 2) - 0.8).abs() < 1e-12);
        let turned = [gt[0], planar(0.3, 0.4, 0.5)];
        assert!((true_step_m(&turned, 1) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn heading_changes_are_the_vehicle_s_turns_whatever_the_mount() {
        // A camera pitched down 10 deg, yawed 2 deg, rolled 1 deg: the camera's own rotation
        // between frames is not a turn about its y axis, the vehicle's is about its vertical.
        let mount = roadvo::Mount {
            pitch_rad: 10f32.to_radians(),
            yaw_rad: 2f32.to_radians(),
            roll_rad: 1f32.to_radians(),
            ..roadvo::Mount::DEFAULT
        };
        let m = mount.rotation_vehicle_from_camera(roadvo::Attitude::default());
        let turns_rad = [0.0, 0.02, -0.05, 0.3];
        let mut heading = 0.0;
        let gt: Vec<Pose> = turns_rad
            .iter()
            .map(|t| {
                heading += t;
                // The first camera's frame is the world's (KITTI's convention).
                let r = m.transpose() * Rotation3::from_axis_angle(&Vector3::z_axis(), heading) * m;
                [
                    r[(0, 0)],
                    r[(0, 1)],
                    r[(0, 2)],
                    0.0,
                    r[(1, 0)],
                    r[(1, 1)],
                    r[(1, 2)],
                    0.0,
                    r[(2, 0)],
                    r[(2, 1)],
                    r[(2, 2)],
                    0.0,
                ]
            })
            .collect();
        let truth = true_heading_changes_rad(&gt, &m);
        for (got, want) in truth.iter().zip(&turns_rad[1..]) {
            assert!((got - want).abs() < 1e-12, "{truth:?}");
        }
        let off = [0.0, 0.021, -0.051, 0.3];
        let e = heading_change_errors(&gt, &off, &m).unwrap();
        assert!(e.mean_deg.abs() < 1e-9, "{e:?}");
        assert!((e.rms_deg - (2.0f64 / 3.0).sqrt() * 0.001f64.to_degrees()).abs() < 1e-9);
        assert!(heading_change_errors(&gt, &off[1..], &m).is_err());
    }

    #[test]
    fn identical_trajectories_score_zero() {
        let gt = straight(3000, 0.1);
        let r = evaluate(&gt, &gt).unwrap();
        assert_eq!(r.t_err_pct, Some(0.0));
        assert_eq!(r.r_err_deg_per_m, Some(0.0));
        assert_eq!(r.end_drift_pct, 0.0);
        assert_eq!(r.end_heading_err_deg, 0.0);
        assert!(r.segments > 0 && r.short_segments > 0);
    }

    #[test]
    fn five_percent_scale_error_scores_five_percent() {
        let gt = straight(3000, 0.1);
        let est = straight(3000, 0.105);
        let r = evaluate(&gt, &est).unwrap();
        // Segments end at the first frame past the length, 0.1 m longer than nominal.
        for row in r.per_length.iter().chain(&r.short_per_length) {
            let want = 5.0 * (row.length_m + 0.1) / row.length_m;
            assert!((row.t_err_pct - want).abs() < 1e-6, "{row:?}");
        }
        let pooled = r.t_err_pct.unwrap();
        assert!(pooled > 5.0 && pooled < 5.005, "{pooled}");
        assert!(r.r_err_deg_per_m.unwrap().abs() < 1e-9);
        assert!((r.end_drift_pct - 5.0).abs() < 1e-9);
        // All of it is scale: divided by the path ratio, nothing is left.
        let ratio = r.path_ratio.unwrap();
        assert!((ratio - 1.05).abs() < 1e-9, "{ratio}");
        assert!(
            r.scaled_t_err_pct.unwrap() < 1e-9,
            "{:?}",
            r.scaled_t_err_pct
        );
        assert!(r.scaled_short_t_err_pct.unwrap() < 1e-9);
    }

    #[test]
    fn heading_rate_bias_scores_its_rate() {
        // The estimate drives the same distance but turns 0.01 deg per metre.
        let bias = 0.01f64.to_radians();
        let gt = straight(3000, 0.1);
        let mut est = Vec::new();
        let (mut x, mut y, mut h) = (0.0, 0.0, 0.0);
        for _ in 0..3000 {
            est.push(planar(x, y, h));
            x += 0.1 * h.cos();
            y += 0.1 * h.sin();
            h += bias * 0.1;
        }
        let r = evaluate(&gt, &est).unwrap();
        // Segments are 0.1 m longer than nominal, so the angle per nominal metre is a bit more.
        let want = 0.01 * (1.0 + 0.1 / 100.0);
        let got = r.r_err_deg_per_m.unwrap();
        assert!((got - want).abs() < 2e-4 * want + 1e-6, "{got} vs {want}");
        let got_short = r.short_r_err_deg_per_m.unwrap();
        assert!((got_short - 0.01).abs() < 3e-4, "{got_short}");
        // The path is as long as the truth's: the scale takes none of the error away.
        assert!((r.path_ratio.unwrap() - 1.0).abs() < 1e-12);
        assert!((r.scaled_t_err_pct.unwrap() - r.t_err_pct.unwrap()).abs() < 1e-9);
    }

    #[test]
    fn a_truth_that_does_not_move_has_no_scale() {
        let gt = straight(20, 0.0);
        let r = evaluate(&gt, &straight(20, 0.1)).unwrap();
        assert_eq!(r.path_ratio, None);
        assert_eq!((r.scaled_t_err_pct, r.scaled_short_t_err_pct), (None, None));
        assert!(format_report(&r).contains("path is - of the true one"));
    }

    #[test]
    fn short_drive_has_only_short_metric() {
        let gt = straight(400, 0.1);
        let r = evaluate(&gt, &gt).unwrap();
        assert_eq!((r.t_err_pct, r.segments), (None, 0));
        assert_eq!(r.short_t_err_pct, Some(0.0));
        let text = format_report(&r);
        assert!(text.contains("t_err - %"), "{text}");
    }

    #[test]
    fn rotation_angle_matches_the_devkit_for_true_rotations() {
        for deg in [0.5f64, 10.0, 90.0, 170.0] {
            let p = planar(0.0, 0.0, deg.to_radians());
            let got = rotation_angle_rad(&matrix(&p)).to_degrees();
            assert!((got - deg).abs() < 1e-9, "{got} vs {deg}");
        }
    }

    #[test]
    fn planar_metric_ignores_the_climb_that_the_3d_metric_counts() {
        // A straight 150 m drive climbing 5 %: the estimate stays level.
        let est = straight(151, 1.0);
        let gt: Vec<Pose> = est
            .iter()
            .map(|p| {
                let mut q = *p;
                q[7] = -0.05 * p[11];
                q
            })
            .collect();
        let r = evaluate_planar(&gt, &est).unwrap();
        assert!(r.t_err_pct.unwrap() > 4.0, "{:?}", r.t_err_pct);
        let planar = r.planar.as_ref().unwrap();
        assert!(planar.t_err_pct.unwrap() < 1e-9, "{:?}", planar.t_err_pct);
        // The floor is what the level estimate scores: it is the planar motion of the truth.
        let (floor_t, _) = r.planar_floor.unwrap();
        assert!((floor_t - r.t_err_pct.unwrap()).abs() < 1e-9);
    }

    #[test]
    fn a_camera_looking_down_at_its_plane_has_that_plane_as_its_floor() {
        // A drive in the ground plane of a camera looking 2 deg down at it (its up vector tilted
        // back), turning left at 0.01 rad/m, and an estimate that is the truth itself.
        let tilt = 2f64.to_radians();
        let up = Unit::new_normalize(Vector3::new(0.0, -tilt.cos(), -tilt.sin()));
        let z = Vector3::z();
        let ahead = (z - up.into_inner() * z.dot(&up)).normalize();
        let (mut t, mut gt) = (Vector3::zeros(), Vec::new());
        for i in 0..3000 {
            let turn = Rotation3::from_axis_angle(&up, 0.001 * f64::from(i));
            let m = turn.matrix();
            gt.push(std::array::from_fn(|k| {
                let (i, j) = (k / 4, k % 4);
                if j == 3 { t[i] } else { m[(i, j)] }
            }));
            t += turn * ahead * 0.1;
        }
        let r = evaluate_planar(&gt, &gt).unwrap();
        let own = r.own_plane_floor.unwrap();
        assert!((own.pitch_down_deg - 2.0).abs() < 1e-9, "{own:?}");
        assert!(own.roll_left_up_deg.abs() < 1e-9, "{own:?}");
        assert!(
            own.t_err_pct < 1e-6 && own.r_err_deg_per_m < 1e-6,
            "{own:?}"
        );
        // Taken as level, the same drive climbs and turns about a tilted axis.
        let (level_t, level_r) = r.planar_floor.unwrap();
        assert!(level_t > 0.5 && level_r > 1e-4, "{level_t} {level_r}");
        assert!(format_report(&r).contains("looking 2.00 deg down at it"));
        // A truth that climbs out of that plane, 5 cm a frame: the estimate is its motion in the
        // plane, so it scores the floor.
        let climbing: Vec<Pose> = gt
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let mut q = *p;
                for (k, u) in [3, 7, 11].into_iter().zip(up.iter()) {
                    q[k] += 0.05 * f64::from(i as u32) * u;
                }
                q
            })
            .collect();
        let r = evaluate_planar(&climbing, &gt).unwrap();
        let own = r.own_plane_floor.unwrap();
        assert!(r.t_err_pct.unwrap() > 10.0, "{:?}", r.t_err_pct);
        assert!(
            (own.t_err_pct - r.t_err_pct.unwrap()).abs() < 1e-6,
            "{own:?}"
        );
    }

    #[test]
    fn a_straight_estimate_has_no_plane_of_its_own() {
        let gt = straight(1100, 0.1);
        let r = evaluate_planar(&gt, &gt).unwrap();
        assert_eq!(r.own_plane_floor, None);
        assert!(r.planar_floor.is_some());
    }

    #[test]
    fn planar_pose_keeps_heading_and_ground_position() {
        let p = planar(3.0, 1.5, 0.4);
        assert!(
            p.iter()
                .zip(planar_pose(&p))
                .all(|(a, b)| (a - b).abs() < 1e-12)
        );
    }

    #[test]
    fn lengths_must_match() {
        let e = evaluate(&straight(10, 1.0), &straight(9, 1.0)).unwrap_err();
        assert!(e.to_string().contains("10 poses and the estimate 9"));
    }
}
