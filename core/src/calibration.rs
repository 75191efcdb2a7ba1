//! The mount as learned while driving: a correction to the configured mount's yaw, its spread
//! and the road it rests on, in a small plain value that an ECU can keep in non-volatile memory
//! ([`Calibration::to_bytes`], [`Calibration::from_bytes`]) and give back to the odometer
//! after the next ignition ([`crate::Odometer::restore_calibration`]).
//!
//! A camera turned by a yaw error sees the road move off the arc's chord by the error times
//! the distance, in every frame, straight or turning; the body's roll shakes it frame by frame
//! but not on average. Each frame the ground's matched pairs measure that step across the chord
//! ([`crate::method::pitch_vote`]); this module keeps their robust running mean, weighed by the
//! distance each frame covers and forgetting over [`FORGET_M`] of road, so that it follows a
//! camera refitted or knocked while the noise of single frames averages out. The odometer
//! turns the mount by [`Calibration::applied_yaw_rad`] (the estimate held short by a standard
//! error) whenever that has moved by [`APPLY_STEP_RAD`].

/// Road over which the calibration forgets, metres: an estimate rests on about this much of
/// the latest driving, enough to average a body's rolling out and to follow a change between
/// ignitions within minutes.
pub const FORGET_M: f32 = 1000.0;

/// Road driven before the calibration's yaw is applied, metres: until then the configured
/// mount stands.
pub const SETTLE_M: f32 = 10.0;

/// Standard errors of the estimate it is held short of when applied.
pub const APPLY_SDS: f32 = 1.0;

/// The change of the learned yaw, radians, that turns the mount again (0.02 deg: a tenth of
/// the error that costs 0.005 deg/m).
pub const APPLY_STEP_RAD: f32 = 0.02 * core::f32::consts::PI / 180.0;

/// A frame's measurement is taken at most this many spreads from the estimate (a vehicle
/// passing, a frame matched wrong).
const CLIP_SPREADS: f32 = 2.5;

/// The spread assumed before any measurement, radians (3 deg: a frame's sideways step on a
/// swaying body).
const START_SPREAD_RAD: f32 = 3.0 * core::f32::consts::PI / 180.0;

/// Frames over which the spread is taken at least as [`START_SPREAD_RAD`].
const WARM_FRAMES: f32 = 10.0;

/// The spread never falls under this, radians (0.1 deg): the clipping stays open to a change.
const MIN_SPREAD_RAD: f32 = 0.1 * core::f32::consts::PI / 180.0;

/// Shortest frame that measures, metres: the step across the chord is the yaw error times the
/// distance, lost in the matching's noise at a crawl.
pub const MIN_DISTANCE_M: f32 = 0.05;

/// One frame's sideways step, as the ground's matched pairs show it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SidewaysStep {
    /// The vehicle's step across the arc's chord, metres, positive to the left (the road moving
    /// right): a mount's yaw error times the distance, on average.
    pub sideways_m: f32,
    /// How many pairs' worth tell it from a heading error (fewer than the pairs where their
    /// ranges are alike).
    pub pairs: f32,
}

/// The mount learned while driving.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Calibration {
    /// Added to the configured mount's yaw, radians, counter-clockwise seen from above: the
    /// camera looks this much further left than the mount file says.
    pub yaw_rad: f32,
    /// The weighted spread of the frames' measurements about it, radians; 0 before a frame
    /// measured.
    pub yaw_spread_rad: f32,
    /// The sum of the frames' weights, forgetting included: each frame weighs its distance
    /// times the pairs that tell its sideways step (metres).
    pub weight: f32,
    /// The sum of the squares of the frames' weights, forgetting included (for the standard
    /// error: the frames' effective number is `weight^2 / weight_sq`).
    pub weight_sq: f32,
    /// Road driven while it measured, metres, all of it.
    pub distance_m: f32,
}

/// Why saved bytes, or a calibration given back to an odometer, were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CalibrationError {
    /// Not [`Calibration::BYTES`] long.
    WrongLength,
    /// The first four bytes are not [`Calibration::MAGIC`]: not a saved calibration, or one of
    /// another version.
    WrongMagic,
    /// The checksum does not match: the memory was corrupted or never written.
    Corrupted,
    /// A value is not finite or out of its range.
    OutOfRange,
    /// The odometer has no configuration yet: a calibration belongs to a mount, and
    /// [`crate::Odometer::configure`] forgets it.
    NotConfigured,
}

impl core::fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::WrongLength => "a saved calibration is 28 bytes long",
            Self::WrongMagic => "not a saved roadvo calibration (or one of another version)",
            Self::Corrupted => "the saved calibration's checksum does not match",
            Self::OutOfRange => "a saved calibration value is not finite or out of range",
            Self::NotConfigured => "the odometer has no configuration for the calibration",
        })
    }
}

impl core::error::Error for CalibrationError {}

impl Default for Calibration {
    fn default() -> Self {
        Self::NONE
    }
}

