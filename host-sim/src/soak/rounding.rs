//! What the core's `f32` pose loses to rounding: the odometer's per-frame motions composed
//! again in `f64` ([`Reference`]), the gap between its pose and theirs, and a worst-case bound
//! on that gap ([`Bound`]).
//!
//! ## The bound
//! Each frame the core does `pose = pose.compose(motion.end_pose())` in `f32` (unit roundoff
//! u = 2^-24), the heading wrapped to [-pi, pi). With N frames, W of them wrapping the heading,
//! D the largest distance of the pose from the origin and d the longest frame's travel:
//!
//! - heading: `h + alpha` rounds once, by at most half an ulp of a number below 4 (2^-23 rad);
//!   a wrap subtracts `2 pi` rounded to `f32` (1.75e-7 rad off) and rounds once more. So
//!   `e_h <= N 2^-23 + W (2^-23 + 1.75e-7)` rad.
//! - position, directly: `x + c px - s py` rounds two sums of size up to D + d and two products
//!   of size d (`u (2 D + 4 d)`), `sinf`/`cosf` of the heading are within an ulp (`3 u d` on
//!   the step), and the step itself (the chord, its `sinc`, `sinf` and `cosf` of half the
//!   turn) within `6 u d`: per coordinate at most `u (2 D + 16 d)` with room to spare, times
//!   sqrt(2) for the vector, per frame.
//! - position, through the heading: a heading error made at frame k turns the rest of the drive
//!   about the pose at k, moving the end by at most that error times `|p_N - p_k| <= 2 D`: in
//!   all at most `2 D e_h`.
//!
//! `e_p <= 2 D e_h + N sqrt(2) u (2 D + 16 d)` metres. Errors of this kind round both ways and
//! mostly cancel, so the real gap is far below the bound; the bound says what no run can exceed.

use crate::path::WorldPose;
use roadvo::{Estimate, Pose2};
use serde::Serialize;
use std::f64::consts::{PI, TAU};

/// `f32`'s unit roundoff, 2^-24.
const UNIT_ROUNDOFF: f64 = 1.0 / 16_777_216.0;
/// Half an ulp of an `f32` between 2 and 4, radians: the rounding of a heading sum.
const HEADING_ROUNDING_RAD: f64 = 1.0 / 8_388_608.0;
/// How far `2 pi` rounded to `f32` is from `2 pi`, radians.
fn two_pi_f32_error_rad() -> f64 {
    (f64::from(std::f32::consts::TAU) - TAU).abs()
}

/// `a` wrapped to [-pi, pi), radians.
pub fn wrap_rad(a: f64) -> f64 {
    a - TAU * ((a + PI) / TAU).floor()
}

/// The gap between two poses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Gap {
    /// Distance between the positions, metres.
    pub position_m: f64,
    /// Heading difference, wrapped, absolute, degrees.
    pub heading_deg: f64,
}

impl Gap {
    /// How far `pose` is from `reference` (whose heading may be unwrapped).
    pub fn between(pose: &Pose2, reference: &WorldPose) -> Self {
        let dx = f64::from(pose.x_m) - reference.x_m;
        let dy = f64::from(pose.y_m) - reference.y_m;
        let dh = wrap_rad(f64::from(pose.heading_rad) - reference.heading_rad);
        Self {
            position_m: dx.hypot(dy),
            heading_deg: dh.abs().to_degrees(),
        }
    }

    /// Each component the larger of the two gaps'.
    fn max(self, other: Gap) -> Gap {
        Gap {
            position_m: self.position_m.max(other.position_m),
            heading_deg: self.heading_deg.max(other.heading_deg),
        }
    }
}

/// The worst-case rounding gap after a run (the module docs derive it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Bound {
    /// Position, metres.
    pub position_m: f64,
    /// Heading, degrees.
    pub heading_deg: f64,
}

/// The odometer's motions composed in `f64`, frame by frame beside its own `f32` pose.
#[derive(Clone, Debug, Default)]
pub struct Reference {
    pose: WorldPose,
    frames: usize,
    wraps: usize,
    last_heading_rad: f32,
    /// Largest distance of either pose from the origin, metres.
    max_radius_m: f64,
    /// Longest frame's travel, metres.
    max_step_m: f64,
    last_gap: Gap,
    max_gap: Gap,
}

