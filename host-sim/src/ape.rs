//! The absolute and relative pose errors evo reports (`evo_ape`, `evo_rpe`), translation part,
//! after an Umeyama alignment of the estimate to the ground truth.
//!
//! APE: the distance between each estimated position (aligned) and the true one, metres. RPE
//! per distance: the aligned estimate's path (or the ground truth's: [`PairsFrom`]) is cut into
//! consecutive sections of `delta` metres (evo's `--delta D --delta_unit m`, and
//! `--pairs_from_reference`); the error of a section from `i` to `j` is
//! `E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)` (Q the truth, P the aligned estimate), its translation
//! norm in metres and rotation angle in degrees. The alignment ([`umeyama`]) is the least-squares
//! rigid motion (SE(3)) or similarity (Sim(3), with a scale: a monocular estimate's) taking the
//! estimated positions onto the true ones, in the ground truth's world frame.

use crate::kitti::Pose;
use anyhow::{Result, bail};
use nalgebra::{Matrix3, Matrix4, Vector3};
use serde::Serialize;

/// How the estimate is aligned to the ground truth before the errors are taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Alignment {
    /// As it is (evo without `-a`).
    None,
    /// A rotation and translation (evo's `-a`).
    Se3,
    /// A rotation, translation and scale (evo's `-as`).
    Sim3,
}

/// A similarity `y = scale * rotation * x + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Rotation.
    pub rotation: Matrix3<f64>,
    /// Translation, metres of the target frame.
    pub translation: Vector3<f64>,
    /// Scale (1 for a rigid motion).
    pub scale: f64,
}

impl Similarity {
    /// The identity.
    pub const IDENTITY: Self = Self {
        rotation: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        translation: Vector3::new(0.0, 0.0, 0.0),
        scale: 1.0,
    };

    /// Pose `p` moved by the similarity: its position mapped, its rotation turned.
    pub fn apply(&self, p: &Pose) -> Pose {
        let r = self.rotation * Matrix3::from_fn(|i, j| p[4 * i + j]);
        let t = self.scale * self.rotation * position(p) + self.translation;
        std::array::from_fn(|k| {
            let (i, j) = (k / 4, k % 4);
            if j == 3 { t[i] } else { r[(i, j)] }
        })
    }
}

/// The least-squares similarity (a rigid motion without `with_scale`) taking points `from` onto
/// `to` (Umeyama 1991, as evo's `umeyama_alignment`). An error for fewer than 3 points, sets of
/// different sizes, or points on a line (no rotation is determined).
pub fn umeyama(from: &[Vector3<f64>], to: &[Vector3<f64>], with_scale: bool) -> Result<Similarity> {
    if from.len() != to.len() || from.len() < 3 {
        bail!(
            "an alignment needs as many points on both sides, three or more ({} and {})",
            from.len(),
            to.len()
        );
    }
    let n = from.len() as f64;
    let mean = |v: &[Vector3<f64>]| v.iter().sum::<Vector3<f64>>() / n;
    let (mean_x, mean_y) = (mean(from), mean(to));
    let sigma_x = from
        .iter()
        .map(|x| (x - mean_x).norm_squared())
        .sum::<f64>()
        / n;
    let cov = from
        .iter()
        .zip(to)
        .map(|(x, y)| (y - mean_y) * (x - mean_x).transpose())
        .sum::<Matrix3<f64>>()
        / n;
    let svd = cov.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        bail!("the alignment's SVD did not converge");
    };
    let d = svd.singular_values;
    if d.iter().filter(|&&s| s > f64::EPSILON).count() < 2 {
        bail!("the positions lie on a line or a point: no alignment is determined");
    }
    // Flip the axis of the smallest singular value if U V^T would be a reflection.
    let mut s = Vector3::new(1.0, 1.0, 1.0);
    if u.determinant() * v_t.determinant() < 0.0 {
        s[d.imin()] = -1.0;
    }
    let rotation = u * Matrix3::from_diagonal(&s) * v_t;
    let scale = if with_scale { d.dot(&s) / sigma_x } else { 1.0 };
    Ok(Similarity {
        rotation,
        translation: mean_y - scale * rotation * mean_x,
        scale,
    })
}

/// Statistics of a set of errors, as evo prints them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median (the mean of the middle two for an even count).
    pub median: f64,
    /// Standard deviation (about the mean, over n).
    pub std: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
}

