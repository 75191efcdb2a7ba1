//! Vehicle motion (paper §2.2, Ackermann model): per-frame arcs, planar poses, and lifting a
//! planar pose to a KITTI camera-0 pose.
//!
//! Between two frames the rear-axle centre follows a circular arc: it turns by
//! `heading_change_rad` (alpha) while travelling `distance_m` (v) along the arc, of radius
//! v / alpha. Every formula here is written with `sin(x) / x`, evaluated by its series near zero,
//! so a straight line (alpha = 0) is the arc's continuous limit rather than a special case.

use crate::projection::{GroundPoint, Mount};
use nalgebra::{ArrayStorage, Matrix3, Vector3};

/// `sin(x) / x`, continuous through zero.
fn sinc(x: f32) -> f32 {
    if x.abs() < 1.0e-2 {
        // Truncation error below x^6 / 5040 < 2e-16: far under f32 precision.
        let x2 = x * x;
        1.0 - x2 / 6.0 + x2 * x2 / 120.0
    } else {
        libm::sinf(x) / x
    }
}

/// Wraps an angle to [-pi, pi), radians.
pub fn wrap_angle_rad(a: f32) -> f32 {
    use core::f32::consts::PI;
    let w = a - 2.0 * PI * libm::floorf((a + PI) / (2.0 * PI));
    // Rounding can land exactly on +pi.
    if w >= PI { w - 2.0 * PI } else { w }
}

/// The vehicle's motion between two consecutive frames: an arc of the rear-axle centre.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Motion {
    /// Heading change over the frame, radians, positive to the left (alpha).
    pub heading_change_rad: f32,
    /// Arc length travelled by the rear-axle centre, metres, negative reversing (v).
    pub distance_m: f32,
}

impl Motion {
    /// No motion.
    pub const ZERO: Motion = Motion {
        heading_change_rad: 0.0,
        distance_m: 0.0,
    };

    /// The end pose of the arc, in the vehicle frame at its start.
    pub fn end_pose(&self) -> Pose2 {
        // The chord has length v sinc(alpha/2) and points along alpha/2.
        let half = 0.5 * self.heading_change_rad;
        let chord_m = self.distance_m * sinc(half);
        Pose2 {
            x_m: chord_m * libm::cosf(half),
            y_m: chord_m * libm::sinf(half),
            heading_rad: self.heading_change_rad,
        }
    }

    /// The weighted mean of this motion (weight `self_weight`) and `other` (weight
    /// `other_weight`), component by component; `self` when the weights sum to 0.
    pub fn weighted_mean(self, self_weight: f32, other: Motion, other_weight: f32) -> Motion {
        let total = self_weight + other_weight;
        if total <= 0.0 {
            return self;
        }
        let mean = |a: f32, b: f32| (a * self_weight + b * other_weight) / total;
        Motion {
            heading_change_rad: mean(self.heading_change_rad, other.heading_change_rad),
            distance_m: mean(self.distance_m, other.distance_m),
        }
    }

    /// Where a point fixed on the ground, at `p` in the vehicle frame at the arc's start, lies in
    /// the vehicle frame at its end.
    pub fn move_point(&self, p: GroundPoint) -> GroundPoint {
        self.end_pose().inverse().transform_point(p)
    }
}

/// A planar pose: position and heading of a vehicle frame in a parent frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pose2 {
    /// Position along the parent's x axis, metres.
    pub x_m: f32,
    /// Position along the parent's y axis, metres.
    pub y_m: f32,
    /// Heading, radians counter-clockwise from the parent's x axis, in [-pi, pi).
    pub heading_rad: f32,
}

impl Pose2 {
    /// The parent frame itself.
    pub const IDENTITY: Pose2 = Pose2 {
        x_m: 0.0,
        y_m: 0.0,
        heading_rad: 0.0,
    };

    /// `self` followed by `other` (other expressed in self's frame).
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let p = self.transform_point(GroundPoint {
            x_m: other.x_m,
            y_m: other.y_m,
        });
        Pose2 {
            x_m: p.x_m,
            y_m: p.y_m,
            heading_rad: wrap_angle_rad(self.heading_rad + other.heading_rad),
        }
    }

    /// The pose reached from `self` by driving the arc `motion`.
    pub fn advance(&self, motion: Motion) -> Pose2 {
        self.compose(&motion.end_pose())
    }

    /// The parent frame as seen from this pose.
    pub fn inverse(&self) -> Pose2 {
        let (s, c) = (libm::sinf(self.heading_rad), libm::cosf(self.heading_rad));
        Pose2 {
            x_m: -(c * self.x_m + s * self.y_m),
            y_m: s * self.x_m - c * self.y_m,
            heading_rad: wrap_angle_rad(-self.heading_rad),
        }
    }

    /// A point given in this pose's frame, expressed in the parent frame.
    pub fn transform_point(&self, p: GroundPoint) -> GroundPoint {
        let (s, c) = (libm::sinf(self.heading_rad), libm::cosf(self.heading_rad));
        GroundPoint {
            x_m: self.x_m + c * p.x_m - s * p.y_m,
            y_m: self.y_m + s * p.x_m + c * p.y_m,
        }
    }

    /// The pose of the point `ahead_m` ahead along the heading (itself for 0).
    pub fn moved_ahead(&self, ahead_m: f32) -> Self {
        if ahead_m == 0.0 {
            return *self;
        }
        let p = self.transform_point(GroundPoint {
            x_m: ahead_m,
            y_m: 0.0,
        });
        Self {
            x_m: p.x_m,
            y_m: p.y_m,
            ..*self
        }
    }
}

