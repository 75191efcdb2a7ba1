//! Matching at the winning attitude and motion (method step 5): each track takes the untaken
//! observation with the smallest residual, if under the tolerance across the chord and within
//! its distance tent along it. The matched pairs also measure the pitch error common to both
//! frames (the slope of their distances against their range), the step across the chord that
//! a mount's yaw error adds to every pair alike, and, with `refine_heading`, the heading that
//! balances their residuals across the chord.

use super::pairs::{HEADING_STEP_RAD, Spread, residual, trig};
use crate::calibration::SidewaysStep;
use crate::config::ValidConfig;
use crate::motion::Motion;
use crate::projection::GroundPoint;
use crate::tracks::{Observation, Observations};

/// What a matching found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Matches {
    /// Tracks matched.
    pub count: usize,
    /// Sums over the pairs of (range, distance): n, x, v, xx, xv.
    regression: [f32; 5],
    /// Sums over the pairs of the residual across the chord `r` and its rate with the heading
    /// `r'`: n, r, r', r r', r'^2.
    across: [f32; 5],
    /// Whether the heading is refined from them (`refine_heading`).
    refine: bool,
}

/// Fewest pairs for a regression over them (the common pitch error, the refined heading).
const MIN_PAIRS: f32 = 8.0;

/// Matches the tracks at `prev` (the previous frame, measured from `pivot_m` ahead of the rear
/// axle) to `obs` under `motion`: `observed[i]` becomes track `i`'s observation, if any, and the
/// observations taken are marked in `obs`. `tolerance_m` across the chord, along it the pair's
/// distance tent or `along_m`, whichever is wider.
pub fn match_tracks<const F: usize>(
    cfg: &ValidConfig,
    prev: &[GroundPoint],
    obs: &mut Observations<F>,
    pivot_m: f32,
    motion: Motion,
    (tolerance_m, along_m): (f32, f32),
    observed: &mut [Option<Observation>],
) -> Matches {
    let t = trig(motion.heading_change_rad);
    let spread = Spread::new(cfg, false, pivot_m);
    obs.untake_all();
    let mut m = Matches {
        refine: cfg.settings().refine_heading,
        ..Matches::default()
    };
    let stepped = trig(motion.heading_change_rad + HEADING_STEP_RAD);
    for (&p, slot) in prev.iter().zip(observed.iter_mut()) {
        *slot = None;
        let var_p = spread.range_variance(p);
        let mut best: Option<(f32, usize, usize)> = None;
        for (side, (side_obs, taken)) in obs.sides.iter().zip(&obs.taken).enumerate() {
            for (k, (c, &taken)) in side_obs.iter().zip(taken).enumerate() {
                if taken {
                    continue;
                }
                let (across, v) = residual(p, c.ground, &t);
                let along = (v - motion.distance_m).abs();
                // As far along as the pair's distance tent reaches, if farther.
                let reach = spread.half_width_m(var_p, c.ground).max(along_m);
                if across.abs() < tolerance_m && along < reach {
                    let cost = across.abs() + along;
                    if best.is_none_or(|b| cost < b.0) {
                        best = Some((cost, side, k));
                    }
                }
            }
        }
        let taken = best.and_then(|(_, side, k)| {
            let taken = obs.taken.get_mut(side)?.get_mut(k)?;
            *taken = true;
            obs.sides.get(side)?.get(k).copied()
        });
        if let Some(o) = taken {
            *slot = Some(o);
            m.count += 1;
            let (r0, v) = residual(p, o.ground, &t);
            let x = 0.5 * (cfg.window_coords(p).0 + cfg.window_coords(o.ground).0);
            let r = &mut m.regression;
            *r = [r[0] + 1.0, r[1] + x, r[2] + v, r[3] + x * x, r[4] + x * v];
            let (r1, _) = residual(p, o.ground, &stepped);
            let rate = (r1 - r0) / HEADING_STEP_RAD;
            let a = &mut m.across;
            *a = [
                a[0] + 1.0,
                a[1] + r0,
                a[2] + rate,
                a[3] + r0 * rate,
                a[4] + rate * rate,
            ];
        }
    }
    m
}

impl Matches {
    /// The common pitch error of both frames the pairs show, radians, positive when the
    /// hypotheses are too far nose down: a common error `e` moves a point at range `x` nearer by
    /// about `(x^2 + h^2) e / h`, so a pair at mean range `x` shows the distance
    /// `v (1 - 2 x e / h)`. `None` with fewer than eight pairs, ranges spread over less than a
    /// metre, or under 0.2 m of travel.
    pub fn common_pitch_error_rad(&self, height_m: f32) -> Option<f32> {
        /// Least spread of the pairs' ranges for a slope, square metres.
        const MIN_RANGE_VARIANCE_M2: f32 = 1.0;
        /// Least travel for a slope, metres.
        const MIN_DISTANCE_M: f32 = 0.2;
        let [n, sx, sv, sxx, sxv] = self.regression;
        if n < MIN_PAIRS {
            return None;
        }
        let var = sxx / n - (sx / n) * (sx / n);
        let v = sv / n;
        if var < MIN_RANGE_VARIANCE_M2 || v.abs() < MIN_DISTANCE_M {
            return None;
        }
        let slope = (sxv / n - (sx / n) * v) / var;
        Some(-slope * height_m / (2.0 * v))
    }

    /// The vehicle's step across the chord common to every pair: the intercept of the least
    /// squares line of their residuals across the chord against the residuals' rate with the
    /// heading (a heading error moves a pair across in proportion to its range, a sideways step
    /// moves all alike). A camera whose mount file's yaw is too far left by `e` sees the
    /// vehicle step left of the chord by about `e` times the distance. `None` with fewer than
    /// eight pairs or where their ranges do not tell the two apart.
    pub fn sideways_step(&self) -> Option<SidewaysStep> {
        let [n, r, rate, r_rate, rate_sq] = self.across;
        let det = n * rate_sq - rate * rate;
        // Under a metre's spread of the pairs' rates (ranges): the two cannot be told apart.
        if n < MIN_PAIRS || det <= n * n {
            return None;
        }
        Some(SidewaysStep {
            sideways_m: (r * rate_sq - rate * r_rate) / det,
            // The intercept's information over the residuals' variance, in pairs.
            pairs: det / rate_sq,
        })
    }

    /// `motion` with its heading refined so that the pairs' residuals across the chord balance:
    /// one Gauss-Newton step of least squares over them, the residual being nearly linear in the
    /// heading. `motion` itself with fewer than eight pairs, or when `refine_heading` is off.
    pub fn refined(&self, motion: Motion) -> Motion {
        let [n, _, _, r_rate, rate_sq] = self.across;
        if !self.refine || n < MIN_PAIRS || rate_sq <= 0.0 {
            return motion;
        }
        Motion {
            heading_change_rad: motion.heading_change_rad - r_rate / rate_sq,
            ..motion
        }
    }
}