impl Calibration {
    /// Nothing learned: the configured mount stands.
    pub const NONE: Self = Self {
        yaw_rad: 0.0,
        yaw_spread_rad: 0.0,
        weight: 0.0,
        weight_sq: 0.0,
        distance_m: 0.0,
    };

    /// Bytes of [`to_bytes`](Self::to_bytes): the magic, five `f32`, a checksum.
    pub const BYTES: usize = 28;

    /// The first four bytes of a saved calibration (`rvc1`).
    pub const MAGIC: [u8; 4] = *b"rvc1";

    /// Largest yaw correction, radians (10 deg): past it the mount file is wrong, not worn.
    pub const MAX_YAW_RAD: f32 = 10.0 * core::f32::consts::PI / 180.0;

    /// The yaw correction's standard error, radians; `None` before a frame measured.
    pub fn yaw_sd_rad(&self) -> Option<f32> {
        (self.weight > 0.0).then(|| self.yaw_spread_rad * libm::sqrtf(self.weight_sq) / self.weight)
    }

    /// The yaw correction to turn the mount by, radians: none before it is
    /// [`settled`](Self::settled), then the estimate less [`APPLY_SDS`] of its standard errors
    /// towards the mount file's (none where it is within them), so that an estimate the road
    /// does not yet support leaves the mount as it is, and a clear error is turned away at once.
    pub fn applied_yaw_rad(&self) -> f32 {
        let Some(sd) = self.yaw_sd_rad().filter(|_| self.settled()) else {
            return 0.0;
        };
        let margin = APPLY_SDS * sd;
        if self.yaw_rad > margin {
            self.yaw_rad - margin
        } else if self.yaw_rad < -margin {
            self.yaw_rad + margin
        } else {
            0.0
        }
    }

    /// Whether it rests on enough road ([`SETTLE_M`]) to be applied.
    pub fn settled(&self) -> bool {
        self.distance_m >= SETTLE_M
    }

    /// Takes one frame's measurement, seen through the mount turned by `applied_yaw_rad`: the
    /// vehicle's step across the chord, positive left, over `distance_m`. A frame shorter than
    /// [`MIN_DISTANCE_M`] or a measurement that is not finite counts its road only.
    pub fn measure(&mut self, step: SidewaysStep, distance_m: f32, applied_yaw_rad: f32) {
        let d = distance_m.abs();
        if !d.is_finite() {
            return;
        }
        self.distance_m += d;
        let yaw_rad = applied_yaw_rad - step.sideways_m / distance_m;
        let w = d * step.pairs;
        if d < MIN_DISTANCE_M || !yaw_rad.is_finite() || !(w > 0.0 && w.is_finite()) {
            return;
        }
        let keep = libm::expf(-d / FORGET_M);
        self.weight = self.weight * keep + w;
        self.weight_sq = self.weight_sq * keep * keep + w * w;
        let share = w / self.weight;
        let frames = self.weight * self.weight / self.weight_sq;
        // Over the first frames the spread is not known yet: the assumed one bounds it below.
        let spread = if frames < WARM_FRAMES {
            self.yaw_spread_rad.max(START_SPREAD_RAD)
        } else {
            self.yaw_spread_rad
        };
        let bound = CLIP_SPREADS * spread;
        // max then min rather than clamp: no panic path for a bound the compiler cannot order.
        let r = (yaw_rad - self.yaw_rad).max(-bound).min(bound);
        self.yaw_rad = (self.yaw_rad + share * r).clamp(-Self::MAX_YAW_RAD, Self::MAX_YAW_RAD);
        // The spread follows the clipped residuals, never collapsing on a few alike frames.
        let var = (1.0 - share) * (spread * spread + share * r * r);
        self.yaw_spread_rad = libm::sqrtf(var).max(MIN_SPREAD_RAD);
    }