impl Stats {
    /// The statistics of `errors`; all zero without any.
    pub fn of(errors: &[f64]) -> Self {
        if errors.is_empty() {
            return Self::default();
        }
        let n = errors.len() as f64;
        let mean = errors.iter().sum::<f64>() / n;
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let mid = sorted.len() / 2;
        let median = if sorted.len().is_multiple_of(2) {
            0.5 * (sorted[mid - 1] + sorted[mid])
        } else {
            sorted[mid]
        };
        Self {
            rmse: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
            mean,
            median,
            std: (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n).sqrt(),
            min: sorted[0],
            max: sorted[sorted.len() - 1],
        }
    }
}

/// The absolute pose error, translation part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Ape {
    /// The alignment applied to the estimate.
    pub alignment: Alignment,
    /// Its scale (1 but for Sim(3)): true metres per estimated metre.
    pub scale: f64,
    /// Position errors, metres.
    pub translation_m: Stats,
}

/// Whose path the RPE's sections are cut along.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PairsFrom {
    /// The aligned estimate's (evo's default).
    Estimate,
    /// The ground truth's (evo's `--pairs_from_reference`).
    GroundTruth,
}

/// The relative pose error over sections of a path.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Rpe {
    /// Section length along the path, metres.
    pub delta_m: f64,
    /// Whose path.
    pub pairs_from: PairsFrom,
    /// Sections compared.
    pub pairs: usize,
    /// Translation errors, metres (`None` without sections).
    pub translation_m: Option<Stats>,
    /// Rotation errors, degrees (`None` without sections).
    pub rotation_deg: Option<Stats>,
}

/// An estimate aligned to its ground truth, and its errors.
#[derive(Clone, Debug, PartialEq)]
pub struct Aligned {
    /// The estimate's poses moved by the alignment, in the ground truth's world frame.
    pub poses: Vec<Pose>,
    /// The APE.
    pub ape: Ape,
    /// Each pose's position error, metres.
    pub errors_m: Vec<f64>,
}

fn position(p: &Pose) -> Vector3<f64> {
    Vector3::new(p[3], p[7], p[11])
}

/// Aligns `est` to `gt` (paired pose by pose) as `alignment` says and takes the APE.
pub fn ape(gt: &[Pose], est: &[Pose], alignment: Alignment) -> Result<Aligned> {
    if gt.len() != est.len() || gt.is_empty() {
        bail!(
            "{} ground-truth poses for {} estimated: need as many, one or more",
            gt.len(),
            est.len()
        );
    }
    let similarity = match alignment {
        Alignment::None => Similarity::IDENTITY,
        Alignment::Se3 | Alignment::Sim3 => {
            let from: Vec<_> = est.iter().map(position).collect();
            let to: Vec<_> = gt.iter().map(position).collect();
            umeyama(&from, &to, alignment == Alignment::Sim3)?
        }
    };
    let poses: Vec<Pose> = est.iter().map(|p| similarity.apply(p)).collect();
    let errors_m: Vec<f64> = gt
        .iter()
        .zip(&poses)
        .map(|(g, e)| (position(g) - position(e)).norm())
        .collect();
    Ok(Aligned {
        ape: Ape {
            alignment,
            scale: similarity.scale,
            translation_m: Stats::of(&errors_m),
        },
        poses,
        errors_m,
    })
}

/// The ground truth's path length up to each pose, metres.
pub fn distances_m(gt: &[Pose]) -> Vec<f64> {
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(gt.len());
    for (i, p) in gt.iter().enumerate() {
        if i > 0 {
            acc += (position(p) - position(&gt[i - 1])).norm();
        }
        out.push(acc);
    }
    out
}

