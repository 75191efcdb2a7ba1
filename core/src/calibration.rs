//! The mount as learned while driving: corrections to the configured mount's yaw, pitch, roll and
//! camera distance ahead of the axle, their spreads and the road they rest on, in a small plain
//! value that an ECU can keep in non-volatile memory ([`Calibration::to_bytes`],
//! [`Calibration::from_bytes`]) and give back to the odometer after the next ignition
//! ([`crate::Odometer::restore_calibration`]).
//!
//! - **Yaw.** A camera turned about the vertical by an error sees the road move off the arc's
//!   chord by the error times the distance, in every frame, straight or turning; the body's
//!   roll shakes it frame by frame but not on average. Each frame the ground's matched pairs
//!   measure that step across the chord ([`crate::method::pitch_vote`]). The whole image's
//!   motion holds the direction of travel too ([`crate::heading`]): a camera turned left by an
//!   error sees it to the right of the chord by the error, on frames that see more than the
//!   road (as for the pitch); on frames that see nothing but road the road's plane holds it
//!   (its homography holds the camera's travel, [`crate::heading::plane`]). The two kinds are
//!   weighed by their variances ([`Calibration::turn`]); the direction is the tighter. Both
//!   measure the camera's turn about the vertical, which a camera pitched down takes from its
//!   roll too (the roll is about the optical axis: [`crate::projection::Mount::yaw_per_roll`]).
//!   So they are kept as that turn, whatever roll the mount had when they were taken, and the
//!   yaw is the turn less the learned roll's share ([`Calibration::yaw`]): evidence taken
//!   before the roll was learned stays good after.
//! - **Pitch.** The vehicle travels along the road, so over any stretch the direction of travel
//!   lies in the road's plane; the body's pitching swings it about that plane frame by frame
//!   but not on average. The whole image's motion holds that direction ([`crate::heading`]): a
//!   camera pitched up by an error sees it below the horizontal of the mount file by the error.
//!   Only frames whose inliers include points above the horizon measure it: on a scene of
//!   nothing but road the direction trades against the pitch change and is biased. There the
//!   road's own plane measures it: the pairs on the road (the whole image's, and the ground
//!   window's corners found again by patch, [`crate::ground_patches`]) move by its homography,
//!   which with the camera's height known holds the body's pitch and roll to the road
//!   ([`crate::heading::plane`]); the body's pitching and rolling average out.
//! - **Roll.** From the road's plane alone, on every frame whose pairs on the road fit one
//!   (the direction of travel does not see a roll).
//! - **The camera's distance ahead of the rear axle.** A camera further ahead than the mount
//!   file says swings further sideways in a bend: its direction of travel leaves the chord by
//!   the error times the curvature. The whole image's motion holds that direction on frames
//!   that see more than the road; on frames that see nothing but road the road's plane holds
//!   it (its homography holds the camera's travel whole), where its fit holds it as well as
//!   the line's spread. It is learned as the slope of a line against each frame's own response
//!   to a metre of it ([`Calibration::swing`]), where the bends spread enough to tell it.
//!
//! Each estimate keeps its measurements' robust running mean ([`Learned`]), weighed by the
//! distance each frame covers (times the pairs that tell a sideways step, for the ground's) and
//! forgetting over [`FORGET_M`] of road, so that it follows a camera refitted or knocked while
//! the noise of single frames averages out. The odometer turns the mount by
//! [`Calibration::applied_yaw_rad`], [`Calibration::applied_pitch_rad`] and
//! [`Calibration::applied_roll_rad`] and moves its camera by [`Calibration::applied_x_m`] (each
//! estimate shrunk by its signal to noise: none within a standard error) whenever one has moved
//! by [`APPLY_STEP_RAD`] or [`APPLY_STEP_M`].

use crate::heading::plane::Road;

/// Road over which the calibration forgets, metres: an estimate rests on about this much of
/// the latest driving, enough to average a body's rolling and pitching out and to follow a
/// change between ignitions within minutes.
pub const FORGET_M: f32 = 1000.0;

/// Road driven before the calibration is applied, metres: until then the configured mount
/// stands.
pub const SETTLE_M: f32 = 10.0;

/// The change of a learned angle, radians, that turns the mount again (0.02 deg: a tenth of
/// the yaw error that costs 0.005 deg/m).
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
/// distance, lost in the matching's noise at a crawl, and the direction of travel of so short
/// a step is the image's noise.
pub const MIN_DISTANCE_M: f32 = 0.05;

/// Fewest of the whole image's inliers seen above the horizon for a frame's direction of
/// travel to measure the pitch: as many as the ground's regressions ask. On a scene of nothing
/// but road (none above it) the direction is biased by the pitch change it trades against
/// (the paper's s-course: 0.3 deg, a frame's spread 1.2 deg); KITTI and the town have 10 to 40
/// (`docs/experiments.md`, "The mount while driving").
pub const MIN_INLIERS_ABOVE_HORIZON: u16 = 8;

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

/// One angle of the mount as learned: the robust running mean of the frames' measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Learned {
    /// Added to the configured mount's angle, radians.
    pub rad: f32,
    /// The weighted spread of the frames' measurements about it, radians; 0 before a frame
    /// measured.
    pub spread_rad: f32,
    /// The sum of the frames' weights, forgetting included (metres, times pairs for the yaw).
    pub weight: f32,
    /// The sum of the squares of the frames' weights, forgetting included (for the standard
    /// error: the frames' effective number is `weight^2 / weight_sq`).
    pub weight_sq: f32,
}

impl Learned {
    /// Nothing learned: the configured angle stands.
    pub const NONE: Self = Self {
        rad: 0.0,
        spread_rad: 0.0,
        weight: 0.0,
        weight_sq: 0.0,
    };

    /// The estimate's standard error, radians; `None` before a frame measured.
    pub fn sd_rad(&self) -> Option<f32> {
        (self.weight > 0.0).then(|| {
            let spread = warm_spread(self.spread_rad, self.weight, self.weight_sq);
            spread * libm::sqrtf(self.weight_sq) / self.weight
        })
    }

    /// The estimate and its standard error; `None` before a frame measured.
    pub fn estimate(&self) -> Option<AngleEstimate> {
        self.sd_rad().map(|sd_rad| AngleEstimate {
            rad: self.rad,
            sd_rad,
        })
    }

