//! A fixed-lag smoother of the heading: each frame's heading change is refitted with the `lag`
//! frames on either side of it, so that the trajectory comes out `lag` frames late.
//!
//! A frame's heading error grows fast as its vote's support falls, so each frame's turn rate is
//! refitted by weighted least squares to a straight line in time through its neighbours, each
//! weighing its matched tracks to the fourth power (about the inverse of its variance; fallback
//! and start-up frames weigh nothing): a weak frame between strong ones takes their line, a strong
//! one keeps its own, and a bend's entry or exit, linear in time, passes through unchanged. The
//! distance is left alone: its errors last longer than any short window. The figures behind it:
//! `docs/method.md`, "The heading smoother".
//!
//! The smoothed trajectory is integrated from the smoothed steps: a step keeps its length and its
//! chord turns by half the change of its heading change, as an arc's does. The odometer's own
//! estimate is unaffected. Storage is caller-sized: `Smoother<N>` holds `N` frames, enough for a
//! lag of `(N - 1) / 2`.

use crate::motion::{Motion, Pose2};
use crate::odometer::Estimate;
use crate::projection::GroundPoint;
use crate::time::{Duration, Instant};
use heapless::Deque;

/// Why a smoother cannot be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmootherError {
    /// `2 lag + 1` frames do not fit the smoother's capacity.
    LagTooLong {
        /// The lag asked for, frames.
        lag_frames: u8,
        /// The longest lag the capacity holds, frames.
        max_frames: u8,
    },
}

impl core::fmt::Display for SmootherError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::LagTooLong {
                lag_frames,
                max_frames,
            } => write!(
                f,
                "a smoothing lag of {lag_frames} frames is longer than the capacity's \
                 {max_frames}"
            ),
        }
    }
}

/// One frame in the smoother.
#[derive(Clone, Copy, Debug)]
struct Held {
    estimate: Estimate,
    /// The rear axle's step from the previous frame, in the previous frame's vehicle frame.
    step: Pose2,
    /// Its timestamp.
    timestamp: Instant,
    /// Time since the previous frame, seconds (0 for a drive's first frame).
    dt_s: f32,
    /// Weight of its turn rate in the fit.
    weight: f32,
    /// Which drive it belongs to (a start-up frame begins another).
    drive: u32,
}

/// A fixed-lag smoother of the heading for up to `(N - 1) / 2` frames of lag (see the module
/// docs). Feed it every estimate with [`push`](Self::push), in order; it hands each back,
/// smoothed, `lag` frames later, and [`flush`](Self::flush) hands back the rest at the end.
#[derive(Clone, Debug)]
pub struct Smoother<const N: usize = 5> {
    lag: usize,
    /// Up to `lag` frames already handed back (the next one's past), then those not yet.
    held: Deque<Held, N>,
    /// How many of `held` have been handed back.
    done: usize,
    /// The last frame pushed: its raw pose and timestamp, and its drive.
    last: Option<(Pose2, Instant, u32)>,
    /// The smoothed pose of the last frame handed back.
    pose: Pose2,
}

impl<const N: usize> Smoother<N> {
    /// A smoother that hands each frame back `lag_frames` frames later (0: unchanged, at once).
    pub fn new(lag_frames: u8) -> Result<Self, SmootherError> {
        let max = N.saturating_sub(1) / 2;
        if usize::from(lag_frames) > max {
            return Err(SmootherError::LagTooLong {
                lag_frames,
                max_frames: u8::try_from(max).unwrap_or(u8::MAX),
            });
        }
        Ok(Self {
            lag: usize::from(lag_frames),
            held: Deque::new(),
            done: 0,
            last: None,
            pose: Pose2::IDENTITY,
        })
    }

    /// The lag, frames.
    pub fn lag_frames(&self) -> u8 {
        u8::try_from(self.lag).unwrap_or(u8::MAX)
    }

