//! The body's attitude hypotheses: pitches and rolls spread evenly about level, their
//! homographies and roll maps (built once per configuration), and the corrections that move the
//! estimate between frames (the absolute pitch measurement, the settling back to level).

use crate::config::hypothesis_rad;
use crate::config::{MAX_PITCH_HYPOTHESES, MAX_ROLL_HYPOTHESES, Settings, ValidConfig};
use crate::projection::{Attitude, GroundPoint, Homography, Pixel, RollMap};

/// A body attitude hypothesis: indices into the pitch and roll hypotheses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AttitudeIndex {
    /// Index into the pitch hypotheses.
    pub pitch: usize,
    /// Index into the roll hypotheses.
    pub roll: usize,
}

impl AttitudeIndex {
    /// The level body: the middle hypotheses.
    pub fn level(s: &Settings) -> Self {
        Self {
            pitch: usize::from(s.pitch_steps / 2),
            roll: usize::from(s.roll_steps / 2),
        }
    }

    /// The attitude it stands for, radians.
    pub fn attitude(&self, s: &Settings) -> Attitude {
        Attitude {
            pitch_rad: hypothesis_rad(s.pitch_range_rad, s.pitch_steps, self.pitch),
            roll_rad: hypothesis_rad(s.roll_range_rad, s.roll_steps, self.roll),
        }
    }
}

/// The hypotheses' homographies and roll maps, in order of angle.
#[derive(Clone, Debug)]
pub struct Fans {
    pitch: [Homography; MAX_PITCH_HYPOTHESES],
    roll: [RollMap; MAX_ROLL_HYPOTHESES],
    pitches: usize,
    rolls: usize,
}

/// A homography and a roll map: how the corners of one frame are seen.
pub type Seen<'a> = (&'a Homography, &'a RollMap);

impl Fans {
    /// None: the placeholder of an unconfigured odometer.
    pub const ZERO: Self = Self {
        pitch: [Homography::ZERO; MAX_PITCH_HYPOTHESES],
        roll: [RollMap::ZERO; MAX_ROLL_HYPOTHESES],
        pitches: 0,
        rolls: 0,
    };

    /// Builds the hypotheses of `cfg` in place (validation checked that each exists).
    pub fn build(&mut self, cfg: &ValidConfig) {
        let (c, s) = (cfg.config(), cfg.settings());
        let (k, m) = (&c.camera, &c.mount);
        self.pitches = usize::from(s.pitch_steps).min(MAX_PITCH_HYPOTHESES);
        self.rolls = usize::from(s.roll_steps).min(MAX_ROLL_HYPOTHESES);
        for (i, h) in self.pitch.iter_mut().enumerate().take(self.pitches) {
            let attitude = Attitude {
                pitch_rad: hypothesis_rad(s.pitch_range_rad, s.pitch_steps, i),
                roll_rad: 0.0,
            };
            *h = Homography::new(k, m, attitude).unwrap_or(cfg.projection().nominal);
        }
        for (i, map) in self.roll.iter_mut().enumerate().take(self.rolls) {
            let roll_rad = hypothesis_rad(s.roll_range_rad, s.roll_steps, i);
            *map = RollMap::new(k, m, roll_rad).unwrap_or(RollMap::IDENTITY);
        }
    }

    /// The pitch hypotheses' homographies.
    pub fn pitch(&self) -> &[Homography] {
        &self.pitch[..self.pitches.min(MAX_PITCH_HYPOTHESES)]
    }

    /// The roll hypotheses' maps.
    pub fn roll(&self) -> &[RollMap] {
        &self.roll[..self.rolls.min(MAX_ROLL_HYPOTHESES)]
    }

    /// How a frame is seen at attitude `at`; `None` for an index past the hypotheses.
    pub fn seen(&self, at: AttitudeIndex) -> Option<Seen<'_>> {
        Some((self.pitch().get(at.pitch)?, self.roll().get(at.roll)?))
    }
}

/// The ground point of a pixel seen at attitude `at`: through the roll's map, then the pitch's
/// homography. `None` at or above the horizon.
pub fn backproject(at: Seen, px: Pixel) -> Option<GroundPoint> {
    let (h, roll) = at;
    roll.apply(px).and_then(|level| h.backproject(level))
}

/// Corrections of the attitude estimate waiting to be applied, in hypothesis steps: whole steps
/// move both frames' hypotheses (see [`shift`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AttitudeDrift {
    /// Pitch steps.
    pub pitch_steps: f32,
    /// Roll steps.
    pub roll_steps: f32,
}