/// A KITTI pose: the 3x4 matrix `[R | t]` of camera 0 at some frame in the frame of camera 0 at
/// the first frame (camera axes: x right, y down, z forward), row-major.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CameraPose {
    /// The three rows of `[R | t]`; t in metres.
    pub rows: [[f32; 4]; 3],
}

/// Lifts planar vehicle poses to KITTI camera poses through a fixed mount. Built once per mount.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraLift {
    /// Camera-to-vehicle rotation, body level.
    rotation: Matrix3<f32>,
    /// Camera centre in the vehicle frame, metres.
    position: Vector3<f32>,
}

impl CameraLift {
    /// All zeros: the placeholder of an unconfigured odometer.
    pub(crate) const ZERO: Self = Self {
        rotation: Matrix3::from_array_storage(ArrayStorage([[0.0; 3]; 3])),
        position: Vector3::from_array_storage(ArrayStorage([[0.0; 3]; 1])),
    };

    /// The lift for a camera on `mount`.
    pub fn new(mount: &Mount) -> Self {
        Self {
            rotation: mount
                .rotation_vehicle_from_camera(Default::default())
                .cast::<f32>(),
            position: mount.position_vehicle().cast::<f32>(),
        }
    }

    /// The camera pose of a vehicle at `pose` (in the vehicle frame of the first frame), in the
    /// camera frame of the first frame: `M^-1 W M` with M the mount's camera-to-vehicle transform.
    pub fn camera_pose(&self, pose: &Pose2) -> CameraPose {
        let (s, c) = (libm::sinf(pose.heading_rad), libm::cosf(pose.heading_rad));
        let yaw = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let r_t = self.rotation.transpose();
        let rot = r_t * yaw * self.rotation;
        let t = r_t * (yaw * self.position + Vector3::new(pose.x_m, pose.y_m, 0.0) - self.position);
        let row = |i: usize| [rot[(i, 0)], rot[(i, 1)], rot[(i, 2)], t[i]];
        CameraPose {
            rows: [row(0), row(1), row(2)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::PI;
    use proptest::prelude::*;

    fn close(a: Pose2, b: Pose2, tol: f32) -> bool {
        (a.x_m - b.x_m).abs() < tol
            && (a.y_m - b.y_m).abs() < tol
            && wrap_angle_rad(a.heading_rad - b.heading_rad).abs() < tol
    }

    #[test]
    fn weighted_mean_weighs_each_motion_by_its_weight() {
        let motion = |heading_change_rad, distance_m| Motion {
            heading_change_rad,
            distance_m,
        };
        let (vote, prior) = (motion(0.03, 0.6), motion(0.01, 0.9));
        // Three votes to one: three quarters of the way from the prior to the vote.
        let m = vote.weighted_mean(3.0, prior, 1.0);
        assert!((m.heading_change_rad - 0.025).abs() < 1e-7);
        assert!((m.distance_m - 0.675).abs() < 1e-6);
        assert_eq!(vote.weighted_mean(1.0, prior, 0.0), vote);
        assert_eq!(vote.weighted_mean(0.0, prior, 0.0), vote);
    }

    #[test]
    fn quarter_circle_ends_where_geometry_says() {
        // Radius 10 m, 90 deg left: ends at (10, 10), heading pi/2.
        let m = Motion {
            heading_change_rad: PI / 2.0,
            distance_m: 10.0 * PI / 2.0,
        };
        let e = m.end_pose();
        assert!(close(
            e,
            Pose2 {
                x_m: 10.0,
                y_m: 10.0,
                heading_rad: PI / 2.0
            },
            1e-5
        ));
    }

    #[test]
    fn straight_line_is_the_limit() {
        let e = Motion {
            heading_change_rad: 0.0,
            distance_m: 2.5,
        }
        .end_pose();
        assert_eq!(
            e,
            Pose2 {
                x_m: 2.5,
                y_m: 0.0,
                heading_rad: 0.0
            }
        );
    }

    #[test]
    fn moving_a_point_ahead_brings_it_closer() {
        let m = Motion {
            heading_change_rad: 0.0,
            distance_m: 1.0,
        };
        let p = m.move_point(GroundPoint { x_m: 5.0, y_m: 1.0 });
        assert!((p.x_m - 4.0).abs() < 1e-6 && (p.y_m - 1.0).abs() < 1e-6);
    }

    #[test]
    fn wrap_stays_in_range() {
        for a in [-7.0f32, -PI, -1.0, 0.0, 1.0, PI, 4.0, 100.0] {
            let w = wrap_angle_rad(a);
            assert!((-PI..PI).contains(&w), "{a} -> {w}");
            assert!((libm::sinf(w) - libm::sinf(a)).abs() < 1e-4);
        }
    }

    #[test]
    fn level_forward_camera_lifts_vehicle_motion_to_camera_axes() {
        let mount = Mount {
            x_m: 1.2,
            y_m: 0.0,
            height_m: 1.65,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
            roll_rad: 0.0,
        };
        let lift = CameraLift::new(&mount);
        // Driving 10 m straight ahead moves camera 0 along its z axis.
        let p = lift.camera_pose(&Pose2 {
            x_m: 10.0,
            y_m: 0.0,
            heading_rad: 0.0,
        });
        assert!((p.rows[2][3] - 10.0).abs() < 1e-5);
        assert!(p.rows[0][3].abs() < 1e-6 && p.rows[1][3].abs() < 1e-6);
        // Turning left in place (about the rear axle) swings the camera, which sits ahead of the
        // axle, to the left: negative camera x. Its new heading is a turn about camera -y.
        let q = lift.camera_pose(&Pose2 {
            x_m: 0.0,
            y_m: 0.0,
            heading_rad: PI / 2.0,
        });
        assert!((q.rows[0][3] + 1.2).abs() < 1e-5, "{:?}", q);
        assert!((q.rows[2][3] + 1.2).abs() < 1e-5, "{:?}", q);
        assert!((q.rows[0][2] + 1.0).abs() < 1e-6, "{:?}", q);
    }

    proptest! {
        #[test]
        fn arcs_of_one_circle_compose(k in -0.2f32..0.2, v1 in -3.0f32..3.0, v2 in -3.0f32..3.0) {
            // Two arcs on the same circle (curvature k) make one arc of the summed length.
            let a = Motion { heading_change_rad: k * v1, distance_m: v1 };
            let b = Motion { heading_change_rad: k * v2, distance_m: v2 };
            let ab = Motion { heading_change_rad: k * (v1 + v2), distance_m: v1 + v2 };
            let composed = Pose2::IDENTITY.advance(a).advance(b);
            prop_assert!(close(composed, ab.end_pose(), 1e-5), "{:?} vs {:?}", composed, ab.end_pose());
        }

        #[test]
        fn arc_is_continuous_at_zero_heading_change(v in -3.0f32..3.0, a in -1e-3f32..1e-3) {
            let straight = Motion { heading_change_rad: 0.0, distance_m: v }.end_pose();
            let bent = Motion { heading_change_rad: a, distance_m: v }.end_pose();
            // Lateral offset of a gentle arc is v * alpha / 2; nothing else may jump.
            prop_assert!((bent.x_m - straight.x_m).abs() <= 1e-6 * (1.0 + v.abs()));
            prop_assert!((bent.y_m - v * a / 2.0).abs() <= 1e-7);
        }

        #[test]
        fn pose_inverse_undoes_pose(x in -100.0f32..100.0, y in -100.0f32..100.0, h in -3.1f32..3.1) {
            let p = Pose2 { x_m: x, y_m: y, heading_rad: h };
            prop_assert!(close(p.compose(&p.inverse()), Pose2::IDENTITY, 1e-4));
        }

        #[test]
        fn moving_a_pose_ahead_and_back_returns_it(
            x in -100.0f32..100.0, y in -100.0f32..100.0, h in -3.1f32..3.1, d in -2.0f32..2.0,
        ) {
            let p = Pose2 { x_m: x, y_m: y, heading_rad: h };
            let ahead = p.moved_ahead(d);
            prop_assert!((libm::hypotf(ahead.x_m - x, ahead.y_m - y) - d.abs()).abs() < 1e-4);
            prop_assert_eq!(ahead.heading_rad, h);
            prop_assert!(close(ahead.moved_ahead(-d), p, 1e-4));
            prop_assert_eq!(p.moved_ahead(0.0), p);
        }

        #[test]
        fn moved_points_keep_their_distances(
            k in -0.2f32..0.2, v in 0.0f32..3.0,
            x1 in 2.0f32..12.0, y1 in -3.0f32..3.0, x2 in 2.0f32..12.0, y2 in -3.0f32..3.0,
        ) {
            let m = Motion { heading_change_rad: k * v, distance_m: v };
            let (a, b) = (GroundPoint { x_m: x1, y_m: y1 }, GroundPoint { x_m: x2, y_m: y2 });
            let (a2, b2) = (m.move_point(a), m.move_point(b));
            let d = |p: GroundPoint, q: GroundPoint| libm::hypotf(p.x_m - q.x_m, p.y_m - q.y_m);
            prop_assert!((d(a, b) - d(a2, b2)).abs() < 1e-4);
        }
    }
}
