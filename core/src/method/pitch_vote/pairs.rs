//! One pair of a track (a ground point in the previous frame) and an observation (in this one)
//! under the arc model: the heading change turns the observation back, the chord between them
//! has the direction of half the turn; the component along it is the distance, the component
//! across it the pair's residual. And the vote a pair gives: a tent across the lateral tolerance
//! and, along the distance, a tent as wide as its corners' rows allow.

use crate::config::ValidConfig;
use crate::projection::GroundPoint;
use crate::vote::{BestPerBin, MotionWindow};

const VOTE_WEIGHT: f32 = 8.0;
/// Half width of a pair's distance tent in standard deviations of its distance.
const SPREAD_SIGMAS: f32 = 2.0;

/// Heading step over which a residual's rate with the heading is taken, radians (1 mrad: the
/// residual is nearly linear in the heading over a window's width, see step 3).
pub const HEADING_STEP_RAD: f32 = 1e-3;

/// Per heading bin: cos alpha, sin alpha, cos alpha/2, sin alpha/2, 1 / sinc(alpha/2).
pub type Trig = [f32; 5];

/// The trigonometry of heading change `alpha` a pair's residual needs.
pub fn trig(alpha: f32) -> Trig {
    let half = 0.5 * alpha;
    let sinc = if half.abs() < 1e-2 {
        1.0 - half * half / 6.0
    } else {
        libm::sinf(half) / half
    };
    [
        libm::cosf(alpha),
        libm::sinf(alpha),
        libm::cosf(half),
        libm::sinf(half),
        1.0 / sinc,
    ]
}

/// A vote's weight from where the pair falls in its lateral tent and, if it has one, its
/// distance tent (each 1 at the centre, 0 at the edge). Both stand on a pedestal of 1: a pair
/// at a tent's edge still counts, and a wide tent's votes add up to more than a narrow one's:
/// without the pedestal along the distance, random pairs near zero distance could hold the
/// estimate at a stop (`docs/experiments.md`, "The vote").
fn tent_weight(lateral: f32, along: Option<f32>) -> u8 {
    // At most (1 + 8)^2 = 81: fits a byte.
    ((1.0 + VOTE_WEIGHT * lateral) * along.map_or(1.0, |a| 1.0 + VOTE_WEIGHT * a)) as u8
}

/// Sorts ground points by range, nearest first.
pub fn sort_by_ahead(points: &mut [GroundPoint]) {
    crate::sort::sort_by_key(points, |p| p.x_m);
}

/// Keeps the votes of a pair at heading bin `i` for distance `v_m`: one bin when `half_m` is 0,
/// else a tent of half width `half_m` (at least a bin) whose height falls as it widens, so that
/// the pair's votes are a density: a pair that allows a wide span of distances weighs less in
/// each (full height down to a width of `full_height_m`).
pub fn vote_distance<const GRID: usize>(
    votes: &mut BestPerBin<GRID>,
    window: &MotionWindow,
    i: usize,
    v_m: f32,
    half_m: f32,
    lateral: f32,
    full_height_m: f32,
) {
    if half_m <= 0.0 {
        if let Some(j) = window.distance_bin(v_m, GRID) {
            votes.keep(i, j, tent_weight(lateral, None));
        }
        return;
    }
    let half_m = half_m.max(window.distance_step_m(GRID));
    let height = (full_height_m / half_m).min(1.0);
    let (Some(j0), Some(j1)) = (
        window.distance_bin_clamped(v_m - half_m, GRID),
        window.distance_bin_clamped(v_m + half_m, GRID),
    ) else {
        return;
    };
    for j in j0..=j1 {
        let along = 1.0 - (window.distance_at(j as f32, GRID) - v_m).abs() / half_m;
        if along > 0.0 {
            votes.keep(i, j, tent_weight(lateral, Some(along * height)));
        }
    }
}

/// How far a corner's position on the road may be off along its range: a corner's row is
/// uncertain by `corner_sigma_px`, and a row's ground range changes by `(x^2 + h^2) / (f h)`
/// metres a pixel at range `x`.
pub struct Spread {
    /// Metres of range a pixel per square metre of `x^2 + h^2` (0: sharp, no tent).
    per_px: f32,
    height_sq_m2: f32,
    /// The camera's look direction and position on the ground, in the frame the points are
    /// measured in (from the pivot): a point's range is measured along the one from the other
    /// (as [`ValidConfig::window_coords`] does, its sine and cosine taken once here rather than
    /// for every pair).
    cos_yaw: f32,
    sin_yaw: f32,
    camera: GroundPoint,
}