impl Reference {
    /// Before the first frame: at the origin.
    pub fn new() -> Self {
        Self::default()
    }

    /// Composes the next frame's motion and measures its pose against the reference.
    pub fn push(&mut self, e: &Estimate) {
        let (turn, distance) = (e.motion.heading_change_rad, e.motion.distance_m);
        self.pose = self.pose.drive(f64::from(turn), f64::from(distance));
        // The core's heading wrapped where it moved by more than half a turn in one frame.
        let moved = f64::from(e.pose.heading_rad) - f64::from(self.last_heading_rad);
        if (moved - f64::from(turn)).abs() > PI {
            self.wraps += 1;
        }
        self.last_heading_rad = e.pose.heading_rad;
        self.frames += 1;
        let radius = f64::from(e.pose.x_m.hypot(e.pose.y_m));
        self.max_radius_m = self
            .max_radius_m
            .max(radius)
            .max(self.pose.x_m.hypot(self.pose.y_m));
        self.max_step_m = self.max_step_m.max(f64::from(distance.abs()));
        self.last_gap = Gap::between(&e.pose, &self.pose);
        self.max_gap = self.max_gap.max(self.last_gap);
    }

    /// The pose the motions compose to in `f64` (heading unwrapped).
    pub fn pose(&self) -> WorldPose {
        self.pose
    }

    /// The gap after the last frame.
    pub fn last_gap(&self) -> Gap {
        self.last_gap
    }

    /// The largest gap of any frame, each component on its own.
    pub fn max_gap(&self) -> Gap {
        self.max_gap
    }

    /// Frames whose heading the core wrapped.
    pub fn wraps(&self) -> usize {
        self.wraps
    }

    /// Largest distance of the pose from the origin over the run, metres.
    pub fn max_radius_m(&self) -> f64 {
        self.max_radius_m
    }

    /// The worst-case gap after the frames pushed so far.
    pub fn bound(&self) -> Bound {
        let n = self.frames as f64;
        let heading_rad = n * HEADING_ROUNDING_RAD
            + self.wraps as f64 * (HEADING_ROUNDING_RAD + two_pi_f32_error_rad());
        let (d_m, step_m) = (self.max_radius_m, self.max_step_m);
        let direct_m = n * std::f64::consts::SQRT_2 * UNIT_ROUNDOFF * (2.0 * d_m + 16.0 * step_m);
        Bound {
            position_m: 2.0 * d_m * heading_rad + direct_m,
            heading_deg: heading_rad.to_degrees(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use roadvo::Motion;

    #[test]
    fn the_core_composes_a_circle_as_f64_does_within_the_bound() {
        // 72 frames of 5 deg and 1 m: a closed 72-gon, ten times round.
        let motion = Motion {
            heading_change_rad: 5f32.to_radians(),
            distance_m: 1.0,
        };
        let (mut pose, mut reference) = (Pose2::IDENTITY, Reference::new());
        for _ in 0..720 {
            pose = pose.advance(motion);
            reference.push(&Estimate {
                motion,
                pose,
                ..Default::default()
            });
        }
        assert_eq!(reference.wraps(), 10);
        let (gap, bound) = (reference.max_gap(), reference.bound());
        assert!(gap.position_m > 0.0, "f32 rounds somewhere");
        assert!(gap.position_m < bound.position_m, "{gap:?} {bound:?}");
        assert!(gap.heading_deg < bound.heading_deg, "{gap:?} {bound:?}");
        // Ten laps of the 72-gon end near where they started (5 deg rounded to f32 is not
        // exactly a 72nd of a turn), the heading unwrapped.
        let end = reference.pose();
        let turn = 720.0 * f64::from(motion.heading_change_rad);
        assert!((end.heading_rad - turn).abs() < 1e-9, "{end:?}");
        assert!(end.x_m.hypot(end.y_m) < 1e-4, "{end:?}");
    }

    #[test]
    fn wrapping_keeps_the_range() {
        assert!((wrap_rad(3.0 * PI) + PI).abs() < 1e-12);
        assert!((wrap_rad(-0.5) + 0.5).abs() < 1e-15);
    }
}
