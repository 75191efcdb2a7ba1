//! The ground-truth path of a synthetic drive: segments of constant or linearly changing curvature
//! (straights, arcs, clothoids) integrated into a dense list of poses, and a speed profile that
//! turns it into a pose per frame.

use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

/// One piece of the path. Curvature is continuous where a clothoid joins; a straight or an arc
/// sets its own curvature.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Segment {
    /// A straight, `length_m` long.
    Straight {
        /// Length, metres.
        length_m: f64,
    },
    /// A circular arc of `radius_m` turning by `angle_deg` (positive left).
    Arc {
        /// Radius, metres.
        radius_m: f64,
        /// Heading change, degrees, positive to the left.
        angle_deg: f64,
    },
    /// A clothoid: curvature changes linearly from where the previous segment ended to
    /// `end_curvature_per_m` over `length_m`.
    Clothoid {
        /// Length, metres.
        length_m: f64,
        /// Curvature at the end, 1/m, positive turning left.
        end_curvature_per_m: f64,
    },
}

/// Spacing of the integrated path, metres.
const STEP_M: f64 = 0.01;

/// A planar pose in the world frame: the vehicle frame of the path's start.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorldPose {
    /// Metres.
    pub x_m: f64,
    /// Metres.
    pub y_m: f64,
    /// Radians, counter-clockwise from x.
    pub heading_rad: f64,
}

impl WorldPose {
    /// Drives an arc of curvature `k` for `ds` metres from this pose.
    pub fn advance(&self, k: f64, ds: f64) -> WorldPose {
        self.drive(k * ds, ds)
    }

    /// Drives an arc that turns by `turn_rad` (positive left) over `distance_m` metres from this
    /// pose: the core's per-frame [`roadvo::Motion`] in `f64`. The heading is not wrapped.
    pub fn drive(&self, turn_rad: f64, distance_m: f64) -> WorldPose {
        let half = 0.5 * turn_rad;
        // Chord length ds * sin(a/2) / (a/2), continuous at a = 0.
        let sinc = if half.abs() < 1e-6 {
            1.0 - half * half / 6.0
        } else {
            half.sin() / half
        };
        let chord = distance_m * sinc;
        let dir = self.heading_rad + half;
        WorldPose {
            x_m: self.x_m + chord * dir.cos(),
            y_m: self.y_m + chord * dir.sin(),
            heading_rad: self.heading_rad + turn_rad,
        }
    }

    /// Maps a point given in this pose's frame into the world.
    pub fn to_world(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.heading_rad.sin_cos();
        (self.x_m + c * x - s * y, self.y_m + s * x + c * y)
    }

    /// This pose seen from `origin`'s frame.
    pub fn relative_to(&self, origin: &WorldPose) -> WorldPose {
        let (s, c) = origin.heading_rad.sin_cos();
        let (dx, dy) = (self.x_m - origin.x_m, self.y_m - origin.y_m);
        WorldPose {
            x_m: c * dx + s * dy,
            y_m: -s * dx + c * dy,
            heading_rad: self.heading_rad - origin.heading_rad,
        }
    }
}

/// The integrated path: a pose and curvature every centimetre.
#[derive(Clone, Debug)]
pub struct Path {
    poses: Vec<WorldPose>,
    /// Curvature of the step that starts at each pose, 1/m.
    curvature: Vec<f64>,
}

impl Path {
    /// Integrates `segments` from the origin, heading along x.
    pub fn new(segments: &[Segment]) -> Result<Self> {
        let mut poses = vec![WorldPose::default()];
        let mut curvature = Vec::new();
        let mut k_end = 0.0;
        for (i, seg) in segments.iter().enumerate() {
            let (length, k0, k1) = match *seg {
                Segment::Straight { length_m } => (length_m, 0.0, 0.0),
                Segment::Arc {
                    radius_m,
                    angle_deg,
                } => {
                    if radius_m.is_nan() || radius_m <= 0.0 {
                        bail!("segment {}: arc radius_m must be positive", i + 1);
                    }
                    let k = angle_deg.signum() / radius_m;
                    (radius_m * angle_deg.to_radians().abs(), k, k)
                }
                Segment::Clothoid {
                    length_m,
                    end_curvature_per_m,
                } => (length_m, k_end, end_curvature_per_m),
            };
            if !(length.is_finite() && length > 0.0 && k0.is_finite() && k1.is_finite()) {
                bail!(
                    "segment {}: length and curvature must be finite, length positive",
                    i + 1
                );
            }
            let n = (length / STEP_M).round().max(1.0) as usize;
            let ds = length / n as f64;
            for j in 0..n {
                // Curvature at the step's middle: exact for arcs, second order for clothoids.
                let k = k0 + (k1 - k0) * (j as f64 + 0.5) / n as f64;
                let last = *poses.last().expect("starts with the origin");
                poses.push(last.advance(k, ds));
                curvature.push(k);
            }
            k_end = k1;
        }
        if curvature.is_empty() {
            bail!("the path has no segments");
        }
        curvature.push(k_end);
        Ok(Self { poses, curvature })
    }