    /// Takes the estimate of the frame at `timestamp` (as given to the odometer); returns the
    /// frame `lag` frames back, smoothed, once there is one. A start-up estimate (the odometer
    /// was reset) begins a new drive, which no fit reaches across.
    pub fn push(&mut self, estimate: Estimate, timestamp: Instant) -> Option<Estimate> {
        if self.lag == 0 {
            return Some(estimate);
        }
        let startup = estimate.quality.startup;
        let (step, dt, drive) = match self.last {
            Some((pose, last, drive)) if !startup => (
                pose.inverse().compose(&estimate.pose),
                timestamp.since(last).unwrap_or(Duration::ZERO),
                drive,
            ),
            Some((_, _, drive)) => (estimate.pose, Duration::ZERO, drive.wrapping_add(1)),
            None => (estimate.pose, Duration::ZERO, 0),
        };
        self.last = Some((estimate.pose, timestamp, drive));
        let q = &estimate.quality;
        let weight = if q.fallback || q.startup || dt == Duration::ZERO {
            0.0
        } else {
            let m = f32::from(q.tracks_matched);
            m * m * m * m
        };
        let held = Held {
            estimate,
            step,
            timestamp,
            dt_s: dt.secs_f32(),
            weight,
            drive,
        };
        // Cannot fail: at most `2 lag + 1 <= N` are held after a frame is handed back.
        let _ = self.held.push_back(held);
        if self.held.len() - self.done > self.lag {
            self.hand_back()
        } else {
            None
        }
    }

    /// The next frame not yet handed back, smoothed with the frames after it that there are;
    /// None when every frame pushed has been handed back. Call it until None at a drive's end.
    pub fn flush(&mut self) -> Option<Estimate> {
        (self.held.len() > self.done)
            .then(|| self.hand_back())
            .flatten()
    }

    /// Hands back the first frame not yet handed back, and forgets what no fit needs any more.
    fn hand_back(&mut self) -> Option<Estimate> {
        let i = self.done;
        let at = *self.held.iter().nth(i)?;
        let heading_change_rad = self.fitted_heading_change(i, &at);
        let step = turned(at.step, heading_change_rad);
        self.pose = if at.dt_s == 0.0 {
            at.estimate.pose
        } else {
            self.pose.compose(&step)
        };
        self.done += 1;
        if self.done > self.lag {
            self.held.pop_front();
            self.done -= 1;
        }
        Some(Estimate {
            motion: Motion {
                heading_change_rad,
                ..at.estimate.motion
            },
            pose: self.pose,
            quality: at.estimate.quality,
        })
    }

    /// Frame `i`'s heading change from the weighted straight line through the turn rates of
    /// its drive's frames within `lag` of it; its own where no line can be fitted.
    fn fitted_heading_change(&self, i: usize, at: &Held) -> f32 {
        let own = at.step.heading_rad;
        if at.dt_s <= 0.0 {
            return own;
        }
        // Weighted sums of 1, x, x^2, y, x y over the window (x: seconds from frame i, y: rad/s).
        let mut s = [0.0f32; 5];
        let window = self
            .held
            .iter()
            .skip(i.saturating_sub(self.lag))
            .take(2 * self.lag + 1);
        for h in window.filter(|h| h.drive == at.drive && h.dt_s > 0.0 && h.weight > 0.0) {
            let apart_s = h.timestamp.abs_diff(at.timestamp).secs_f32();
            let x = if h.timestamp < at.timestamp {
                -apart_s
            } else {
                apart_s
            };
            let (y, w) = (h.step.heading_rad / h.dt_s, h.weight);
            s = [
                s[0] + w,
                s[1] + w * x,
                s[2] + w * x * x,
                s[3] + w * y,
                s[4] + w * x * y,
            ];
        }
        let [sw, sx, sxx, sy, sxy] = s;
        let det = sw * sxx - sx * sx;
        let rate = if sw <= 0.0 {
            return own;
        } else if det > 1e-6 * sw * sxx {
            (sy * sxx - sxy * sx) / det
        } else {
            // One time in the window (a lone frame): the mean.
            sy / sw
        };
        rate * at.dt_s
    }
}