/// The RPE of `est` (already aligned) against `gt` (paired pose by pose) over consecutive
/// sections of `delta_m` metres of the path `pairs_from` names: evo's `filter_pairs_by_path`
/// without `--all_pairs`.
pub fn rpe(gt: &[Pose], est: &[Pose], delta_m: f64, pairs_from: PairsFrom) -> Rpe {
    let n = gt.len().min(est.len());
    let along = match pairs_from {
        PairsFrom::Estimate => &est[..n],
        PairsFrom::GroundTruth => &gt[..n],
    };
    let mut ids = vec![0];
    let mut path = 0.0;
    for i in 1..n {
        path += (position(&along[i]) - position(&along[i - 1])).norm();
        if path >= delta_m {
            ids.push(i);
            path = 0.0;
        }
    }
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for w in ids.windows(2) {
        let rel = |p: &[Pose]| inverse(&matrix(&p[w[0]])) * matrix(&p[w[1]]);
        let e = inverse(&rel(gt)) * rel(est);
        t.push(e.fixed_view::<3, 1>(0, 3).norm());
        let rot: Matrix3<f64> = e.fixed_view::<3, 3>(0, 0).into();
        r.push(angle_deg(&rot));
    }
    let some = |v: &[f64]| (!v.is_empty()).then(|| Stats::of(v));
    Rpe {
        delta_m,
        pairs_from,
        pairs: t.len(),
        translation_m: some(&t),
        rotation_deg: some(&r),
    }
}

fn matrix(p: &Pose) -> Matrix4<f64> {
    Matrix4::from_fn(|i, j| {
        if i < 3 {
            p[4 * i + j]
        } else {
            f64::from(j == 3)
        }
    })
}

fn inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into();
    let t: Vector3<f64> = m.fixed_view::<3, 1>(0, 3).into();
    let mut out = Matrix4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&r.transpose());
    out.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(-(r.transpose() * t)));
    out
}

/// The rotation angle of `r`, degrees, from its cosine and sine (accurate near 0 and 180).
fn angle_deg(r: &Matrix3<f64>) -> f64 {
    let cos = 0.5 * (r.trace() - 1.0);
    let sin = 0.5
        * Vector3::new(
            r[(2, 1)] - r[(1, 2)],
            r[(0, 2)] - r[(2, 0)],
            r[(1, 0)] - r[(0, 1)],
        )
        .norm();
    sin.atan2(cos).to_degrees()
}