    /// Path length, metres.
    pub fn length_m(&self) -> f64 {
        (self.poses.len() - 1) as f64 * STEP_M
    }

    /// The pose at arc length `s_m` (clamped to the path).
    pub fn pose_at(&self, s_m: f64) -> WorldPose {
        let s = s_m.clamp(0.0, self.length_m());
        let i = ((s / STEP_M) as usize).min(self.poses.len() - 1);
        self.poses[i].advance(self.curvature[i], s - i as f64 * STEP_M)
    }
}

/// A speed profile: speed as a piecewise-linear function of distance along the path.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedKnot {
    /// Distance along the path, metres.
    pub at_m: f64,
    /// Speed there, m/s.
    pub speed_m_s: f64,
}

/// Speed at distance `s` along the path, m/s (knots at increasing distances: a binary search).
pub fn speed_at(knots: &[SpeedKnot], s: f64) -> f64 {
    match knots.partition_point(|k| k.at_m <= s) {
        i if i == knots.len() => knots.last().map_or(0.0, |k| k.speed_m_s),
        0 => knots[0].speed_m_s,
        i => {
            let (a, b) = (&knots[i - 1], &knots[i]);
            a.speed_m_s + (b.speed_m_s - a.speed_m_s) * (s - a.at_m) / (b.at_m - a.at_m)
        }
    }
}

/// Checks a speed profile: at least one knot, increasing distances, speeds finite and >= 0.
pub fn check_speed_profile(knots: &[SpeedKnot]) -> Result<()> {
    if knots.is_empty() {
        bail!("the speed profile needs at least one [[speed]] entry");
    }
    for (i, k) in knots.iter().enumerate() {
        if !(k.speed_m_s.is_finite() && k.speed_m_s >= 0.0 && k.at_m.is_finite()) {
            bail!(
                "[[speed]] entry {}: numbers must be finite, speed >= 0",
                i + 1
            );
        }
        if i > 0 && k.at_m <= knots[i - 1].at_m {
            bail!("[[speed]] entry {}: at_m must increase", i + 1);
        }
    }
    Ok(())
}

/// Integrates ds/dt = v(s) forward in time with fourth-order Runge-Kutta in 1 ms steps.
pub struct DistanceClock<'a> {
    knots: &'a [SpeedKnot],
    t_s: f64,
    s_m: f64,
}

impl<'a> DistanceClock<'a> {
    /// At the start of the path at time zero.
    pub fn new(knots: &'a [SpeedKnot]) -> Self {
        Self {
            knots,
            t_s: 0.0,
            s_m: 0.0,
        }
    }

    /// Distance along the path at time `t_s`, metres; times must not go backwards.
    pub fn advance_to(&mut self, t_s: f64) -> f64 {
        const DT: f64 = 1e-3;
        let v = |s| speed_at(self.knots, s);
        while self.t_s < t_s {
            let h = DT.min(t_s - self.t_s);
            let s = self.s_m;
            let k1 = v(s);
            let k2 = v(s + 0.5 * h * k1);
            let k3 = v(s + 0.5 * h * k2);
            let k4 = v(s + h * k3);
            self.s_m += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0;
            self.t_s += h;
        }
        self.s_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn half_circle_ends_opposite() {
        let p = Path::new(&[Segment::Arc {
            radius_m: 10.0,
            angle_deg: 180.0,
        }])
        .unwrap();
        let end = p.pose_at(p.length_m());
        assert!((end.x_m).abs() < 1e-6 && (end.y_m - 20.0).abs() < 1e-6);
        assert!((end.heading_rad - PI).abs() < 1e-9);
    }

    #[test]
    fn clothoid_pair_turns_by_its_curvature_area() {
        // 0 -> k over 15 m then k -> 0 over 15 m: heading change k * 15.
        let k = PI / 15.0;
        let p = Path::new(&[
            Segment::Clothoid {
                length_m: 15.0,
                end_curvature_per_m: k,
            },
            Segment::Clothoid {
                length_m: 15.0,
                end_curvature_per_m: 0.0,
            },
        ])
        .unwrap();
        let end = p.pose_at(30.0);
        assert!((end.heading_rad - PI).abs() < 1e-6, "{end:?}");
    }

    #[test]
    fn constant_speed_gives_linear_distance() {
        let knots = [SpeedKnot {
            at_m: 0.0,
            speed_m_s: 2.5,
        }];
        let mut clock = DistanceClock::new(&knots);
        let d: Vec<f64> = [0.0, 0.1, 1.0].map(|t| clock.advance_to(t)).to_vec();
        assert!((d[1] - 0.25).abs() < 1e-9 && (d[2] - 2.5).abs() < 1e-9);
    }

    #[test]
    fn bad_segments_are_named() {
        let e = Path::new(&[
            Segment::Straight { length_m: 1.0 },
            Segment::Straight { length_m: -1.0 },
        ])
        .unwrap_err();
        assert!(e.to_string().starts_with("segment 2:"), "{e}");
    }
}