    /// Whether every field is finite and in its range: the yaw within
    /// [`MAX_YAW_RAD`](Self::MAX_YAW_RAD), the spread, weights and distance not negative.
    pub fn check(&self) -> Result<(), CalibrationError> {
        let finite_non_negative = [
            self.yaw_spread_rad,
            self.weight,
            self.weight_sq,
            self.distance_m,
        ]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0);
        if !finite_non_negative
            || !self.yaw_rad.is_finite()
            || self.yaw_rad.abs() > Self::MAX_YAW_RAD
        {
            return Err(CalibrationError::OutOfRange);
        }
        Ok(())
    }

    /// The value as bytes for non-volatile memory: [`MAGIC`](Self::MAGIC), the five fields as
    /// little-endian `f32` in declaration order, and a 32-bit checksum (FNV-1a) of the rest.
    pub fn to_bytes(&self) -> [u8; Self::BYTES] {
        let fields = [
            self.yaw_rad,
            self.yaw_spread_rad,
            self.weight,
            self.weight_sq,
            self.distance_m,
        ];
        let mut out = [0u8; Self::BYTES];
        let head = Self::MAGIC
            .into_iter()
            .chain(fields.into_iter().flat_map(f32::to_le_bytes));
        for (slot, b) in out.iter_mut().zip(head) {
            *slot = b;
        }
        let sum = fnv1a(out.get(..Self::BYTES - 4).unwrap_or_default());
        for (slot, b) in out.iter_mut().skip(Self::BYTES - 4).zip(sum.to_le_bytes()) {
            *slot = b;
        }
        out
    }

    /// A value saved by [`to_bytes`](Self::to_bytes), checked: its length, magic and checksum,
    /// and every field finite and in range.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, CalibrationError> {
        if bytes.len() != Self::BYTES {
            return Err(CalibrationError::WrongLength);
        }
        let Some((head, sum)) = bytes.split_at_checked(Self::BYTES - 4) else {
            return Err(CalibrationError::WrongLength);
        };
        let Some((magic, body)) = head.split_at_checked(4) else {
            return Err(CalibrationError::WrongLength);
        };
        if magic != Self::MAGIC {
            return Err(CalibrationError::WrongMagic);
        }
        let word =
            |b: &[u8]| -> [u8; 4] { core::array::from_fn(|i| b.get(i).copied().unwrap_or(0)) };
        if u32::from_le_bytes(word(sum)) != fnv1a(head) {
            return Err(CalibrationError::Corrupted);
        }
        let mut f = body.chunks_exact(4).map(|c| f32::from_le_bytes(word(c)));
        let mut next = || f.next().unwrap_or(f32::NAN);
        let c = Self {
            yaw_rad: next(),
            yaw_spread_rad: next(),
            weight: next(),
            weight_sq: next(),
            distance_m: next(),
        };
        c.check()?;
        Ok(c)
    }
}

/// FNV-1a over `bytes`, 32 bits.
fn fnv1a(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5u32, |h, &b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(d: f32) -> f32 {
        d.to_radians()
    }

    /// A frame's step of `sideways_m` told by 20 pairs.
    fn step(sideways_m: f32) -> SidewaysStep {
        SidewaysStep {
            sideways_m,
            pairs: 20.0,
        }
    }

    #[test]
    fn noisy_frames_settle_on_their_mean_and_an_outlier_moves_it_little() {
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(5u32);
        // A mount file's yaw 1 deg too far left: the vehicle steps left of the chord by 1 deg
        // of each 0.9 m, +-2 deg a frame.
        for _ in 0..1000 {
            let yaw = deg(1.0) + deg(4.0) * (next() - 0.5);
            c.measure(step(yaw * 0.9), 0.9, 0.0);
        }
        let err = (c.yaw_rad + deg(1.0)).to_degrees();
        assert!(err.abs() < 0.1, "{c:?}");
        assert!(c.settled() && (c.distance_m - 900.0).abs() < 0.1, "{c:?}");
        let sd = c.yaw_sd_rad().unwrap().to_degrees();
        assert!(sd > 0.02 && sd < 0.1, "{sd}");
        let before = c.yaw_rad;
        c.measure(step(deg(-30.0) * 0.9), 0.9, 0.0);
        assert!((c.yaw_rad - before).abs() < deg(0.01), "{c:?}");
    }

    #[test]
    fn measurements_through_an_applied_yaw_are_taken_against_the_file() {
        // The mount already turned by -1 deg: a frame with no step across says -1 deg.
        let mut c = Calibration::NONE;
        for _ in 0..200 {
            c.measure(step(0.0), 1.0, deg(-1.0));
        }
        assert!((c.yaw_rad - deg(-1.0)).abs() < deg(0.01), "{c:?}");
        // Frames at a crawl count their road only.
        let weight = c.weight;
        c.measure(step(0.5), 0.01, 0.0);
        assert_eq!(c.weight, weight);
        assert!((c.distance_m - 200.01).abs() < 1e-3);
    }

    #[test]
    fn saved_bytes_come_back_and_damaged_ones_are_refused() {
        let mut c = Calibration::NONE;
        for k in 0..50 {
            c.measure(step(0.01 * (k % 3) as f32), 0.8, 0.0);
        }
        let bytes = c.to_bytes();
        assert_eq!(Calibration::from_bytes(&bytes), Ok(c));
        assert_eq!(
            Calibration::from_bytes(&bytes[..27]),
            Err(CalibrationError::WrongLength)
        );
        let mut other = bytes;
        other[0] = b'x';
        assert_eq!(
            Calibration::from_bytes(&other),
            Err(CalibrationError::WrongMagic)
        );
        for i in 4..Calibration::BYTES {
            let mut flipped = bytes;
            flipped[i] ^= 0x10;
            assert_eq!(
                Calibration::from_bytes(&flipped),
                Err(CalibrationError::Corrupted),
                "byte {i}"
            );
        }
        // Erased flash (all ones) is not a calibration.
        assert!(Calibration::from_bytes(&[0xff; Calibration::BYTES]).is_err());
        // Checksummed but out of range.
        let wild = Calibration { yaw_rad: 1.0, ..c };
        assert_eq!(
            Calibration::from_bytes(&wild.to_bytes()),
            Err(CalibrationError::OutOfRange)
        );
    }
}
