//! Matching at the winning attitude and motion (method step 5): each track takes the untaken
//! observation with the smallest residual, if under the tolerance across the chord and within
//! its distance tent along it. The matched pairs also measure the pitch error common to both
//! frames (the slope of their distances against their range), the step across the chord that
//! a mount's yaw error adds to every pair alike, and, with `refine_heading`, the heading that
//! balances their residuals across the chord.

use super::pairs::{HEADING_STEP_RAD, Spread, residual, trig};
use crate::calibration::{AngleEstimate, SidewaysStep};
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
    /// `r'`: n, r, r', r r', r'^2, r^2.
    across: [f32; 6],
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
            m.add_across(r0, (r1 - r0) / HEADING_STEP_RAD);
        }
    }
    m
}

impl Matches {
    /// Adds a pair's residual across the chord `r` (metres) and its rate with the heading (metres
    /// a radian) to the sums.
    fn add_across(&mut self, r: f32, rate: f32) {
        let a = &mut self.across;
        *a = [
            a[0] + 1.0,
            a[1] + r,
            a[2] + rate,
            a[3] + r * rate,
            a[4] + rate * rate,
            a[5] + r * r,
        ];
    }

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

    /// The least squares line of the pairs' residuals across the chord against the residuals'
    /// rate with the heading (a heading error moves a pair across in proportion to its range, a
    /// step across the chord moves all alike): its intercept (metres) and slope (radians), and
    /// the determinant of its normal equations. `None` with fewer than eight pairs or where
    /// their ranges spread over less than a metre: the two cannot be told apart.
    fn across_line(&self) -> Option<(f32, f32, f32)> {
        let [n, r, rate, r_rate, rate_sq, _] = self.across;
        let det = n * rate_sq - rate * rate;
        if n < MIN_PAIRS || det <= n * n {
            return None;
        }
        Some((
            (r * rate_sq - rate * r_rate) / det,
            (n * r_rate - r * rate) / det,
            det,
        ))
    }

    /// The vehicle's step across the chord common to every pair: the intercept of the least
    /// squares line of their residuals across the chord against their rate with the heading. A
    /// camera whose mount file's yaw is too far left by `e` sees the vehicle step left of the
    /// chord by about `e` times the distance. `None` where the line is.
    pub fn sideways_step(&self) -> Option<SidewaysStep> {
        let (sideways_m, _, det) = self.across_line()?;
        Some(SidewaysStep {
            sideways_m,
            // The intercept's information over the residuals' variance, in pairs.
            pairs: det / self.across[4],
        })
    }

    /// `motion` with its heading refined so that the pairs' residuals across the chord balance:
    /// one Gauss-Newton step of least squares over them, the residual being nearly linear in the
    /// heading. `motion` itself with fewer than eight pairs, or when `refine_heading` is off.
    pub fn refined(&self, motion: Motion) -> Motion {
        let [n, _, _, r_rate, rate_sq, _] = self.across;
        if !self.refine || n < MIN_PAIRS || rate_sq <= 0.0 {
            return motion;
        }
        Motion {
            heading_change_rad: motion.heading_change_rad - r_rate / rate_sq,
            ..motion
        }
    }

    /// The heading change the pairs' residuals across the chord show with the step across it
    /// free (the slope of the line of `sideways_step`, from `motion`'s heading, at which they
    /// were matched), radians, and its standard deviation from the residuals' scatter about the
    /// line. A car leaves the arc's chord by a degree or so (slip, the body's sway), which
    /// a heading fitted through the chord would take as a turn, and a standard deviation from
    /// that fit would not show. `None` where the line is.
    pub fn heading(&self, motion: Motion) -> Option<AngleEstimate> {
        let (intercept, slope, det) = self.across_line()?;
        let [n, r, _, r_rate, _, r_sq] = self.across;
        let scatter = (r_sq - intercept * r - slope * r_rate).max(0.0) / (n - 2.0);
        Some(AngleEstimate {
            rad: motion.heading_change_rad - slope,
            sd_rad: libm::sqrtf(scatter * n / det),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairs at ranges 4 to 19 m whose residuals across the chord show a heading `error_rad`
    /// too far left, a step `step_m` across the chord and a scatter of +-`noise_m`.
    fn matches(error_rad: f32, step_m: f32, noise_m: f32) -> Matches {
        let mut m = Matches::default();
        for k in 0..16 {
            let rate = 4.0 + k as f32;
            let noise = if k % 2 == 0 { noise_m } else { -noise_m };
            m.add_across(step_m + rate * error_rad + noise, rate);
        }
        m
    }

    #[test]
    fn a_step_across_the_chord_does_not_turn_the_ground_s_heading() {
        let at = Motion {
            heading_change_rad: 0.02,
            distance_m: 1.0,
        };
        // A 2 cm step (a degree off the chord over a metre), the heading 1 mrad off.
        let m = matches(0.001, 0.02, 0.0);
        let h = m.heading(at).unwrap();
        assert!((h.rad - 0.019).abs() < 1e-5, "{}", h.rad);
        assert!(h.sd_rad < 1e-5, "{}", h.sd_rad);
        assert!((m.sideways_step().unwrap().sideways_m - 0.02).abs() < 1e-4);
        // Fitted through the chord, the step reads as a turn of 1.5 mrad more.
        let through_chord = Matches { refine: true, ..m }.refined(at).heading_change_rad;
        assert!((through_chord - 0.0175).abs() < 1e-4, "{through_chord}");
    }

    #[test]
    fn the_ground_s_heading_spread_is_the_residuals_over_their_ranges() {
        let at = Motion {
            heading_change_rad: 0.0,
            distance_m: 1.0,
        };
        let h = matches(0.0, 0.0, 0.01).heading(at).unwrap();
        // 16 pairs of +-1 cm about the line, ranges 4..19 m (a spread of 4.6 m): about 0.6 mrad.
        let expected = 0.01 / (16.0f32.sqrt() * 4.61);
        assert!(
            (h.sd_rad / expected - 1.0).abs() < 0.1,
            "{} {expected}",
            h.sd_rad
        );
        assert!(h.rad.abs() < 2.0 * h.sd_rad, "{}", h.rad);
        // Fewer than eight pairs, or all at one range: no heading.
        let mut few = Matches::default();
        for _ in 0..20 {
            few.add_across(0.0, 10.0);
        }
        assert!(few.heading(at).is_none());
        assert!(matches(0.0, 0.0, 0.0).heading(at).is_some());
    }
}