impl AttitudeDrift {
    /// Nothing waiting.
    pub const ZERO: Self = Self {
        pitch_steps: 0.0,
        roll_steps: 0.0,
    };

    /// Takes `interval_s / settle_s` of the estimate's offset `at` from `level` off each
    /// correction (pitch with `pitch_settle_s`, roll with `roll_settle_s`; 0: never): offsets
    /// that outlast the suspension's swing are the estimate's drift.
    pub fn settle(
        &mut self,
        at: AttitudeIndex,
        level: AttitudeIndex,
        interval_s: f32,
        s: &Settings,
    ) {
        let off = |at: usize, level: usize| at as f32 - level as f32;
        let share = |settle_s: f32| (interval_s / settle_s).min(1.0);
        if s.pitch_settle_s > 0.0 {
            self.pitch_steps -= share(s.pitch_settle_s) * off(at.pitch, level.pitch);
        }
        if s.roll_settle_s > 0.0 {
            self.roll_steps -= share(s.roll_settle_s) * off(at.roll, level.roll);
        }
    }

    /// Feeds the absolute pitch measurement: `error_rad` too far nose down (a higher index
    /// fixes it), `absolute_gain` of it.
    pub fn measure_pitch(&mut self, error_rad: f32, s: &Settings) {
        let steps = s.pitch_steps.saturating_sub(1).max(1);
        let step_rad = 2.0 * s.pitch_range_rad / f32::from(steps);
        if step_rad > 0.0 {
            self.pitch_steps += s.absolute_gain * error_rad / step_rad;
        }
    }
}

/// Hypotheses within `reach` of `previous` among `len`.
pub fn near(previous: usize, reach: u8, len: usize) -> core::ops::Range<usize> {
    let reach = usize::from(reach);
    previous.saturating_sub(reach)..(previous + reach + 1).min(len)
}

/// Applies the whole steps of `integrator` to both frames' hypotheses `previous` and `cur` (of
/// `len`), as far as the range allows; what the range cuts off is dropped, so the integrator
/// cannot wind up. Returns the moved pair.
pub fn shift(integrator: &mut f32, previous: usize, cur: usize, len: usize) -> (usize, usize) {
    let last = len as isize - 1;
    let (lo, hi) = (previous.min(cur) as isize, previous.max(cur) as isize);
    // max then min rather than clamp: no panic path for bounds the compiler cannot order.
    let step = (libm::truncf(*integrator) as isize).max(-lo).min(last - hi);
    *integrator = (*integrator - step as f32).clamp(-1.0, 1.0);
    (
        previous.saturating_add_signed(step),
        cur.saturating_add_signed(step),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pitch_and_roll_settle_each_with_their_own_time_constant() {
        let s = Settings {
            pitch_settle_s: 0.5,
            roll_settle_s: 1.0,
            ..Settings::DEFAULT
        };
        let level = AttitudeIndex { pitch: 10, roll: 7 };
        let at = AttitudeIndex { pitch: 14, roll: 3 };
        let mut d = AttitudeDrift::default();
        d.settle(at, level, 0.1, &s);
        // A fifth of +4 pitch steps, a tenth of -4 roll steps.
        assert!((d.pitch_steps + 0.8).abs() < 1e-6, "{d:?}");
        assert!((d.roll_steps - 0.4).abs() < 1e-6, "{d:?}");
        // 0: that axis never settles (a vehicle whose pitch follows the absolute measurement).
        let mut d = AttitudeDrift::default();
        let s = Settings {
            pitch_settle_s: 0.0,
            ..s
        };
        d.settle(at, level, 0.1, &s);
        assert_eq!(d.pitch_steps, 0.0);
        assert!((d.roll_steps - 0.4).abs() < 1e-6, "{d:?}");
        // Never more than the whole offset, however long the interval.
        let mut d = AttitudeDrift::default();
        d.settle(at, level, 10.0, &s);
        assert!((d.roll_steps - 4.0).abs() < 1e-6, "{d:?}");
    }

    #[test]
    fn a_shift_moves_both_frames_within_the_range_and_keeps_the_remainder() {
        let mut i = 2.7;
        assert_eq!(shift(&mut i, 10, 11, 21), (12, 13));
        assert!((i - 0.7).abs() < 1e-6);
        // Cut off at the end of the range, and the integrator cannot wind up past a step.
        let mut i = -9.0;
        assert_eq!(shift(&mut i, 3, 2, 21), (1, 0));
        assert_eq!(i, -1.0);
    }
}