    /// Takes one frame's measurement `rad`, weighing `w`, over `distance_m` of road (for the
    /// forgetting). A frame shorter than [`MIN_DISTANCE_M`] or a measurement that is not
    /// finite is left out.
    fn take(&mut self, rad: f32, w: f32, distance_m: f32) {
        let weights = (&mut self.weight, &mut self.weight_sq);
        let Some((share, spread)) = admit(weights, self.spread_rad, w, distance_m, rad) else {
            return;
        };
        let bound = CLIP_SPREADS * spread;
        // max then min rather than clamp: no panic path for a bound the compiler cannot order.
        let r = (rad - self.rad).max(-bound).min(bound);
        let max = Calibration::MAX_RAD;
        self.rad = (self.rad + share * r).max(-max).min(max);
        self.spread_rad = next_spread(share, spread, r);
    }

    /// Whether every field is finite and in its range.
    fn in_range(&self) -> bool {
        let non_negative = [self.spread_rad, self.weight, self.weight_sq]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0);
        non_negative && self.rad.is_finite() && self.rad.abs() <= Calibration::MAX_RAD
    }

    /// The fields in declaration order.
    fn fields(&self) -> [f32; 4] {
        [self.rad, self.spread_rad, self.weight, self.weight_sq]
    }
}

/// One angle of the mount as learned where the body leans with a load: the robust running
/// least squares line of the frames' measurements against the load (for the roll, the
/// lateral acceleration: a body rolls out of a bend by a few tenths of a degree a m/s^2), whose
/// value at no load is the mount's. A drive of bends one way only cannot tell the two apart,
/// and the estimate's standard error says so.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LearnedLine {
    /// The weighted mean of the measurements, radians.
    pub mean_rad: f32,
    /// The weighted mean of the load (m/s^2 for the roll).
    pub mean_load: f32,
    /// The weighted variance of the load.
    pub load_var: f32,
    /// The weighted covariance of the load and the measurements, radians times the load.
    pub covariance: f32,
    /// The weighted spread of the measurements about the line, radians; 0 before a frame.
    pub spread_rad: f32,
    /// The sum of the frames' weights, forgetting included (metres).
    pub weight: f32,
    /// The sum of the squares of the frames' weights, forgetting included.
    pub weight_sq: f32,
}

impl LearnedLine {
    /// Nothing learned: the configured angle stands.
    pub const NONE: Self = Self {
        mean_rad: 0.0,
        mean_load: 0.0,
        load_var: 0.0,
        covariance: 0.0,
        spread_rad: 0.0,
        weight: 0.0,
        weight_sq: 0.0,
    };

    /// The line's slope, radians a unit of load: none until the loads' variance exceeds
    /// `least_load_var` (under it, frames at one load cannot tell a slope).
    pub fn slope(&self, least_load_var: f32) -> f32 {
        if self.load_var > least_load_var {
            self.covariance / self.load_var
        } else {
            0.0
        }
    }

    /// The slope and its standard error (the spread over the frames' effective number and
    /// the loads' spread), radians a unit of load; `None` until the loads' variance exceeds
    /// `least_load_var`.
    pub fn slope_estimate(&self, least_load_var: f32) -> Option<(f32, f32)> {
        (self.weight > 0.0 && self.load_var > least_load_var).then(|| {
            let sd = self.spread() * libm::sqrtf(self.weight_sq / self.load_var) / self.weight;
            (self.slope(least_load_var), sd)
        })
    }

    /// The angle at no load and its standard error (a line's intercept: the spread over the
    /// frames' effective number, widened by how far their mean load lies from none against
    /// the loads' spread, taken as at least `least_load_var`); `None` before a frame measured.
    pub fn estimate(&self, least_load_var: f32) -> Option<AngleEstimate> {
        (self.weight > 0.0).then(|| {
            let lever = self.mean_load * self.mean_load / self.load_var.max(least_load_var);
            AngleEstimate {
                rad: self.mean_rad - self.slope(least_load_var) * self.mean_load,
                sd_rad: self.spread() * libm::sqrtf(self.weight_sq * (1.0 + lever)) / self.weight,
            }
        })
    }

    /// The spread about the line the standard errors take ([`warm_spread`]), radians.
    fn spread(&self) -> f32 {
        warm_spread(self.spread_rad, self.weight, self.weight_sq)
    }

    /// Takes one frame's measurement `rad` at `load`, weighing `w`, over `distance_m` of road,
    /// as [`Learned`] takes its: clipped at a few spreads from the line (its slope as
    /// [`slope`](Self::slope) gives it with `least_load_var`).
    fn take(&mut self, rad: f32, (load, least_load_var): (f32, f32), w: f32, distance_m: f32) {
        if !load.is_finite() {
            return;
        }
        let weights = (&mut self.weight, &mut self.weight_sq);
        let Some((share, spread)) = admit(weights, self.spread_rad, w, distance_m, rad) else {
            return;
        };
        let bound = CLIP_SPREADS * spread;
        let dx = load - self.mean_load;
        let line = self.mean_rad + self.slope(least_load_var) * dx;
        let r = (rad - line).max(-bound).min(bound);
        let dy = line + r - self.mean_rad;
        let max = Calibration::MAX_RAD;
        self.mean_rad = (self.mean_rad + share * dy).max(-max).min(max);
        self.mean_load += share * dx;
        self.load_var = (1.0 - share) * (self.load_var + share * dx * dx);
        self.covariance = (1.0 - share) * (self.covariance + share * dx * dy);
        self.spread_rad = next_spread(share, spread, r);
    }

    /// Whether every field is finite and in its range.
    fn in_range(&self) -> bool {
        let non_negative = [self.load_var, self.spread_rad, self.weight, self.weight_sq]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0);
        let finite = [self.mean_load, self.covariance]
            .iter()
            .all(|v| v.is_finite());
        non_negative
            && finite
            && self.mean_rad.is_finite()
            && self.mean_rad.abs() <= Calibration::MAX_RAD
    }

    /// The fields in declaration order.
    fn fields(&self) -> [f32; 7] {
        [
            self.mean_rad,
            self.mean_load,
            self.load_var,
            self.covariance,
            self.spread_rad,
            self.weight,
            self.weight_sq,
        ]
    }
}

/// A running estimate's weights (`weight`, `weight_sq`) taking a frame that weighs `w` over
/// `distance_m` of road (the older ones forgotten): the frame's share of them and the spread
/// its measurement `rad` is clipped at (over the first frames, when the spread is not known
/// yet, the assumed one bounds `spread_rad` below). `None`, the weights untouched, for a frame
/// shorter than [`MIN_DISTANCE_M`] or a value that is not finite.
fn admit(
    (weight, weight_sq): (&mut f32, &mut f32),
    spread_rad: f32,
    w: f32,
    distance_m: f32,
    rad: f32,
) -> Option<(f32, f32)> {
    let d = distance_m.abs();
    let finite = d.is_finite() && rad.is_finite() && w.is_finite();
    if !(finite && d >= MIN_DISTANCE_M && w > 0.0) {
        return None;
    }
    let keep = libm::expf(-d / FORGET_M);
    *weight = *weight * keep + w;
    *weight_sq = *weight_sq * keep * keep + w * w;
    Some((w / *weight, warm_spread(spread_rad, *weight, *weight_sq)))
}