impl Spread {
    /// For points measured from `pivot_m` ahead of the rear axle.
    pub fn new(cfg: &ValidConfig, sharp: bool, pivot_m: f32) -> Self {
        let c = cfg.config();
        let m = &c.mount;
        let sigma = if sharp {
            0.0
        } else {
            c.settings.corner_sigma_px
        };
        Self {
            per_px: sigma / (c.camera.fy_px * m.height_m),
            height_sq_m2: m.height_m * m.height_m,
            cos_yaw: libm::cosf(m.yaw_rad),
            sin_yaw: libm::sinf(m.yaw_rad),
            camera: GroundPoint {
                x_m: m.x_m - pivot_m,
                y_m: m.y_m,
            },
        }
    }

    /// Variance of the range of ground point `p`, square metres (0 when sharp).
    pub fn range_variance(&self, p: GroundPoint) -> f32 {
        if self.per_px == 0.0 {
            return 0.0;
        }
        let ahead =
            self.cos_yaw * (p.x_m - self.camera.x_m) + self.sin_yaw * (p.y_m - self.camera.y_m);
        let sd = (ahead * ahead + self.height_sq_m2) * self.per_px;
        sd * sd
    }

    /// Half width of the distance tent of a pair: a point whose range variance is `var_p` and
    /// observation `c`.
    pub fn half_width_m(&self, var_p: f32, c: GroundPoint) -> f32 {
        if self.per_px == 0.0 {
            return 0.0;
        }
        SPREAD_SIGMAS * libm::sqrtf(var_p + self.range_variance(c))
    }
}

/// Residual across the chord and distance along the arc of track `p` and observation `c` under
/// the heading change of `t`.
pub fn residual(p: GroundPoint, c: GroundPoint, t: &Trig) -> (f32, f32) {
    let [ca, sa, ch, sh, inv_sinc] = *t;
    let wx = p.x_m - (ca * c.x_m - sa * c.y_m);
    let wy = p.y_m - (sa * c.x_m + ca * c.y_m);
    let along = wx * ch + wy * sh;
    let across = -wx * sh + wy * ch;
    (across, along * inv_sinc)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::motion::Motion;
    use crate::vote::VoteGrid;

    /// Ground points spread over the KITTI window, pseudo-random but fixed.
    pub(crate) fn scene(n: usize) -> std::vec::Vec<GroundPoint> {
        let mut next = crate::test_rng::uniform(12345u32);
        (0..n)
            .map(|_| GroundPoint {
                x_m: 7.0 + 6.0 * next(),
                y_m: -2.5 + 5.0 * next(),
            })
            .collect()
    }

    #[test]
    fn sort_by_ahead_orders_nearest_first() {
        let mut points = scene(40);
        let mut expected = points.clone();
        expected.sort_by(|a, b| a.x_m.total_cmp(&b.x_m));
        sort_by_ahead(&mut points);
        assert_eq!(points, expected);
        sort_by_ahead(&mut points[..0]);
    }

    #[test]
    fn a_pair_votes_one_bin_or_a_tent_as_wide_as_its_distance_is_uncertain() {
        let window = MotionWindow::around(Motion::ZERO, 0.01, 0.32);
        // 1 cm bins; a pair at +5.5 cm (bin 37), lying on its lateral tent's centre.
        let weights = |half_m: f32| {
            let mut votes = BestPerBin::<64>::new();
            vote_distance(&mut votes, &window, 3, 0.055, half_m, 1.0, 0.04);
            let mut grid = VoteGrid::<64>::new();
            votes.add_to(&mut grid);
            (0..64)
                .map(|j| grid.get(3, j))
                .collect::<std::vec::Vec<_>>()
        };
        let sharp = weights(0.0);
        assert_eq!(sharp[37], 9);
        assert_eq!(sharp.iter().filter(|&&w| w > 0).count(), 1);
        // As precise as the tolerance: full height, nine bins each side of the centre.
        let near = weights(0.04);
        assert!(near[37] >= 80, "{}", near[37]);
        assert!(near[33] < near[35] && near[35] < near[37] && near[39] < near[37]);
        assert_eq!(near.iter().filter(|&&w| w > 9).count(), 7);
        // Four times as wide: a quarter of the height, spread over four times the bins.
        let far = weights(0.16);
        assert!(far[37] < near[37] / 2 && far[37] > 9, "{}", far[37]);
        assert!(far.iter().filter(|&&w| w > 0).count() > 25);
    }

    #[test]
    fn residual_is_zero_for_the_true_motion() {
        let m = Motion {
            heading_change_rad: 0.02,
            distance_m: 1.1,
        };
        let p = GroundPoint {
            x_m: 9.0,
            y_m: -1.2,
        };
        let c = m.move_point(p);
        let (across, v) = residual(p, c, &trig(m.heading_change_rad));
        assert!(across.abs() < 1e-5, "{across}");
        assert!((v - 1.1).abs() < 1e-5, "{v}");
        // A wrong heading leaves a lateral residual of about the point's range times the error.
        let (off, _) = residual(p, c, &trig(m.heading_change_rad + 0.01));
        assert!(off.abs() > 0.05, "{off}");
    }
}