/// `step` with its heading change set to `heading_change_rad` and its chord turned by half the
/// difference, as an arc's chord turns with its heading change.
fn turned(step: Pose2, heading_change_rad: f32) -> Pose2 {
    let half = 0.5 * (heading_change_rad - step.heading_rad);
    let chord = Pose2 {
        heading_rad: half,
        ..Pose2::IDENTITY
    }
    .transform_point(GroundPoint {
        x_m: step.x_m,
        y_m: step.y_m,
    });
    Pose2 {
        x_m: chord.x_m,
        y_m: chord.y_m,
        heading_rad: heading_change_rad,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::odometer::Quality;
    use proptest::prelude::*;
    use std::vec::Vec;

    const DT_US: u64 = 100_000;

    /// A drive of arcs `motions` (heading change, distance, tracks matched), estimated exactly:
    /// each frame's estimate with its timestamp.
    fn drive(motions: &[(f32, f32, u16)]) -> Vec<(Estimate, u64)> {
        let mut pose = Pose2::IDENTITY;
        let mut out = std::vec![(
            Estimate {
                quality: Quality {
                    startup: true,
                    ..Quality::default()
                },
                ..Estimate::default()
            },
            0,
        )];
        for (k, &(h, d, m)) in motions.iter().enumerate() {
            let motion = Motion {
                heading_change_rad: h,
                distance_m: d,
            };
            pose = pose.advance(motion);
            let quality = Quality {
                tracks_matched: m,
                ..Quality::default()
            };
            out.push((
                Estimate {
                    motion,
                    pose,
                    quality,
                },
                (k as u64 + 1) * DT_US,
            ));
        }
        out
    }

    /// Every estimate of `frames` through a smoother of `lag`, flushed at the end.
    fn smoothed(frames: &[(Estimate, u64)], lag: u8) -> Vec<Estimate> {
        let mut s: Smoother<7> = Smoother::new(lag).unwrap();
        let mut out: Vec<Estimate> = frames
            .iter()
            .filter_map(|&(e, t)| s.push(e, Instant::from_micros(t)))
            .collect();
        assert_eq!(out.len(), frames.len().saturating_sub(usize::from(lag)));
        out.extend(core::iter::from_fn(|| s.flush()));
        out
    }

    #[test]
    fn a_two_frame_lag_costs_under_six_hundred_bytes() {
        let size = size_of::<Smoother<5>>();
        std::println!("size_of::<Smoother<5>>() = {size} bytes");
        // 5 estimates of 104 bytes (the quality holds the whole image's support too) and the
        // bookkeeping.
        assert!(size <= 600, "{size} bytes");
    }

    #[test]
    fn no_lag_hands_every_estimate_back_unchanged_at_once() {
        let frames = drive(&[(0.01, 1.0, 30), (-0.03, 0.8, 5), (0.02, 1.2, 0)]);
        let mut s: Smoother<1> = Smoother::new(0).unwrap();
        for &(e, t) in &frames {
            assert_eq!(s.push(e, Instant::from_micros(t)), Some(e));
        }
        assert_eq!(s.flush(), None);
    }

    #[test]
    fn a_lag_longer_than_the_capacity_is_refused() {
        assert_eq!(
            Smoother::<4>::new(2).unwrap_err(),
            SmootherError::LagTooLong {
                lag_frames: 2,
                max_frames: 1
            }
        );
        assert!(Smoother::<5>::new(2).is_ok());
    }

    #[test]
    fn a_bend_whose_rate_changes_linearly_passes_unchanged() {
        // Entering a bend: the turn rate grows by the same step each frame; uneven support.
        let motions: Vec<_> = (0..12)
            .map(|k| (0.002 * k as f32, 1.0, [12, 40, 25, 33][k % 4]))
            .collect();
        let frames = drive(&motions);
        let out = smoothed(&frames, 2);
        for (o, (e, _)) in out.iter().zip(&frames) {
            assert!((o.motion.heading_change_rad - e.motion.heading_change_rad).abs() < 1e-6);
            assert!((o.pose.x_m - e.pose.x_m).abs() < 1e-4, "{o:?} {e:?}");
            assert!((o.pose.y_m - e.pose.y_m).abs() < 1e-4);
            assert!((o.pose.heading_rad - e.pose.heading_rad).abs() < 1e-5);
            assert_eq!(o.quality, e.quality);
            assert_eq!(o.motion.distance_m, e.motion.distance_m);
        }
    }

    #[test]
    fn a_weak_frame_between_strong_ones_takes_their_line() {
        let mut motions = std::vec![(0.01, 1.0, 40); 9];
        motions[4] = (0.02, 1.0, 10); // poorly supported, off by 0.01 rad
        let frames = drive(&motions);
        let out = smoothed(&frames, 2);
        let weak = out[5].motion.heading_change_rad;
        assert!((weak - 0.01).abs() < 2e-5, "{weak}");
        // The smoothed pose integrates the smoothed steps, each as long as its estimate's.
        let sum: f32 = out.iter().map(|e| e.motion.heading_change_rad).sum();
        assert!((out[9].pose.heading_rad - sum).abs() < 1e-5);
        let length = |a: &Pose2, b: &Pose2| {
            let step = a.inverse().compose(b);
            libm::hypotf(step.x_m, step.y_m)
        };
        let (raw, smooth) = (
            length(&frames[4].0.pose, &frames[5].0.pose),
            length(&out[4].pose, &out[5].pose),
        );
        assert!((raw - smooth).abs() < 1e-5, "{raw} {smooth}");
    }

    #[test]
    fn a_strong_frame_between_weak_ones_keeps_its_own() {
        let mut motions = std::vec![(0.01, 1.0, 10); 9];
        motions[4] = (0.012, 1.0, 40);
        let out = smoothed(&drive(&motions), 2);
        let strong = out[5].motion.heading_change_rad;
        assert!((strong - 0.012).abs() < 5e-5, "{strong}");
    }

    #[test]
    fn no_fit_reaches_across_a_restart() {
        let mut frames = drive(&[(0.01, 1.0, 40); 4]);
        // The odometer was reset: a start-up frame at the origin, then a drive turning the
        // other way, poorly supported.
        let again = drive(&[(-0.02, 1.0, 10); 4]);
        frames.extend(again.iter().map(|&(e, t)| (e, t + 10 * DT_US)));
        let out = smoothed(&frames, 2);
        assert_eq!(out.len(), frames.len());
        assert_eq!(out[5].pose, Pose2::IDENTITY);
        for o in &out[6..] {
            assert!((o.motion.heading_change_rad + 0.02).abs() < 1e-6);
        }
        for o in &out[1..5] {
            assert!((o.motion.heading_change_rad - 0.01).abs() < 1e-6);
        }
    }

    proptest! {
        #[test]
        fn any_estimates_come_back_each_once_in_order(
            frames in proptest::collection::vec(
                (
                    any::<f32>(),
                    any::<f32>(),
                    any::<u16>(),
                    any::<bool>(),
                    any::<bool>(),
                    0u64..1_000_000,
                ),
                0..40,
            ),
            lag in 0u8..4,
        ) {
            let mut t = 0u64;
            let frames: Vec<(Estimate, u64)> = frames
                .iter()
                .enumerate()
                .map(|(k, &(h, d, m, startup, fallback, dt))| {
                    t = t.saturating_add(dt);
                    let quality = Quality {
                        tracks_matched: m,
                        startup,
                        fallback,
                        features_detected: k as u16,
                        ..Quality::default()
                    };
                    let motion = Motion { heading_change_rad: h, distance_m: d };
                    (Estimate { motion, pose: Pose2::IDENTITY.advance(motion), quality }, t)
                })
                .collect();
            let out = smoothed(&frames, lag);
            let order: Vec<u16> = out.iter().map(|e| e.quality.features_detected).collect();
            let sent: Vec<u16> = frames.iter().map(|(e, _)| e.quality.features_detected).collect();
            prop_assert_eq!(order, sent);
        }
    }
}
