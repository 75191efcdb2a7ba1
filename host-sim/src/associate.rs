//! Pairs of poses of two trajectories to compare: by timestamp, as evo's `nearest_time`
//! association, or line by line.

use serde::Serialize;

/// evo's default largest timestamp difference of a pair (`--t_max_diff`), seconds.
pub const DEFAULT_MAX_DIFF_S: f64 = 0.01;

/// How the poses of two trajectories were paired.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Association {
    /// `"timestamp"` (both files have timestamps) or `"line"`.
    pub by: &'static str,
    /// The largest timestamp difference of a pair, seconds (by timestamp only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_diff_s: Option<f64>,
    /// Poses of the ground truth.
    pub gt_poses: usize,
    /// Poses of the estimate.
    pub est_poses: usize,
    /// Pairs: (ground-truth index, estimate index), in order.
    #[serde(skip)]
    pub pairs: Vec<(usize, usize)>,
    /// Pairs found.
    pub matched: usize,
}

/// Pairs each pose of the trajectory with fewer poses (the estimate's on a tie) with the pose of
/// the other nearest in time, if within `max_diff_s` seconds: evo's `associate_trajectories`
/// with `nearest_time`. Timestamps in seconds; pairs (ground truth, estimate) in the shorter
/// trajectory's order.
pub fn by_timestamp(gt_s: &[f64], est_s: &[f64], max_diff_s: f64) -> Association {
    let est_shorter = est_s.len() <= gt_s.len();
    let (short, long) = if est_shorter {
        (est_s, gt_s)
    } else {
        (gt_s, est_s)
    };
    let pairs = short
        .iter()
        .enumerate()
        .filter_map(|(i, &t)| nearest(long, t, max_diff_s).map(|j| (i, j)))
        .map(|(i, j)| if est_shorter { (j, i) } else { (i, j) })
        .collect::<Vec<_>>();
    Association {
        by: "timestamp",
        max_diff_s: Some(max_diff_s),
        gt_poses: gt_s.len(),
        est_poses: est_s.len(),
        matched: pairs.len(),
        pairs,
    }
}

/// Pairs pose `i` with pose `i`: as many as the shorter has.
pub fn by_line(gt_poses: usize, est_poses: usize) -> Association {
    let pairs: Vec<(usize, usize)> = (0..gt_poses.min(est_poses)).map(|i| (i, i)).collect();
    Association {
        by: "line",
        max_diff_s: None,
        gt_poses,
        est_poses,
        matched: pairs.len(),
        pairs,
    }
}

/// The index of the time in `times` nearest `t`, if within `max_diff`; on a tie the earlier
/// (evo's rule for sorted times; unsorted times are searched through, the first minimum won).
fn nearest(times: &[f64], t: f64, max_diff: f64) -> Option<usize> {
    let sorted = times.windows(2).all(|w| w[0] <= w[1]);
    let best = if sorted {
        let upper = times.partition_point(|&s| s <= t).min(times.len() - 1);
        let diff_ub = times[upper] - t;
        let diff_lb = if upper > 0 {
            t - times[upper - 1]
        } else {
            f64::INFINITY
        };
        if diff_ub <= max_diff && diff_ub < diff_lb {
            upper
        } else {
            upper.checked_sub(1)?
        }
    } else {
        (0..times.len()).min_by(|&a, &b| (times[a] - t).abs().total_cmp(&(times[b] - t).abs()))?
    };
    ((times[best] - t).abs() <= max_diff).then_some(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_the_nearest_within_the_difference() {
        let gt = [0.0, 0.1, 0.2, 0.3, 0.4];
        let est = [0.004, 0.196, 0.27, 0.9];
        let a = by_timestamp(&gt, &est, DEFAULT_MAX_DIFF_S);
        assert_eq!(a.pairs, vec![(0, 0), (2, 1)]);
        let a = by_timestamp(&gt, &est, 0.05);
        assert_eq!(a.pairs, vec![(0, 0), (2, 1), (3, 2)]);
        // The ground truth shorter: its poses are the ones paired.
        let a = by_timestamp(&est, &gt, 0.05);
        assert_eq!(a.pairs, vec![(0, 0), (1, 2), (2, 3)]);
    }

    #[test]
    fn unsorted_times_are_searched_through() {
        let a = by_timestamp(&[0.3, 0.1, 0.2], &[0.1, 0.2], 0.01);
        assert_eq!(a.pairs, vec![(1, 0), (2, 1)]);
    }

    #[test]
    fn by_line_pairs_as_many_as_the_shorter() {
        let a = by_line(3, 5);
        assert_eq!((a.pairs, a.matched), (vec![(0, 0), (1, 1), (2, 2)], 3));
    }
}