/// The spread an estimate of `weight` and `weight_sq` is taken at: over its first
/// [`WARM_FRAMES`] (their effective number, `weight^2 / weight_sq`; none before a frame) at least
/// [`START_SPREAD_RAD`], since a few frames' own spread says little of the next one's (a single
/// frame's is none). Both the clipping and the standard error take it, so that an estimate
/// that has just begun (the road's pitch on the first frame that sees nothing but road) does
/// not weigh like hundreds of frames against another.
fn warm_spread(spread_rad: f32, weight: f32, weight_sq: f32) -> f32 {
    if weight <= 0.0 || weight * weight < WARM_FRAMES * weight_sq {
        spread_rad.max(START_SPREAD_RAD)
    } else {
        spread_rad
    }
}

/// The spread after a frame of `share` whose clipped residual is `r`: it follows the clipped
/// residuals, never collapsing on a few alike frames.
fn next_spread(share: f32, spread: f32, r: f32) -> f32 {
    let var = (1.0 - share) * (spread * spread + share * r * r);
    libm::sqrtf(var).max(MIN_SPREAD_RAD)
}

/// Least variance of the lateral acceleration for the roll's slope against it, (m/s^2)^2: a
/// spread of 0.5 m/s^2.
const ROLL_LOAD_VAR: f32 = 0.5 * 0.5;

/// Least variance of the swing's load (the direction of travel's change a metre of the
/// camera's distance ahead of the axle: about the curvature driven) for the distance to be
/// learned, (1/m)^2: a spread of 0.01 1/m (a bend of 100 m radius). Over straighter drives the
/// offset moves the direction of travel by less than the image tells (0.2 m by 0.1 deg in
/// that bend).
const SWING_VAR: f32 = 0.01 * 0.01;

/// Largest correction of the camera's distance ahead of the rear axle, metres: past it the
/// mount file is wrong, not worn.
pub const MAX_X_M: f32 = 1.0;

/// The least step of the learned distance ahead of the axle, metres (1 cm: 0.005 deg of
/// direction a frame in a bend of 10 m radius).
pub const APPLY_STEP_M: f32 = 0.01;

/// One learned angle: its value and its standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AngleEstimate {
    /// Added to the configured mount's angle, radians.
    pub rad: f32,
    /// Its standard error, radians.
    pub sd_rad: f32,
}

/// The correction to turn the mount by, radians: none unless `settled`, then the estimate shrunk
/// towards the mount file's by its variance over its square (the positive-part James-Stein
/// rule; none within a standard error of the file's). An estimate the road does not yet
/// support leaves the mount as it is, and a clear error is turned away all but whole (1 deg
/// known to 0.1 deg: 0.99 of it). Holding each estimate a standard error short instead left
/// that error in every frame's scale (`docs/experiments.md`, "The mount as estimated").
fn shrunk(estimate: Option<(f32, f32)>, settled: bool) -> f32 {
    let Some((value, sd)) = estimate.filter(|_| settled) else {
        return 0.0;
    };
    if value.abs() > sd {
        value - sd * sd / value
    } else {
        0.0
    }
}

/// An angle estimate as `shrunk` takes it.
fn pair(e: Option<AngleEstimate>) -> Option<(f32, f32)> {
    e.map(|e| (e.rad, e.sd_rad))
}

