//! A frame's distance from its two measurements (`road_distance`): the ground vote's, which
//! rests on the body pitch it voted for, and the road's plane's, its homography's travel over
//! the camera's height with its own tilt fitted beside it ([`crate::heading::plane`]). Their
//! errors are nearly apart and neither is the smaller on every road, so each counts alike, as
//! a share of the distance: their geometric mean. A plane fitted to something that is not the
//! road (a car crossing the window, its flank taken for a road tilted by degrees), or a vote thrown
//! by one, leaves the other by far more than the two ever disagree otherwise: past a few
//! spreads of their running disagreement the one nearer the steady speed's distance stands
//! alone. No threshold is set by hand but how many spreads.

use crate::running_mean::RunningMeans;

/// Spreads of the running disagreement past which one of the two distances is taken as
/// thrown: a frame's log ratio is that far out by chance about once in a hundred frames.
const GATE_SPREADS: f32 = 2.5;

/// Least spread of the disagreement, as a log ratio (5 %): under any road's per-frame spread
/// of either measurement, so that the gate stays open to a change.
const MIN_SPREAD: f32 = 0.05;

/// Frames the running disagreement is taken over, at most (3 s at 10 frames/s).
const FRAMES: u16 = 30;

/// How far the road's plane's distance and the ground vote's have disagreed of late: the
/// running mean square of the log of their ratio. All zeros before the first frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoadDistance {
    /// The running mean square of the log ratio (a share, squared), over up to [`FRAMES`].
    var: RunningMeans<1>,
}

impl RoadDistance {
    /// Before the first frame.
    pub const START: Self = Self {
        var: RunningMeans::START,
    };

    /// The frame's distance, metres, from the ground vote's `vote_m` and the road's plane's
    /// `plane_m`: their geometric mean; `vote_m` where `plane_m` is no positive finite
    /// distance (nor their product); where the two are more than [`GATE_SPREADS`] spreads of
    /// the running disagreement apart, one of them is thrown, and the one nearer the
    /// `predicted_m` distance (the steady speed's) stands: the median of the three. A frame
    /// so far apart counts as [`GATE_SPREADS`] spreads out, so that a lasting change of the
    /// spread opens the gate again within frames.
    pub fn blend(&mut self, vote_m: f32, plane_m: f32, predicted_m: f32) -> f32 {
        if !(vote_m > 0.0 && plane_m > 0.0 && (vote_m * plane_m).is_finite()) {
            return vote_m;
        }
        let log_ratio = libm::logf(plane_m / vote_m);
        let [var] = self.var.means();
        let bound = GATE_SPREADS * libm::sqrtf(var).max(MIN_SPREAD);
        let inside = log_ratio.abs() <= bound;
        let r = if inside { log_ratio } else { bound };
        self.var.add([r * r], FRAMES);
        if inside {
            libm::sqrtf(vote_m * plane_m)
        } else {
            predicted_m
                .max(vote_m.min(plane_m))
                .min(vote_m.max(plane_m))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_distances_that_agree_within_their_spread_meet_at_their_geometric_mean() {
        let mut d = RoadDistance::START;
        assert_eq!(d.blend(1.0, 1.1, 1.0), libm::sqrtf(1.1));
        // Standing still, the vote's zero stands; a plane's distance that is no number, or
        // whose product with the vote's is none, leaves the vote's and the spread as they are.
        let before = d;
        for (a, b) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (1.0, f32::NAN),
            (1.0, f32::INFINITY),
            (3e38, 3e38),
        ] {
            assert_eq!(d.blend(a, b, 1.0), a, "{a} {b}");
        }
        assert_eq!(d, before);
    }

    #[test]
    fn a_plane_far_out_of_the_running_disagreement_is_set_aside() {
        // A road where the two disagree by about 10 % a frame either way, then one frame's
        // plane at half the vote's (a crossing car's flank): the vote's stands.
        let mut d = RoadDistance::START;
        for k in 0..40 {
            let plane = if k % 2 == 0 { 1.1 } else { 1.0 / 1.1 };
            assert!((d.blend(1.0, plane, 1.0) - libm::sqrtf(plane)).abs() < 1e-6);
        }
        assert_eq!(d.blend(0.6, 0.3, 0.62), 0.6);
        assert!((d.blend(0.6, 0.66, 0.6) - libm::sqrtf(0.6 * 0.66)).abs() < 1e-6);
        // Or the vote thrown (the car's onset) and the plane near the steady speed: the plane
        // stands; both thrown either way: the steady speed's.
        assert_eq!(d.blend(0.4, 0.6, 0.62), 0.6);
        assert_eq!(d.blend(0.3, 0.9, 0.6), 0.6);
    }

    #[test]
    fn a_lasting_wider_disagreement_opens_the_gate_again() {
        // Planes steadily 10 % off, then steadily 40 % off either way (a rougher road): set
        // aside at first, the spread grows until they count again.
        let mut d = RoadDistance::START;
        for k in 0..40 {
            d.blend(1.0, if k % 2 == 0 { 1.1 } else { 1.0 / 1.1 }, 1.0);
        }
        let counted = (0..40)
            .map(|k| d.blend(1.0, if k % 2 == 0 { 1.4 } else { 1.0 / 1.4 }, 1.0))
            .position(|m| m != 1.0);
        assert!(matches!(counted, Some(k) if k > 0 && k < 20), "{counted:?}");
    }
}