/// Formats the APE and RPE as `roadvo eval` prints them.
pub fn format_ape_rpe(ape: &Ape, rpe: &Rpe) -> String {
    let stats = |s: &Stats, d: usize| {
        format!(
            "rmse {:.d$}, mean {:.d$}, median {:.d$}, std {:.d$}, min {:.d$}, max {:.d$}",
            s.rmse, s.mean, s.median, s.std, s.min, s.max
        )
    };
    let how = match ape.alignment {
        Alignment::None => "no alignment".to_string(),
        Alignment::Se3 => "SE(3) Umeyama alignment".to_string(),
        Alignment::Sim3 => format!("Sim(3) Umeyama alignment, scale {:.6}", ape.scale),
    };
    let mut s = format!(
        "\nAPE, translation (m; {how}): {}\n",
        stats(&ape.translation_m, 4)
    );
    let whose = match rpe.pairs_from {
        PairsFrom::Estimate => "the estimate's",
        PairsFrom::GroundTruth => "the ground truth's",
    };
    match (&rpe.translation_m, &rpe.rotation_deg) {
        (Some(t), Some(r)) => {
            s += &format!(
                "RPE over {:.0} m of {whose} path ({} sections, same alignment):\n  \
                 translation (m): {}\n  rotation (deg): {}\n",
                rpe.delta_m,
                rpe.pairs,
                stats(t, 4),
                stats(r, 4)
            );
        }
        _ => {
            s += &format!(
                "RPE over {:.0} m: {whose} path is shorter, no sections\n",
                rpe.delta_m
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// A wiggly 3D drive: positions spread in all three axes, turning.
    fn drive(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|i| {
                let s = i as f64;
                let r = Rotation3::from_euler_angles(0.01 * s, 0.05 * s, 0.002 * s);
                let t = Vector3::new(10.0 * (0.05 * s).sin(), 0.3 * (0.11 * s).cos(), 1.2 * s);
                std::array::from_fn(|k| {
                    let (i, j) = (k / 4, k % 4);
                    if j == 3 { t[i] } else { r[(i, j)] }
                })
            })
            .collect()
    }

    fn known() -> Similarity {
        Similarity {
            rotation: *Rotation3::from_euler_angles(0.3, -1.1, 2.0).matrix(),
            translation: Vector3::new(4.0, -7.5, 0.25),
            scale: 0.37,
        }
    }

    #[test]
    fn umeyama_recovers_a_known_similarity() {
        let gt = drive(200);
        let truth = known();
        // The estimate is the truth seen through the inverse similarity.
        let from: Vec<_> = gt.iter().map(position).collect();
        let to: Vec<_> = from
            .iter()
            .map(|x| truth.scale * truth.rotation * x + truth.translation)
            .collect();
        let got = umeyama(&from, &to, true).unwrap();
        assert!((got.scale - truth.scale).abs() < 1e-12, "{got:?}");
        assert!((got.rotation - truth.rotation).amax() < 1e-12, "{got:?}");
        assert!(
            (got.translation - truth.translation).amax() < 1e-10,
            "{got:?}"
        );
        // Rigid only: the same rotation when the scale is 1.
        let rigid: Vec<_> = from.iter().map(|x| truth.rotation * x).collect();
        let got = umeyama(&from, &rigid, false).unwrap();
        assert_eq!(got.scale, 1.0);
        assert!((got.rotation - truth.rotation).amax() < 1e-12);
    }

    #[test]
    fn a_similar_estimate_has_no_error_once_aligned() {
        let gt = drive(300);
        let truth = known();
        let inv = Similarity {
            rotation: truth.rotation.transpose(),
            translation: -(truth.rotation.transpose() * truth.translation) / truth.scale,
            scale: 1.0 / truth.scale,
        };
        let est: Vec<Pose> = gt.iter().map(|p| inv.apply(p)).collect();
        let a = ape(&gt, &est, Alignment::Sim3).unwrap();
        assert!(a.ape.translation_m.max < 1e-9, "{:?}", a.ape);
        assert!((a.ape.scale - truth.scale).abs() < 1e-12);
        let r = rpe(&gt, &a.poses, 20.0, PairsFrom::Estimate);
        assert!(r.pairs > 10 && r.translation_m.unwrap().max < 1e-9, "{r:?}");
        assert!(r.rotation_deg.unwrap().max < 1e-6, "{r:?}");
        // Without the scale, the error remains.
        assert!(
            ape(&gt, &est, Alignment::Se3)
                .unwrap()
                .ape
                .translation_m
                .rmse
                > 1.0
        );
    }

    #[test]
    fn a_trajectory_against_itself_scores_zero() {
        let gt = drive(100);
        for alignment in [Alignment::None, Alignment::Se3, Alignment::Sim3] {
            let a = ape(&gt, &gt, alignment).unwrap();
            assert!(a.ape.translation_m.max < 1e-9, "{alignment:?} {:?}", a.ape);
            assert!((a.ape.scale - 1.0).abs() < 1e-12);
            let r = rpe(&gt, &a.poses, 10.0, PairsFrom::GroundTruth);
            assert!(r.translation_m.unwrap().max < 1e-9);
        }
    }

    #[test]
    fn stats_are_evo_s() {
        let s = Stats::of(&[3.0, 1.0, 4.0, 2.0]);
        assert_eq!((s.min, s.max, s.mean, s.median), (1.0, 4.0, 2.5, 2.5));
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-15);
        assert_eq!(Stats::of(&[5.0, 1.0, 2.0]).median, 2.0);
    }

    #[test]
    fn rpe_sections_follow_the_path_asked_for() {
        // 1.2 m a frame ahead (plus the wiggle): sections of at least 12 m.
        let gt = drive(100);
        let mut est = gt.clone();
        for p in &mut est {
            p[11] *= 1.1;
        }
        let r = rpe(&gt, &est, 12.0, PairsFrom::GroundTruth);
        assert!(r.pairs >= 8 && r.pairs < 11, "{r:?}");
        // Along the estimate's path, 10 % longer: more sections.
        let longer = rpe(&gt, &est, 12.0, PairsFrom::Estimate);
        assert!(longer.pairs > r.pairs, "{longer:?}");
        assert!(r.translation_m.unwrap().mean > 1.0);
        let none = rpe(&gt, &est, 1e6, PairsFrom::Estimate);
        assert_eq!((none.pairs, none.translation_m), (0, None));
        assert!(
            format_ape_rpe(&ape(&gt, &est, Alignment::None).unwrap().ape, &none)
                .contains("no sections")
        );
    }

    #[test]
    fn points_on_a_line_are_refused() {
        let line: Vec<_> = (0..10)
            .map(|i| Vector3::new(0.0, 0.0, f64::from(i)))
            .collect();
        let e = umeyama(&line, &line, true).unwrap_err().to_string();
        assert!(e.contains("on a line"), "{e}");
    }
}