/// The mount learned while driving: the yaw and the pitch from two kinds of evidence each, the
/// roll from one.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Calibration {
    /// The camera's turn about the vertical the ground's sideways step shows, counter-clockwise
    /// seen from above: the camera looks `yaw_ground.rad` further left than the mount file
    /// says (its yaw and its roll's share, [`Calibration::yaw`]).
    pub yaw_ground: Learned,
    /// The camera's turn the direction of travel shows, as `yaw_ground`: the whole image's
    /// motion's on frames that see more than the road, the road's plane's on frames that see
    /// nothing but road.
    pub yaw_image: Learned,
    /// The pitch the whole image's direction of travel shows, nose up: the camera looks
    /// `pitch_image.rad` further up than the mount file says.
    pub pitch_image: Learned,
    /// The pitch the road's plane shows, on frames that see nothing but road, as
    /// `pitch_image`.
    pub pitch_road: Learned,
    /// The roll the road's plane shows, left side up, against the lateral acceleration: at
    /// none, the camera is rolled that much further left side up than the mount file says.
    pub roll: LearnedLine,
    /// The direction of travel left of the arc's chord (the whole image's, or the road's
    /// plane's on a frame that sees nothing but road; radians, as the mount file's distance
    /// ahead of the axle would show it) against how far a metre of that distance moves it
    /// (about the curvature driven, 1/m): a camera further ahead of the axle than the model
    /// draws it swings further sideways in a bend, by the error times the turn. The line's
    /// slope is the correction to the camera's distance ahead of the rear axle, metres.
    pub swing: LearnedLine,
    /// Road driven on the frames that measured, metres, all of it.
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
            Self::WrongLength => "a saved calibration is 132 bytes long",
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
        yaw_ground: Learned::NONE,
        yaw_image: Learned::NONE,
        pitch_image: Learned::NONE,
        pitch_road: Learned::NONE,
        roll: LearnedLine::NONE,
        swing: LearnedLine::NONE,
        distance_m: 0.0,
    };

    /// Bytes of [`to_bytes`](Self::to_bytes): the magic, thirty-one `f32`, a checksum.
    pub const BYTES: usize = 132;

    /// The first four bytes of a saved calibration (`rvc6`; the older `rvc1` to `rvc4`,
    /// without the road's pitch and roll or the distance ahead of the axle, and `rvc5`, whose
    /// yaw fields held the yaw where these hold the camera's turn, are refused: the odometer
    /// learns again within minutes).
    pub const MAGIC: [u8; 4] = *b"rvc6";

    /// Largest correction of any angle, radians (10 deg): past it the mount file is wrong,
    /// not worn.
    pub const MAX_RAD: f32 = 10.0 * core::f32::consts::PI / 180.0;

    /// The yaw correction to turn the mount by, radians (see [`Learned`]): none before the
    /// calibration is [`settled`](Self::settled), nor while no turn was measured (the mount
    /// file's yaw stands, as with `learn_yaw` off). With the applied roll's share
    /// (`yaw_per_roll`, the mount's [`crate::projection::Mount::yaw_per_roll`]) it turns the
    /// camera about the vertical by the learned [`turn`](Self::turn), shrunk as the others.
    pub fn applied_yaw_rad(&self, yaw_per_roll: f32) -> f32 {
        match self.turn().filter(|_| self.settled()) {
            Some(turn) => {
                shrunk(Some((turn.rad, turn.sd_rad)), true) - yaw_per_roll * self.applied_roll_rad()
            }
            None => 0.0,
        }
    }

    /// The camera's turn about the vertical learned, radians, and its standard error: the
    /// ground's and the image's estimates weighed by their variances (where the image measured,
    /// its estimate is the tighter and stands on evidence the road's plane does not bend);
    /// `None` before either measured.
    pub fn turn(&self) -> Option<AngleEstimate> {
        weighed(&self.yaw_ground, &self.yaw_image)
    }

    /// The yaw learned, radians, and its standard error: the [`turn`](Self::turn) less the
    /// learned roll's share of it (`yaw_per_roll`: the mount's
    /// [`crate::projection::Mount::yaw_per_roll`]); `None` before the turn is measured.
    pub fn yaw(&self, yaw_per_roll: f32) -> Option<AngleEstimate> {
        let turn = self.turn()?;
        Some(match self.roll() {
            Some(roll) => {
                let share = yaw_per_roll * roll.sd_rad;
                AngleEstimate {
                    rad: turn.rad - yaw_per_roll * roll.rad,
                    sd_rad: libm::sqrtf(turn.sd_rad * turn.sd_rad + share * share),
                }
            }
            None => turn,
        })
    }

    /// The pitch learned, radians, and its standard error: the image's and the road's
    /// estimates weighed by their variances (each from its own frames); `None` before either
    /// measured.
    pub fn pitch(&self) -> Option<AngleEstimate> {
        weighed(&self.pitch_image, &self.pitch_road)
    }

    /// The roll learned, radians, and its standard error; `None` before a frame measured.
    pub fn roll(&self) -> Option<AngleEstimate> {
        self.roll.estimate(ROLL_LOAD_VAR)
    }

    /// The correction to the camera's distance ahead of the rear axle learned, metres, and its
    /// standard error (the swing's slope); `None` until the swing's load spreads over
    /// [`SWING_VAR`]'s root.
    pub fn x_ahead(&self) -> Option<(f32, f32)> {
        self.swing.slope_estimate(SWING_VAR)
    }

    /// The correction to move the camera ahead by, metres, as
    /// [`applied_yaw_rad`](Self::applied_yaw_rad), within [`MAX_X_M`].
    pub fn applied_x_m(&self) -> f32 {
        let max = MAX_X_M;
        // max then min rather than clamp: no panic path for a bound the compiler cannot order.
        shrunk(self.x_ahead(), self.settled()).max(-max).min(max)
    }

    /// The roll correction to turn the mount by, radians, as
    /// [`applied_yaw_rad`](Self::applied_yaw_rad).
    pub fn applied_roll_rad(&self) -> f32 {
        shrunk(pair(self.roll()), self.settled())
    }

    /// The pitch correction to turn the mount by, radians, as
    /// [`applied_yaw_rad`](Self::applied_yaw_rad).
    pub fn applied_pitch_rad(&self) -> f32 {
        shrunk(pair(self.pitch()), self.settled())
    }

    /// Whether it rests on enough road ([`SETTLE_M`]) to be applied.
    pub fn settled(&self) -> bool {
        self.distance_m >= SETTLE_M
    }

    /// Counts `distance_m` of road driven on a frame that measured.
    pub fn drive(&mut self, distance_m: f32) {
        let d = distance_m.abs();
        if d.is_finite() {
            self.distance_m += d;
        }
    }

    /// Takes one frame's sideways step, seen through the mount turned about the vertical by
    /// `applied_turn_rad` ([`Angles::turn_rad`]): the vehicle's step across the chord, positive
    /// left, over `distance_m`.
    pub fn measure_yaw(&mut self, step: SidewaysStep, distance_m: f32, applied_turn_rad: f32) {
        let yaw_rad = applied_turn_rad - step.sideways_m / distance_m;
        self.yaw_ground
            .take(yaw_rad, distance_m.abs() * step.pairs, distance_m);
    }

    /// Takes one frame's direction of travel, `azimuth_rad` left of the arc's chord as the
    /// mount turned about the vertical by `applied_turn_rad` ([`Angles::turn_rad`]) sees it,
    /// over `distance_m`: a camera that looks further left than its mount says sees the travel
    /// as far to the right.
    pub fn measure_yaw_image(&mut self, azimuth_rad: f32, distance_m: f32, applied_turn_rad: f32) {
        self.yaw_image
            .take(applied_turn_rad - azimuth_rad, distance_m.abs(), distance_m);
    }

    /// Takes one frame's road plane, seen through the mount turned by `applied` (whose roll
    /// turns it about the vertical by `yaw_per_roll` a radian, [`Angles::turn_rad`]), over
    /// `distance_m` at a lateral acceleration of `lateral_m_s2` (to the left): as
    /// `(pitch, roll, yaw)` say, its pitch (on a frame that sees nothing but road), its roll,
    /// and its direction of travel as the yaw's ([`measure_yaw_image`](Self::measure_yaw_image);
    /// on a frame that sees nothing but road).
    pub fn measure_road(
        &mut self,
        road: &Road,
        (distance_m, lateral_m_s2): (f32, f32),
        (applied, yaw_per_roll): (Angles, f32),
        (pitch, roll, yaw): (bool, bool, bool),
    ) {
        if yaw {
            let turn = applied.turn_rad(yaw_per_roll);
            self.measure_yaw_image(road.azimuth_rad, distance_m, turn);
        }
        if pitch {
            self.pitch_road
                .take(applied.pitch + road.pitch_rad, distance_m.abs(), distance_m);
        }
        if roll {
            let rad = applied.roll + road.roll_rad;
            self.roll.take(
                rad,
                (lateral_m_s2, ROLL_LOAD_VAR),
                distance_m.abs(),
                distance_m,
            );
        }
    }

    /// Takes one frame's direction of travel over `distance_m`, `azimuth_rad` left of the arc's
    /// chord as the mount with its camera moved `applied_x_m` ahead sees it, and
    /// `swing_rad_per_m`, how far it would move right were the camera a metre further ahead
    /// ([`crate::heading::ImageMotion::swing_rad_per_m`], [`Road::swing_rad_per_m`] of the
    /// frame's heading), with the direction's standard error `sd_rad` where the frame's fit
    /// gives one (the road's plane): a frame that holds its direction less well than the
    /// line's spread about its points is left out (a kerb, or a second plane, in a tight bend
    /// reads the direction degrees off, the same way bend after bend, and says so in its
    /// standard error).
    pub fn measure_x_ahead(
        &mut self,
        (azimuth_rad, swing_rad_per_m): (f32, f32),
        sd_rad: Option<f32>,
        distance_m: f32,
        applied_x_m: f32,
    ) {
        if sd_rad.is_some_and(|sd| sd > self.swing.spread()) {
            return;
        }
        // As the mount file's camera would show it: the applied correction's swing added back.
        let rad = azimuth_rad + applied_x_m * swing_rad_per_m;
        let load = (swing_rad_per_m, SWING_VAR);
        self.swing.take(rad, load, distance_m.abs(), distance_m);
    }

    /// Takes one frame's direction of travel, `elevation_rad` above the horizontal of the
    /// mount turned by `applied_pitch_rad`, over `distance_m`.
    pub fn measure_pitch(&mut self, elevation_rad: f32, distance_m: f32, applied_pitch_rad: f32) {
        self.pitch_image.take(
            applied_pitch_rad - elevation_rad,
            distance_m.abs(),
            distance_m,
        );
    }

    /// Whether every field is finite and in its range: each angle within
    /// [`MAX_RAD`](Self::MAX_RAD), the spreads, weights and distance not negative.
    pub fn check(&self) -> Result<(), CalibrationError> {
        let distance = self.distance_m.is_finite() && self.distance_m >= 0.0;
        let angles = [
            &self.yaw_ground,
            &self.yaw_image,
            &self.pitch_image,
            &self.pitch_road,
        ];
        let lines = self.roll.in_range() && self.swing.in_range();
        if !(distance && angles.iter().all(|a| a.in_range()) && lines) {
            return Err(CalibrationError::OutOfRange);
        }
        Ok(())
    }

    /// The value as bytes for non-volatile memory: [`MAGIC`](Self::MAGIC), the thirty-one
    /// fields as little-endian `f32` in declaration order (four for each of the ground's yaw,
    /// the image's yaw, the image's pitch and the road's pitch, seven for each of the roll and
    /// the swing, then the distance driven), and a 32-bit checksum (FNV-1a) of the rest.
    pub fn to_bytes(&self) -> [u8; Self::BYTES] {
        let fields = self.yaw_ground.fields().into_iter();
        let fields = fields
            .chain(self.yaw_image.fields())
            .chain(self.pitch_image.fields())
            .chain(self.pitch_road.fields())
            .chain(self.roll.fields())
            .chain(self.swing.fields());
        let mut out = [0u8; Self::BYTES];
        let head = Self::MAGIC
            .into_iter()
            .chain(fields.chain([self.distance_m]).flat_map(f32::to_le_bytes));
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
        let mut learned = || Learned {
            rad: next(),
            spread_rad: next(),
            weight: next(),
            weight_sq: next(),
        };
        let (yaw_ground, yaw_image) = (learned(), learned());
        let (pitch_image, pitch_road) = (learned(), learned());
        let mut line = || LearnedLine {
            mean_rad: next(),
            mean_load: next(),
            load_var: next(),
            covariance: next(),
            spread_rad: next(),
            weight: next(),
            weight_sq: next(),
        };
        let (roll, swing) = (line(), line());
        let c = Self {
            yaw_ground,
            yaw_image,
            pitch_image,
            pitch_road,
            roll,
            swing,
            distance_m: next(),
        };
        c.check()?;
        Ok(c)
    }
}

/// Two estimates of one angle weighed by their variances; either where the other has not
/// measured, `None` before both.
fn weighed(a: &Learned, b: &Learned) -> Option<AngleEstimate> {
    match (a.estimate(), b.estimate()) {
        (Some(a), Some(b)) => {
            let (wa, wb) = (1.0 / (a.sd_rad * a.sd_rad), 1.0 / (b.sd_rad * b.sd_rad));
            Some(AngleEstimate {
                rad: (wa * a.rad + wb * b.rad) / (wa + wb),
                sd_rad: 1.0 / libm::sqrtf(wa + wb),
            })
        }
        (a, b) => a.or(b),
    }
}

/// The mount's angles the calibration turns, radians.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Angles {
    /// Yaw, counter-clockwise seen from above.
    pub yaw: f32,
    /// Pitch, nose up.
    pub pitch: f32,
    /// Roll, left side up.
    pub roll: f32,
}

impl Angles {
    /// None.
    pub const ZERO: Self = Self {
        yaw: 0.0,
        pitch: 0.0,
        roll: 0.0,
    };

    /// The camera's turn about the vertical, radians, counter-clockwise seen from above: the
    /// yaw and the roll's share, `yaw_per_roll` a radian of it (the mount's
    /// [`crate::projection::Mount::yaw_per_roll`]).
    pub fn turn_rad(&self, yaw_per_roll: f32) -> f32 {
        self.yaw + yaw_per_roll * self.roll
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

    /// A frame's road plane: the body's pitch and roll to it (the travel along the chord).
    fn road(pitch_rad: f32, roll_rad: f32) -> Road {
        Road {
            pitch_rad,
            roll_rad,
            azimuth_rad: 0.0,
            distance_m: 0.8,
            azimuth_sd_rad: 0.001,
            pairs: 20,
            rms_px: 0.2,
        }
    }

    #[test]
    fn the_road_s_plane_measures_the_roll_and_on_road_alone_the_pitch_and_the_yaw() {
        // A mount file rolled 1 deg too far left side up, pitched 0.5 deg too far down and
        // turned 0.3 deg too far right: the road's plane is seen rolled -1 deg and pitched +0.5
        // deg, +-0.5 deg a frame as the body sways, and the travel 0.3 deg right of the chord,
        // as much. Half-way the mount is turned by the applied estimates, which the plane then
        // shows less of.
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(13u32);
        let mut applied = Angles::ZERO;
        for k in 0..400 {
            if k == 200 {
                c.drive(200.0);
                applied.pitch = c.applied_pitch_rad();
                applied.roll = c.applied_roll_rad();
                applied.yaw = c.applied_yaw_rad(0.0);
                assert!(
                    applied.roll < deg(-0.9) && applied.roll > deg(-1.1),
                    "{c:?}"
                );
                assert!(
                    applied.pitch > deg(0.4) && applied.pitch < deg(0.6),
                    "{c:?}"
                );
                assert!(applied.yaw > deg(0.2) && applied.yaw < deg(0.4), "{c:?}");
            }
            let mut sway = |amplitude_deg: f32| deg(amplitude_deg) * (next() - 0.5);
            let seen = Road {
                azimuth_rad: applied.yaw - deg(0.3) + sway(1.0),
                ..road(
                    deg(0.5) - applied.pitch + sway(1.0),
                    deg(-1.0) - applied.roll + sway(1.0),
                )
            };
            c.measure_road(&seen, (0.8, 0.0), (applied, 0.0), (true, true, true));
        }
        let (pitch, roll, yaw) = (c.pitch().unwrap(), c.roll().unwrap(), c.yaw(0.0).unwrap());
        assert!((pitch.rad - deg(0.5)).abs() < deg(0.05), "{c:?}");
        assert!((roll.rad + deg(1.0)).abs() < deg(0.05), "{c:?}");
        assert!((yaw.rad - deg(0.3)).abs() < deg(0.05), "{c:?}");
        assert_eq!(c.pitch_image, Learned::NONE);
        assert_eq!(c.yaw_ground, Learned::NONE);
        // A frame that sees beyond the road leaves the pitch and the yaw to the image's
        // direction of travel; with `learn_roll` off the roll stands.
        let before = c;
        let far_road = road(deg(3.0), deg(3.0));
        c.measure_road(&far_road, (0.8, 0.0), (applied, 0.0), (false, false, false));
        assert_eq!(c, before);
    }

    #[test]
    fn a_pitched_camera_s_roll_turns_it_and_the_yaw_learned_before_the_roll_stays_good() {
        // The paper's rig, pitched 20 deg down, its mount file rolled 1 deg too far left side
        // up and its yaw right: the camera looks sin(20 deg) of a degree further left than the
        // file says, and the road's travel shows it so until the roll is learned. Then the
        // mount is turned by the applied estimates: the roll, and no yaw.
        let yaw_per_roll = libm::sinf(deg(-20.0));
        let true_turn = yaw_per_roll * deg(-1.0);
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(29u32);
        let mut applied = Angles::ZERO;
        for k in 0..400 {
            if k == 200 {
                c.drive(200.0);
                applied.roll = c.applied_roll_rad();
                applied.yaw = c.applied_yaw_rad(yaw_per_roll);
                assert!((applied.roll + deg(1.0)).abs() < deg(0.1), "{c:?}");
                assert!(applied.yaw.abs() < deg(0.05), "{applied:?}");
            }
            let mut sway = |amplitude_deg: f32| deg(amplitude_deg) * (next() - 0.5);
            let seen = Road {
                azimuth_rad: applied.turn_rad(yaw_per_roll) - true_turn + sway(1.0),
                ..road(sway(1.0), deg(-1.0) - applied.roll + sway(1.0))
            };
            let takes = (false, true, true);
            c.measure_road(&seen, (0.8, 0.0), (applied, yaw_per_roll), takes);
        }
        let turn = c.turn().unwrap();
        assert!((turn.rad - true_turn).abs() < deg(0.05), "{c:?}");
        assert!(c.yaw(yaw_per_roll).unwrap().rad.abs() < deg(0.05), "{c:?}");
        // Read without the roll's share, the same evidence is a third of a degree of yaw.
        assert!(
            (c.yaw(0.0).unwrap().rad - true_turn).abs() < deg(0.05),
            "{c:?}"
        );
        // With no turn measured (`learn_yaw` off) the mount file's yaw stands.
        let rolled_only = Calibration {
            yaw_ground: Learned::NONE,
            yaw_image: Learned::NONE,
            ..c
        };
        assert!(
            rolled_only.applied_roll_rad() < deg(-0.9),
            "{rolled_only:?}"
        );
        assert_eq!(rolled_only.applied_yaw_rad(yaw_per_roll), 0.0);
    }

    #[test]
    fn the_roll_is_the_road_s_at_no_lateral_acceleration() {
        // A mount rolled 0.5 deg; the body leans 0.4 deg out of a bend per m/s^2 (right bends:
        // negative acceleration, left side down). Bends of one way only: the lean cannot be told
        // from the mount, and the estimate's standard error says so, which keeps it unapplied.
        let lean = |a: f32| deg(0.5) + deg(0.4) * a;
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(17u32);
        c.drive(100.0);
        for _ in 0..60 {
            let a = -3.8 + 0.2 * (next() - 0.5);
            let seen = road(0.0, lean(a) + deg(0.2) * (next() - 0.5));
            c.measure_road(&seen, (1.0, a), (Angles::ZERO, 0.0), (false, true, false));
        }
        let one_way = c.roll().unwrap();
        assert!(one_way.sd_rad > deg(1.0), "{one_way:?}");
        assert_eq!(c.applied_roll_rad(), 0.0);
        // Then straight road and the other way: the line through them meets the mount's roll.
        for k in 0..300 {
            let a = [0.0, 2.5, -1.0][k % 3] + 0.2 * (next() - 0.5);
            let seen = road(0.0, lean(a) + deg(0.2) * (next() - 0.5));
            c.measure_road(&seen, (1.0, a), (Angles::ZERO, 0.0), (false, true, false));
        }
        let r = c.roll().unwrap();
        assert!((r.rad - deg(0.5)).abs() < deg(0.05), "{r:?} {c:?}");
        assert!(r.sd_rad < deg(0.05), "{r:?}");
        assert!(
            (c.roll.slope(ROLL_LOAD_VAR) - deg(0.4)).abs() < deg(0.05),
            "{c:?}"
        );
        assert_eq!(c.pitch(), None);
    }

    #[test]
    fn noisy_frames_settle_on_their_mean_and_an_outlier_moves_it_little() {
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(5u32);
        // A mount file's yaw 1 deg too far left: the vehicle steps left of the chord by 1 deg
        // of each 0.9 m, +-2 deg a frame.
        for _ in 0..1000 {
            let yaw = deg(1.0) + deg(4.0) * (next() - 0.5);
            c.drive(0.9);
            c.measure_yaw(step(yaw * 0.9), 0.9, 0.0);
        }
        let err = (c.yaw_ground.rad + deg(1.0)).to_degrees();
        assert!(err.abs() < 0.1, "{c:?}");
        assert!(c.settled() && (c.distance_m - 900.0).abs() < 0.1, "{c:?}");
        let sd = c.yaw_ground.sd_rad().unwrap().to_degrees();
        assert!(sd > 0.02 && sd < 0.1, "{sd}");
        let before = c.yaw_ground.rad;
        c.measure_yaw(step(deg(-30.0) * 0.9), 0.9, 0.0);
        assert!((c.yaw_ground.rad - before).abs() < deg(0.01), "{c:?}");
        assert_eq!(c.pitch(), None);
        assert_eq!(c.roll(), None);
    }

    #[test]
    fn measurements_through_an_applied_yaw_are_taken_against_the_file() {
        // The mount already turned by -1 deg: a frame with no step across says -1 deg.
        let mut c = Calibration::NONE;
        for _ in 0..200 {
            c.measure_yaw(step(0.0), 1.0, deg(-1.0));
        }
        assert!((c.yaw_ground.rad - deg(-1.0)).abs() < deg(0.01), "{c:?}");
        // Frames at a crawl are left out.
        let weight = c.yaw_ground.weight;
        c.measure_yaw(step(0.5), 0.01, 0.0);
        assert_eq!(c.yaw_ground.weight, weight);
    }

    #[test]
    fn the_pitch_is_the_mount_s_less_the_direction_of_travel_s_elevation() {
        // A mount file's pitch 1 deg too far down: the travel is seen 1 deg below the file's
        // horizontal, +-0.5 deg a frame as the body pitches; half-way, the mount turned up by
        // the estimate shrunk by its signal to noise, which raises the elevation seen by as much.
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(7u32);
        let mut applied = 0.0;
        for k in 0..400 {
            if k == 200 {
                c.drive(200.0);
                applied = c.applied_pitch_rad();
                let e = c.pitch().unwrap();
                assert!(applied > deg(0.9) && applied < e.rad, "{c:?}");
                let expected = e.rad - e.sd_rad * e.sd_rad / e.rad;
                assert!((applied - expected).abs() < 1e-7, "{applied} {expected}");
            }
            let elevation = applied - deg(1.0) + deg(1.0) * (next() - 0.5);
            c.measure_pitch(elevation, 0.8, applied);
        }
        assert!((c.pitch_image.rad - deg(1.0)).abs() < deg(0.05), "{c:?}");
        assert!(c.pitch_image.sd_rad().unwrap() < deg(0.05), "{c:?}");
        assert_eq!(c.yaw(0.0), None);
        // Not settled (no road counted): nothing applied.
        assert_eq!(
            Calibration {
                distance_m: 0.0,
                ..c
            }
            .applied_pitch_rad(),
            0.0
        );
    }

    #[test]
    fn an_estimate_just_begun_does_not_outweigh_one_of_many_frames() {
        // 300 frames of the image's pitch at +1 deg, +-0.5 deg a frame; then the first frame
        // that sees nothing but road reads -2 deg. Its own spread is none, but one frame tells
        // nothing of the next one's: the pitch moves by its share of the frames (taken at its
        // own spread of 0.1 deg, it moved by a tenth of the gap, 0.3 deg).
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(11u32);
        for _ in 0..300 {
            c.measure_pitch(-deg(1.0) + deg(1.0) * (next() - 0.5), 0.8, 0.0);
        }
        let before = c.pitch().unwrap();
        let pitch_only = (true, false, false);
        let level = (Angles::default(), 0.0);
        c.measure_road(&road(deg(-2.0), 0.0), (0.8, 0.0), level, pitch_only);
        let first = c.pitch_road.estimate().unwrap();
        assert!(first.sd_rad >= START_SPREAD_RAD, "{first:?}");
        let after = c.pitch().unwrap();
        assert!(
            (after.rad - before.rad).abs() < deg(0.01),
            "{before:?} {after:?}"
        );
        // Past its first frames the floor is gone: the standard error falls under what the
        // assumed spread would give its frames (the running spread still carries some of it).
        let frames = 2 * WARM_FRAMES as usize;
        for _ in 0..frames {
            let pitch = deg(-2.0) + deg(0.2) * (next() - 0.5);
            c.measure_road(&road(pitch, 0.0), (0.8, 0.0), level, pitch_only);
        }
        let warm = c.pitch_road.estimate().unwrap();
        let floor = START_SPREAD_RAD / libm::sqrtf(frames as f32 + 1.0);
        assert!(warm.sd_rad < 0.8 * floor, "{warm:?} {floor}");
    }

    #[test]
    fn the_image_s_yaw_is_the_mount_s_less_the_direction_of_travel_s_azimuth() {
        // A camera looking 0.5 deg further left than its mount file says sees the travel 0.5
        // deg right of the chord; through a mount already turned by +0.2 deg, 0.3 deg right.
        let mut c = Calibration::NONE;
        for k in 0..200 {
            let applied = if k < 100 { 0.0 } else { deg(0.2) };
            c.measure_yaw_image(applied - deg(0.5), 0.8, applied);
        }
        assert!((c.yaw_image.rad - deg(0.5)).abs() < deg(0.001), "{c:?}");
        assert_eq!(c.yaw_ground, Learned::NONE);
        assert_eq!(c.yaw(0.0).map(|e| e.rad), Some(c.yaw_image.rad));
    }

    #[test]
    fn the_yaw_weighs_the_ground_s_and_the_image_s_by_their_variances() {
        assert_eq!(Calibration::NONE.yaw(0.0), None);
        // The ground's steps say +0.5 deg, +-2 deg a frame; the image's direction of travel
        // -0.3 deg, +-0.3 deg a frame: the image's estimate is the tighter and mostly stands.
        let mut c = Calibration::NONE;
        let mut next = crate::test_rng::uniform(11u32);
        for _ in 0..400 {
            c.drive(0.8);
            let ground = deg(0.5) + deg(4.0) * (next() - 0.5);
            c.measure_yaw(step(-ground * 0.8), 0.8, 0.0);
            let image = deg(-0.3) + deg(0.6) * (next() - 0.5);
            c.measure_yaw_image(-image, 0.8, 0.0);
        }
        let (g, i) = (
            c.yaw_ground.estimate().unwrap(),
            c.yaw_image.estimate().unwrap(),
        );
        let y = c.yaw(0.0).unwrap();
        assert!((g.rad - deg(0.5)).abs() < 3.0 * g.sd_rad, "{g:?}");
        assert!((i.rad - deg(-0.3)).abs() < 3.0 * i.sd_rad, "{i:?}");
        assert!(
            y.sd_rad < i.sd_rad && i.sd_rad < g.sd_rad,
            "{y:?} {i:?} {g:?}"
        );
        // Between the two, nearer the image's by the ratio of their variances.
        let share = (y.rad - i.rad) / (g.rad - i.rad);
        let expected = i.sd_rad * i.sd_rad / (i.sd_rad * i.sd_rad + g.sd_rad * g.sd_rad);
        assert!((share - expected).abs() < 1e-3, "{share} {expected}");
        assert!(share > 0.0 && share < 0.2, "{share}");
        // The applied yaw is the weighed estimate shrunk by its signal to noise.
        assert!(y.rad.abs() > y.sd_rad, "{y:?}");
        let expected = y.rad - y.sd_rad * y.sd_rad / y.rad;
        assert!((c.applied_yaw_rad(0.0) - expected).abs() < 1e-7, "{c:?}");
        // Within a standard error of the mount file's, nothing is applied.
        let within = Calibration {
            yaw_image: Learned {
                rad: 0.5 * y.sd_rad,
                ..c.yaw_image
            },
            yaw_ground: Learned {
                rad: 0.5 * y.sd_rad,
                ..c.yaw_ground
            },
            ..c
        };
        assert_eq!(within.applied_yaw_rad(0.0), 0.0, "{:?}", within.yaw(0.0));
    }

    #[test]
    fn the_swing_in_bends_moves_the_camera_and_straight_road_leaves_it() {
        let mut next = crate::test_rng::uniform(5u32);
        // The camera 0.2 m further ahead of the axle than the file says, the yaw 0.3 deg off:
        // the direction of travel leaves the chord by the yaw and by the swing of what the
        // camera as moved so far still lacks, where a metre swings it by `share` of the
        // curvature (how well the frame's pairs tell the travel from the turn).
        let frame =
            |c: &mut Calibration, curvature: f32, share: f32, next: &mut dyn FnMut() -> f32| {
                let applied_m = c.applied_x_m();
                let swing = share * curvature;
                let seen = deg(0.3) + (0.2 - applied_m) * swing + deg(0.5) * (next() - 0.5);
                c.drive(0.8);
                c.measure_x_ahead((seen, swing), None, 0.8, applied_m);
            };
        let mut straight = Calibration::NONE;
        for _ in 0..300 {
            frame(&mut straight, 0.002 * (next() - 0.5), 1.0, &mut next);
        }
        assert_eq!(straight.x_ahead(), None);
        assert_eq!(straight.applied_x_m(), 0.0);
        // Bends of 20 m radius both ways between straights, each frame's direction showing all
        // or half of the swing.
        let bends = |k: usize| [0.0, 0.05, 0.0, -0.05][(k / 20) % 4];
        for share in [1.0, 0.5] {
            let mut c = Calibration::NONE;
            for k in 0..600 {
                frame(&mut c, bends(k), share, &mut next);
            }
            let (x, sd) = c.x_ahead().unwrap();
            assert!(
                (x - 0.2).abs() < 0.02 && sd < 0.02,
                "{share}: {x} {sd} {c:?}"
            );
            assert!((c.applied_x_m() - (x - sd * sd / x)).abs() < 1e-6);
            // The line's intercept is the yaw.
            let yaw = c.swing.estimate(SWING_VAR).unwrap();
            assert!((yaw.rad - deg(0.3)).abs() < deg(0.02), "{yaw:?}");
        }
    }

    #[test]
    fn road_frames_that_hold_their_direction_less_well_than_the_line_are_left_out() {
        // The road's plane tells the camera 0.2 m further ahead, each frame to 0.1 deg, in
        // bends both ways; frames of one bend in four read it 1 m off and say that they hold
        // their direction to 2 deg only: they are left out, and the line is the precise
        // frames' alone. Taken at face value they pull it past 0.3 m.
        let mut next = crate::test_rng::uniform(9u32);
        let bends = |k: usize| [0.0, 0.05, 0.0, -0.05][(k / 20) % 4];
        let run = |told_sd: bool, next: &mut dyn FnMut() -> f32| {
            let mut c = Calibration::NONE;
            for k in 0..600 {
                let swing = bends(k);
                let (x, sd) = if k % 80 >= 20 && k % 80 < 40 {
                    (1.0, deg(2.0))
                } else {
                    (0.2, deg(0.1))
                };
                let seen = x * swing + sd * (next() - 0.5);
                c.drive(0.8);
                c.measure_x_ahead((seen, swing), told_sd.then_some(sd), 0.8, 0.0);
            }
            c.x_ahead().unwrap().0
        };
        let gated = run(true, &mut next);
        let ungated = run(false, &mut next);
        assert!((gated - 0.2).abs() < 0.03, "{gated} {ungated}");
        assert!(ungated > 0.3, "{gated} {ungated}");
    }

    #[test]
    fn saved_bytes_come_back_and_damaged_ones_are_refused() {
        let mut c = Calibration::NONE;
        for k in 0..50 {
            c.drive(0.8);
            c.measure_yaw(step(0.01 * (k % 3) as f32), 0.8, 0.0);
            c.measure_yaw_image(deg(0.2) * (k % 4) as f32, 0.8, 0.0);
            c.measure_pitch(deg(0.1) * (k % 5) as f32, 0.8, 0.0);
            let turn = (0.02 * ((k % 5) as f32 - 2.0), 0.8);
            c.measure_x_ahead(
                (deg(0.1) * (k % 3) as f32, turn.0 / turn.1),
                None,
                0.8,
                0.05,
            );
            let road = road(deg(-0.1) * (k % 6) as f32, deg(0.05) * (k % 7) as f32);
            c.measure_road(
                &road,
                (0.8, 0.1 * (k % 9) as f32),
                (Angles::ZERO, 0.0),
                (true, true, true),
            );
        }
        let bytes = c.to_bytes();
        assert_eq!(Calibration::from_bytes(&bytes), Ok(c));
        assert_eq!(
            Calibration::from_bytes(&bytes[..Calibration::BYTES - 1]),
            Err(CalibrationError::WrongLength)
        );
        let mut other = bytes;
        other[0] = b'x';
        assert_eq!(
            Calibration::from_bytes(&other),
            Err(CalibrationError::WrongMagic)
        );
        // The previous version's bytes, laid out alike but with the yaw where these hold the
        // camera's turn, are refused rather than read as the turn.
        let mut previous = bytes;
        previous[..4].copy_from_slice(b"rvc5");
        assert_eq!(
            Calibration::from_bytes(&previous),
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
        for wild in [
            Calibration {
                yaw_image: Learned {
                    rad: 1.0,
                    ..c.yaw_image
                },
                ..c
            },
            Calibration {
                roll: LearnedLine {
                    load_var: -1.0,
                    ..c.roll
                },
                ..c
            },
            Calibration {
                swing: LearnedLine {
                    mean_load: f32::INFINITY,
                    ..c.swing
                },
                ..c
            },
        ] {
            assert_eq!(
                Calibration::from_bytes(&wild.to_bytes()),
                Err(CalibrationError::OutOfRange)
            );
        }
    }
}
