//! The odometer's settings, checked once: [`Config::validate`] turns a [`Config`] into a
//! [`ValidConfig`] holding everything derived from it (homographies, the image region of
//! interest), so that no invalid setting and no per-config computation reaches the per-frame path.

use crate::motion::CameraLift;
use crate::projection::{
    Attitude, GroundPoint, GroundProjection, Homography, Intrinsics, Mount, RollMap,
};
use core::fmt;

/// Size of the camera's frames, pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageSize {
    /// Columns, pixels.
    pub width_px: u16,
    /// Rows, pixels.
    pub height_px: u16,
}

impl ImageSize {
    /// No pixels: a placeholder (an empty image does not validate).
    pub const ZERO: Self = Self {
        width_px: 0,
        height_px: 0,
    };
}

/// Limits of how fast the driver can change the motion (paper §2.2).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Dynamics {
    /// Largest angular acceleration of the heading, rad/s^2 (paper: 10 deg/s^2, which covers 92% of
    /// 22 km of driving).
    pub max_heading_accel_rad_s2: f32,
    /// Largest longitudinal acceleration or deceleration, m/s^2 (paper: 1.5 m/s^2).
    pub max_longitudinal_accel_m_s2: f32,
}

/// The window of road in which features are detected (paper §4, Figure 14), on the ground, in
/// the camera's look direction: distances are measured from the point on the road under the
/// camera, along the camera's yaw, so the same window works for rear-facing cameras.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GroundWindow {
    /// Near cutoff, metres ahead of the camera; 0 means where the image ends.
    pub near_m: f32,
    /// Far cutoff, metres ahead of the camera (paper, KITTI: 12 m).
    pub far_m: f32,
    /// Lateral cutoff each side of the look direction, metres (paper, KITTI: 3 m).
    pub half_width_m: f32,
}

/// Which estimator turns matched features into motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// The default: a joint vote over the frame's pitch, heading change and distance, each
    /// feature backprojected exactly per pitch hypothesis (see the `pitch_vote` module).
    #[default]
    PitchVote,
    /// The paper's §2 as written: observation and prediction quadrilaterals, overlap matching,
    /// a vote over the dynamics patch, centre of gravity above 70% of the peak.
    Paper,
}

/// Settings of the default method's vote (BRIEF §7).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PitchVoteSettings {
    /// Body pitch hypotheses span +- this, radians (1 deg).
    pub pitch_range_rad: f32,
    /// Number of pitch hypotheses, odd so that level is one of them (21: 0.1 deg steps); at
    /// most [`MAX_PITCH_HYPOTHESES`].
    pub pitch_steps: u8,
    /// Largest change of body pitch between two frames, in pitch steps (5: 0.5 deg, the
    /// suspension's +-0.5 deg at 1.5 Hz changes by up to 0.47 deg in 0.1 s).
    pub max_pitch_change_steps: u8,
    /// Half width of the heading-change window around the previous motion, radians per frame
    /// (1 deg): wide enough to see real changes, unlike the paper's 0.1 deg patch.
    pub heading_half_rad: f32,
    /// Half width of the distance window around the previous motion, metres per frame (0.15 m:
    /// 15 m/s^2 at 10 frames/s, beyond any braking). BRIEF §7's prototype used 0.3 m; over the
    /// synthetic acceptance drives (three seeds) that let a car holding its distance ahead, whose
    /// corners vote for no motion, pull the estimate to a stop (13% against 3.2% with 0.15 m),
    /// and it was noisier under suspension motion (kitti-like: 3.0-6.0% against 2.6-3.9%).
    pub distance_half_m: f32,
    /// Largest lateral residual of a track and an observation that still votes, metres (4 cm).
    pub lateral_tolerance_m: f32,
    /// Standard deviation of a corner's row, pixels (0.5; 0: one bin a pair). A pair votes for
    /// the distances its two corners' rows allow: a tent two standard deviations wide each side
    /// (a row is 12 cm of range at KITTI's 12 m), not one bin, which would ask far corners for a
    /// precision they lack.
    pub corner_sigma_px: f32,
    /// Body roll hypotheses span +- this, radians (1.4 deg: a swing of +-1 deg and a margin;
    /// +-2 deg let the estimate wander further, measured on the kitti-like drives).
    pub roll_range_rad: f32,
    /// Number of roll hypotheses, odd so that level is one of them (15: 0.2 deg steps); at most
    /// [`MAX_ROLL_HYPOTHESES`]. 1 turns the roll search off.
    pub roll_steps: u8,
    /// Largest change of body roll between two frames, in roll steps (3: 0.6 deg; a +-1 deg
    /// roll at 1.2 Hz changes by up to 0.75 deg in 0.1 s).
    pub max_roll_change_steps: u8,
    /// Share of each frame's measured common pitch error (the slope of matched distances
    /// against range, see [`crate::pitch_vote`]) that moves both frames' pitch (0.2).
    pub absolute_gain: f32,
    /// Time constant with which the body pitch estimate returns to level, seconds (0.5; 0:
    /// never). The body's attitude on its suspension is a damped oscillation about level with a
    /// period near a second; an offset that lasts longer is the estimate's drift. A vehicle
    /// whose pitch holds an offset for seconds (on a climb, loaded, a camera re-mounted) wants
    /// 0 with `max_pitch_change_steps` 0: its pitch then follows the absolute measurement alone
    /// (see [`crate::pitch_vote`], "Vehicles").
    pub pitch_settle_s: f32,
    /// Time constant with which the body roll estimate returns to level, seconds (0.5; 0:
    /// never); see `pitch_settle_s`.
    pub roll_settle_s: f32,
    /// How many matched tracks the previous motion weighs as against a frame's vote (3; 0: the
    /// vote alone). Each matched track is one measurement of the motion and the previous motion
    /// a prediction: a vote most tracks support (30 to 50 on the kitti-like drives) moves the
    /// estimate nearly all the way, one that a vehicle ahead hiding the road leaves to a handful
    /// moves it part of the way (see [`crate::pitch_vote`], "Weighing").
    pub prior_matches: f32,
    /// Where the vehicle's arc is drawn from: a pivot this many s^2/m times the speed squared
    /// ahead of the rear-axle centre (0: the rear axle, the paper's Ackermann model). A car's
    /// rear tyres slip outwards in a bend as they carry its side force, so the point that
    /// moves along the arc is not the rear axle but one ahead of it, by
    /// `mass * (front axle to centre of mass) / (wheelbase * rear cornering stiffness) * v^2`
    /// (the linear single-track model; 0.003 to 0.007 s^2/m for a mid-size car, 0.4 m at
    /// 40 km/h). An arc drawn from the rear axle turns that sideways slip into a turn too small
    /// (see [`crate::pitch_vote`], step 3). A property of the vehicle, like the mount.
    pub pivot_s2_per_m: f32,
    /// Whether the heading comes from the matched pairs' residuals across the chord alone
    /// (false). The vote's heading also answers to the distances along it, since a turn moves
    /// the two sides' points by opposite amounts along the vehicle: where the two sides'
    /// distances disagree for another reason (a roll estimate off, a kerb, a crowned or sloped
    /// side) the vote turns that into a heading. With this set, the heading is refined after
    /// matching so that the pairs' residuals across the chord balance (least squares over the
    /// matched pairs, see [`crate::pitch_vote`], step 5), and the distance stays the vote's.
    pub refine_heading: bool,
    /// Heading window half width with no previous motion, radians (4 deg: 40 deg/s at 10 frames/s;
    /// KITTI 01 starts in a bend at 2.5 deg a frame).
    pub startup_heading_half_rad: f32,
    /// Distance window upper end with no previous motion, metres per frame (2.6 m: 94 km/h at
    /// 10 frames/s); the lower end is 0.
    pub startup_distance_max_m: f32,
}

impl Default for PitchVoteSettings {
    /// BRIEF §7's prototype (21 pitches over +-1 deg, a +-1 deg window, 4 cm), with a narrower
    /// distance window (see `distance_half_m`), distance tents for 0.5 px corners and a pitch
    /// that settles to level in 0.5 s (see [`crate::pitch_vote`]).
    fn default() -> Self {
        const DEG: f32 = core::f32::consts::PI / 180.0;
        Self {
            pitch_range_rad: 1.0 * DEG,
            pitch_steps: 21,
            max_pitch_change_steps: 5,
            heading_half_rad: 1.0 * DEG,
            distance_half_m: 0.15,
            lateral_tolerance_m: 0.04,
            corner_sigma_px: 0.5,
            roll_range_rad: 1.4 * DEG,
            roll_steps: 15,
            max_roll_change_steps: 3,
            absolute_gain: 0.2,
            pitch_settle_s: 0.5,
            roll_settle_s: 0.5,
            prior_matches: 3.0,
            refine_heading: false,
            pivot_s2_per_m: 0.0,
            startup_heading_half_rad: 4.0 * DEG,
            startup_distance_max_m: 2.6,
        }
    }
}

/// Most pitch hypotheses the default method may use.
pub const MAX_PITCH_HYPOTHESES: usize = 31;
/// Most roll hypotheses the default method may use.
pub const MAX_ROLL_HYPOTHESES: usize = 15;

/// Everything the odometer needs to know, in physical units. Build one, then
/// [`validate`](Config::validate) it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Frame size the odometer expects.
    pub image: ImageSize,
    /// Camera intrinsics.
    pub intrinsics: Intrinsics,
    /// Camera extrinsics on the vehicle.
    pub mount: Mount,
    /// Bounds of the body attitude on its suspension, each side of level (paper §2.1, town
    /// driving: pitch 1 deg, roll 2 deg).
    pub attitude_bounds: Attitude,
    /// Limits on the change of motion between frames.
    pub dynamics: Dynamics,
    /// Where on the road features are looked for.
    pub window: GroundWindow,
    /// Corners kept on each side of straight ahead (paper: 32).
    pub features_per_side: u16,
    /// Frames a track may go unmatched before it is dropped (paper: 3 to 5).
    pub track_max_misses: u8,
    /// Which estimator to run.
    pub method: Method,
    /// The default method's vote.
    pub pitch_vote: PitchVoteSettings,
    /// Below this ratio of matched tracks to detected features the frame falls back to the
    /// previous motion (paper §5: 1/8).
    pub min_inlier_ratio: f32,
    /// Smallest Harris response a corner needs, in units of (Sobel gradient)^4 / 2^16; 2000 is
    /// about a 25-grey-level step at a right-angled corner. Sensor noise of 2 grey levels scores
    /// under 10.
    pub corner_threshold: u32,
}

/// Largest attitude bound accepted, radians (10 deg, the paper's theoretical roll limit).
const MAX_ATTITUDE_BOUND_RAD: f32 = 10.0 * core::f32::consts::PI / 180.0;

/// Smallest width and height of the image region of interest, pixels.
pub const MIN_ROI_PX: u16 = 8;

/// Why a [`Config`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// A number is NaN or infinite; `field` names it.
    NonFinite {
        /// The setting, as `section.name`.
        field: &'static str,
    },
    /// Width or height of the image is zero.
    EmptyImage,
    /// A focal length is zero or negative.
    FocalLengthNotPositive,
    /// The camera is at or below the road (`mount.height_m <= 0`).
    CameraNotAboveGround,
    /// An attitude bound is negative or above 10 deg.
    AttitudeBoundOutOfRange {
        /// The setting, as `section.name`.
        field: &'static str,
    },
    /// A dynamics limit is zero or negative.
    DynamicsNotPositive {
        /// The setting, as `section.name`.
        field: &'static str,
    },
    /// The ground window is empty: near cutoff negative, far cutoff not beyond it, or a lateral
    /// cutoff that is not positive.
    EmptyWindow,
    /// The camera sees the road plane edge-on, so no homography exists.
    DegenerateGeometry,
    /// The far end of the ground window is not in the image (behind the camera, above the horizon
    /// under the attitude bounds, or outside the frame).
    RoiOutsideImage,
    /// The ground window's image is narrower or shorter than [`MIN_ROI_PX`] pixels: too few to
    /// find corners in.
    RoiTooSmall,
    /// A setting of the default method's vote is out of range; `field` names it.
    PitchVoteOutOfRange {
        /// The setting, as `section.name`.
        field: &'static str,
    },
    /// A ratio is outside 0 to 1; `field` names it.
    RatioOutOfRange {
        /// The setting, as `section.name`.
        field: &'static str,
    },
    /// A setting asks for more than the odometer's capacity (a const generic parameter).
    ExceedsCapacity {
        /// The setting, as `section.name`.
        field: &'static str,
    },
    /// A count that sizes the work is zero.
    ZeroCount {
        /// The setting, as `section.name`.
        field: &'static str,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite { field } => write!(f, "{field} is not a finite number"),
            Self::EmptyImage => f.write_str("image width and height must be at least 1 pixel"),
            Self::FocalLengthNotPositive => f.write_str("focal lengths must be positive"),
            Self::CameraNotAboveGround => {
                f.write_str("the camera must be above the road (height_m > 0)")
            }
            Self::AttitudeBoundOutOfRange { field } => {
                write!(f, "{field} must be between 0 and 10 degrees")
            }
            Self::DynamicsNotPositive { field } => write!(f, "{field} must be positive"),
            Self::EmptyWindow => f.write_str(
                "the ground window is empty: need 0 <= near_m < far_m and half_width_m > 0",
            ),
            Self::DegenerateGeometry => f.write_str("the camera sees the road plane edge-on"),
            Self::RoiOutsideImage => f.write_str(
                "the far end of the ground window is not visible in the image \
                 (behind the camera, above the horizon, or outside the frame)",
            ),
            Self::RoiTooSmall => write!(
                f,
                "the ground window covers less than {MIN_ROI_PX}x{MIN_ROI_PX} pixels of the image"
            ),
            Self::ZeroCount { field } => write!(f, "{field} must be at least 1"),
            Self::PitchVoteOutOfRange { field } => write!(
                f,
                "{field} is out of range (pitch_steps odd, 1 to {MAX_PITCH_HYPOTHESES}; \
                 roll_steps odd, 1 to {MAX_ROLL_HYPOTHESES}; angles and distances positive)"
            ),
            Self::RatioOutOfRange { field } => write!(f, "{field} must be between 0 and 1"),
            Self::ExceedsCapacity { field } => {
                write!(f, "{field} exceeds the odometer's capacity")
            }
        }
    }
}

impl core::error::Error for ConfigError {}

/// The image rectangle that holds the ground window, pixels, inclusive bounds. Detection reads
/// only these rows and columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageRoi {
    /// First column.
    pub left_px: u16,
    /// Last column.
    pub right_px: u16,
    /// First row (the far cutoff).
    pub top_px: u16,
    /// Last row (the near cutoff or the image's bottom).
    pub bottom_px: u16,
}

/// Body pitch of hypothesis `i` of the default method's vote, radians: evenly spaced over
/// +-`pitch_range_rad`, level in the middle.
pub fn pitch_hypothesis_rad(pv: &PitchVoteSettings, i: usize) -> f32 {
    hypothesis_rad(pv.pitch_range_rad, pv.pitch_steps, i)
}

/// Body roll of hypothesis `i` of the default method's vote, radians: evenly spaced over
/// +-`roll_range_rad`, level in the middle.
pub fn roll_hypothesis_rad(pv: &PitchVoteSettings, i: usize) -> f32 {
    hypothesis_rad(pv.roll_range_rad, pv.roll_steps, i)
}

/// Angle of hypothesis `i` of `steps` spread evenly over +-`range_rad`.
fn hypothesis_rad(range_rad: f32, steps: u8, i: usize) -> f32 {
    let half = (usize::from(steps) / 2) as f32;
    if half == 0.0 {
        0.0
    } else {
        range_rad * (i as f32 - half) / half
    }
}

/// A [`Config`] that passed validation, with what is derived from it once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValidConfig {
    config: Config,
    projection: GroundProjection,
    /// Homographies of the default method's pitch hypotheses (the first `pitch_steps` are set).
    pitch_fan: [Homography; MAX_PITCH_HYPOTHESES],
    roll_fan: [RollMap; MAX_ROLL_HYPOTHESES],
    lift: CameraLift,
    roi: ImageRoi,
    /// The ground window's image, clipped to the frame (pixels): [`Self::roi`] is its bounding
    /// rectangle, [`Self::roi_rows`] its rows under a band of columns.
    roi_image: Polygon,
}

impl ValidConfig {
    /// No configuration, all zeros (a 0x0 frame, no geometry): the placeholder of an
    /// unconfigured odometer, so that one can be a zero-initialised `static`. Validation never
    /// produces it (a valid frame has pixels).
    pub(crate) const UNSET: Self = {
        let zero_attitude = Attitude {
            pitch_rad: 0.0,
            roll_rad: 0.0,
        };
        Self {
            config: Config {
                image: ImageSize::ZERO,
                intrinsics: Intrinsics::ZERO,
                mount: Mount::ZERO,
                attitude_bounds: zero_attitude,
                dynamics: Dynamics {
                    max_heading_accel_rad_s2: 0.0,
                    max_longitudinal_accel_m_s2: 0.0,
                },
                window: GroundWindow {
                    near_m: 0.0,
                    far_m: 0.0,
                    half_width_m: 0.0,
                },
                features_per_side: 0,
                track_max_misses: 0,
                method: Method::PitchVote,
                pitch_vote: PitchVoteSettings {
                    pitch_range_rad: 0.0,
                    pitch_steps: 0,
                    max_pitch_change_steps: 0,
                    heading_half_rad: 0.0,
                    distance_half_m: 0.0,
                    lateral_tolerance_m: 0.0,
                    corner_sigma_px: 0.0,
                    roll_range_rad: 0.0,
                    roll_steps: 0,
                    max_roll_change_steps: 0,
                    absolute_gain: 0.0,
                    pitch_settle_s: 0.0,
                    roll_settle_s: 0.0,
                    prior_matches: 0.0,
                    refine_heading: false,
                    pivot_s2_per_m: 0.0,
                    startup_heading_half_rad: 0.0,
                    startup_distance_max_m: 0.0,
                },
                min_inlier_ratio: 0.0,
                corner_threshold: 0,
            },
            projection: GroundProjection {
                nominal: Homography::ZERO,
                extremes: [Homography::ZERO; 4],
            },
            pitch_fan: [Homography::ZERO; MAX_PITCH_HYPOTHESES],
            roll_fan: [RollMap::ZERO; MAX_ROLL_HYPOTHESES],
            lift: CameraLift::ZERO,
            roi: ImageRoi {
                left_px: 0,
                right_px: 0,
                top_px: 0,
                bottom_px: 0,
            },
            roi_image: Polygon::EMPTY,
        }
    };

    /// Whether this is a validated configuration rather than [`Self::UNSET`].
    pub(crate) fn is_set(&self) -> bool {
        self.config.image.width_px != 0
    }

    /// The settings as given.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The nominal and extremal-attitude homographies.
    pub fn projection(&self) -> &GroundProjection {
        &self.projection
    }

    /// The homographies of the default method's pitch hypotheses, in order of pitch.
    pub fn pitch_fan(&self) -> &[Homography] {
        // Validation bounds the steps; `min` shows the compiler the slice cannot fail.
        let n = usize::from(self.config.pitch_vote.pitch_steps).min(MAX_PITCH_HYPOTHESES);
        &self.pitch_fan[..n]
    }

    /// The image maps of the default method's roll hypotheses, in order of roll (see
    /// [`RollMap`]).
    pub fn roll_fan(&self) -> &[RollMap] {
        // Validation bounds the steps; `min` shows the compiler the slice cannot fail.
        let n = usize::from(self.config.pitch_vote.roll_steps).min(MAX_ROLL_HYPOTHESES);
        &self.roll_fan[..n]
    }

    /// Lifts planar poses to KITTI camera poses through the mount.
    pub fn lift(&self) -> &CameraLift {
        &self.lift
    }

    /// The image rectangle holding the ground window.
    pub fn roi(&self) -> ImageRoi {
        self.roi
    }

    /// The rows of the region of interest where a point within a pixel of the columns
    /// `left_px..=right_px` can lie in the ground window's image: the window's image is a
    /// trapezoid, narrower at the far end than its bounding rectangle, so that a band of columns
    /// off the centre holds fewer of its rows. `None` if the band misses the window.
    pub fn roi_rows(&self, left_px: u16, right_px: u16) -> Option<(u16, u16)> {
        let (lo, hi) = (f32::from(left_px) - 1.0, f32::from(right_px) + 1.0);
        let band = self.roi_image.clip(|[u, _]| u - lo).clip(|[u, _]| hi - u);
        let ([_, top], [_, bottom]) = band.bounds()?;
        // A pixel's corner may sit half a pixel off it: one pixel of margin, outwards.
        let top = (libm::floorf(top - 1.0).max(0.0) as u16).max(self.roi.top_px);
        let bottom = (libm::ceilf(bottom + 1.0).max(0.0) as u16).min(self.roi.bottom_px);
        (top <= bottom).then_some((top, bottom))
    }

    /// The rows of each frame the odometer reads (the region of interest and the corner
    /// detector's border): a camera need deliver no others.
    pub fn rows_read(&self) -> core::ops::Range<u16> {
        crate::harris::rows_read(self)
    }

    /// A ground point of the window's own frame (`ahead_m` along the camera's look direction from
    /// the point under the camera, `left_m` to its left) in the vehicle frame.
    pub fn window_point(&self, ahead_m: f32, left_m: f32) -> GroundPoint {
        let m = &self.config.mount;
        let (s, c) = (libm::sinf(m.yaw_rad), libm::cosf(m.yaw_rad));
        GroundPoint {
            x_m: m.x_m + c * ahead_m - s * left_m,
            y_m: m.y_m + s * ahead_m + c * left_m,
        }
    }

    /// A ground point (vehicle frame) in the window's own frame: (metres ahead of the camera
    /// along its look direction, metres to the left of it).
    pub fn window_coords(&self, p: GroundPoint) -> (f32, f32) {
        let m = &self.config.mount;
        let (s, c) = (libm::sinf(m.yaw_rad), libm::cosf(m.yaw_rad));
        let (dx, dy) = (p.x_m - m.x_m, p.y_m - m.y_m);
        (c * dx + s * dy, -s * dx + c * dy)
    }

    /// Whether a ground point (vehicle frame) lies inside the ground window.
    pub fn in_window(&self, p: GroundPoint) -> bool {
        let w = &self.config.window;
        let (ahead, left) = self.window_coords(p);
        ahead >= w.near_m && ahead <= w.far_m && left.abs() <= w.half_width_m
    }
}

impl Config {
    /// A configuration for a camera and its mount, every other setting at its documented
    /// default: the paper's values (attitude bounds 1 and 2 deg, dynamics 10 deg/s^2 and
    /// 1.5 m/s^2, the KITTI window 12 m by +-3 m, 32 corners a side, 5 misses, 1/8 inliers) and
    /// BRIEF §7's for the default method's vote.
    pub fn with_defaults(image: ImageSize, intrinsics: Intrinsics, mount: Mount) -> Self {
        const DEG: f32 = core::f32::consts::PI / 180.0;
        Self {
            image,
            intrinsics,
            mount,
            attitude_bounds: Attitude {
                pitch_rad: 1.0 * DEG,
                roll_rad: 2.0 * DEG,
            },
            dynamics: Dynamics {
                max_heading_accel_rad_s2: 10.0 * DEG,
                max_longitudinal_accel_m_s2: 1.5,
            },
            window: GroundWindow {
                near_m: 0.0,
                far_m: 12.0,
                half_width_m: 3.0,
            },
            features_per_side: 32,
            track_max_misses: 5,
            corner_threshold: 2000,
            method: Method::PitchVote,
            pitch_vote: PitchVoteSettings::default(),
            min_inlier_ratio: 0.125,
        }
    }

    /// Checks every setting and derives the homographies and the image region of interest.
    pub fn validate(self) -> Result<ValidConfig, ConfigError> {
        self.check_finite()?;
        let (k, m, w) = (&self.intrinsics, &self.mount, &self.window);
        if self.image.width_px == 0 || self.image.height_px == 0 {
            return Err(ConfigError::EmptyImage);
        }
        if k.fx_px <= 0.0 || k.fy_px <= 0.0 {
            return Err(ConfigError::FocalLengthNotPositive);
        }
        if m.height_m <= 0.0 {
            return Err(ConfigError::CameraNotAboveGround);
        }
        let bound = |v: f32, field| {
            if (0.0..=MAX_ATTITUDE_BOUND_RAD).contains(&v) {
                Ok(())
            } else {
                Err(ConfigError::AttitudeBoundOutOfRange { field })
            }
        };
        bound(self.attitude_bounds.pitch_rad, "attitude_bounds.pitch_rad")?;
        bound(self.attitude_bounds.roll_rad, "attitude_bounds.roll_rad")?;
        let positive = |v: f32, field| {
            if v > 0.0 {
                Ok(())
            } else {
                Err(ConfigError::DynamicsNotPositive { field })
            }
        };
        positive(
            self.dynamics.max_heading_accel_rad_s2,
            "dynamics.max_heading_accel_rad_s2",
        )?;
        positive(
            self.dynamics.max_longitudinal_accel_m_s2,
            "dynamics.max_longitudinal_accel_m_s2",
        )?;
        if w.near_m < 0.0 || w.far_m <= w.near_m || w.half_width_m <= 0.0 {
            return Err(ConfigError::EmptyWindow);
        }
        if self.features_per_side == 0 {
            return Err(ConfigError::ZeroCount {
                field: "features_per_side",
            });
        }
        if self.track_max_misses == 0 {
            return Err(ConfigError::ZeroCount {
                field: "track_max_misses",
            });
        }
        self.check_pitch_vote()?;
        if !(0.0..=1.0).contains(&self.min_inlier_ratio) {
            return Err(ConfigError::RatioOutOfRange {
                field: "min_inlier_ratio",
            });
        }
        let projection = GroundProjection::new(k, m, self.attitude_bounds)
            .ok_or(ConfigError::DegenerateGeometry)?;
        let mut pitch_fan = [projection.nominal; MAX_PITCH_HYPOTHESES];
        let pv = &self.pitch_vote;
        let steps = usize::from(pv.pitch_steps);
        for (i, h) in pitch_fan.iter_mut().enumerate().take(steps) {
            let pitch_rad = pitch_hypothesis_rad(pv, i);
            let attitude = Attitude {
                pitch_rad,
                roll_rad: 0.0,
            };
            *h = Homography::new(k, m, attitude).ok_or(ConfigError::DegenerateGeometry)?;
        }
        let mut roll_fan = [RollMap::ZERO; MAX_ROLL_HYPOTHESES];
        for (i, map) in roll_fan.iter_mut().enumerate().take(pv.roll_steps.into()) {
            let roll_rad = roll_hypothesis_rad(pv, i);
            *map = RollMap::new(k, m, roll_rad).ok_or(ConfigError::DegenerateGeometry)?;
        }
        let mut valid = ValidConfig {
            config: self,
            projection,
            pitch_fan,
            roll_fan,
            lift: CameraLift::new(m),
            roi: ImageRoi {
                left_px: 0,
                right_px: 0,
                top_px: 0,
                bottom_px: 0,
            },
            roi_image: Polygon::EMPTY,
        };
        let (roi, image) = valid.image_roi().ok_or(ConfigError::RoiOutsideImage)?;
        if roi.right_px - roi.left_px < MIN_ROI_PX || roi.bottom_px - roi.top_px < MIN_ROI_PX {
            return Err(ConfigError::RoiTooSmall);
        }
        valid.roi = roi;
        valid.roi_image = image;
        Ok(valid)
    }

    fn check_pitch_vote(&self) -> Result<(), ConfigError> {
        let pv = &self.pitch_vote;
        let bad = |field| Err(ConfigError::PitchVoteOutOfRange { field });
        // Each fan: an odd number of hypotheses it has room for, over a range of angles.
        let fans = [
            (
                pv.pitch_steps,
                MAX_PITCH_HYPOTHESES,
                "pitch_vote.pitch_steps",
                pv.pitch_range_rad,
                "pitch_vote.pitch_range_rad",
            ),
            (
                pv.roll_steps,
                MAX_ROLL_HYPOTHESES,
                "pitch_vote.roll_steps",
                pv.roll_range_rad,
                "pitch_vote.roll_range_rad",
            ),
        ];
        for (steps, max, steps_field, range_rad, range_field) in fans {
            let steps = usize::from(steps);
            if steps == 0 || steps % 2 == 0 || steps > max {
                return bad(steps_field);
            }
            if !(0.0..=MAX_ATTITUDE_BOUND_RAD).contains(&range_rad) {
                return bad(range_field);
            }
        }
        let positive = [
            (pv.heading_half_rad, "pitch_vote.heading_half_rad"),
            (pv.distance_half_m, "pitch_vote.distance_half_m"),
            (pv.lateral_tolerance_m, "pitch_vote.lateral_tolerance_m"),
            (
                pv.startup_heading_half_rad,
                "pitch_vote.startup_heading_half_rad",
            ),
            (
                pv.startup_distance_max_m,
                "pitch_vote.startup_distance_max_m",
            ),
        ];
        if let Some(&(_, field)) = positive.iter().find(|(v, _)| *v <= 0.0) {
            return bad(field);
        }
        let not_negative = [
            (pv.corner_sigma_px, "pitch_vote.corner_sigma_px"),
            (pv.absolute_gain, "pitch_vote.absolute_gain"),
            (pv.pitch_settle_s, "pitch_vote.pitch_settle_s"),
            (pv.roll_settle_s, "pitch_vote.roll_settle_s"),
            (pv.prior_matches, "pitch_vote.prior_matches"),
            (pv.pivot_s2_per_m, "pitch_vote.pivot_s2_per_m"),
        ];
        match not_negative.iter().find(|(v, _)| *v < 0.0) {
            Some(&(_, field)) => bad(field),
            None => Ok(()),
        }
    }

    fn check_finite(&self) -> Result<(), ConfigError> {
        let (k, m, a, d, w) = (
            &self.intrinsics,
            &self.mount,
            &self.attitude_bounds,
            &self.dynamics,
            &self.window,
        );
        let fields = [
            (k.fx_px, "intrinsics.fx_px"),
            (k.fy_px, "intrinsics.fy_px"),
            (k.cx_px, "intrinsics.cx_px"),
            (k.cy_px, "intrinsics.cy_px"),
            (m.x_m, "mount.x_m"),
            (m.y_m, "mount.y_m"),
            (m.height_m, "mount.height_m"),
            (m.yaw_rad, "mount.yaw_rad"),
            (m.pitch_rad, "mount.pitch_rad"),
            (m.roll_rad, "mount.roll_rad"),
            (a.pitch_rad, "attitude_bounds.pitch_rad"),
            (a.roll_rad, "attitude_bounds.roll_rad"),
            (
                d.max_heading_accel_rad_s2,
                "dynamics.max_heading_accel_rad_s2",
            ),
            (
                d.max_longitudinal_accel_m_s2,
                "dynamics.max_longitudinal_accel_m_s2",
            ),
            (w.near_m, "window.near_m"),
            (w.far_m, "window.far_m"),
            (w.half_width_m, "window.half_width_m"),
            (
                self.pitch_vote.pitch_range_rad,
                "pitch_vote.pitch_range_rad",
            ),
            (
                self.pitch_vote.heading_half_rad,
                "pitch_vote.heading_half_rad",
            ),
            (
                self.pitch_vote.distance_half_m,
                "pitch_vote.distance_half_m",
            ),
            (
                self.pitch_vote.lateral_tolerance_m,
                "pitch_vote.lateral_tolerance_m",
            ),
            (
                self.pitch_vote.corner_sigma_px,
                "pitch_vote.corner_sigma_px",
            ),
            (self.pitch_vote.roll_range_rad, "pitch_vote.roll_range_rad"),
            (self.pitch_vote.absolute_gain, "pitch_vote.absolute_gain"),
            (self.pitch_vote.pitch_settle_s, "pitch_vote.pitch_settle_s"),
            (self.pitch_vote.roll_settle_s, "pitch_vote.roll_settle_s"),
            (self.pitch_vote.prior_matches, "pitch_vote.prior_matches"),
            (self.pitch_vote.pivot_s2_per_m, "pitch_vote.pivot_s2_per_m"),
            (
                self.pitch_vote.startup_heading_half_rad,
                "pitch_vote.startup_heading_half_rad",
            ),
            (
                self.pitch_vote.startup_distance_max_m,
                "pitch_vote.startup_distance_max_m",
            ),
            (self.min_inlier_ratio, "min_inlier_ratio"),
        ];
        match fields.iter().find(|(v, _)| !v.is_finite()) {
            Some(&(_, field)) => Err(ConfigError::NonFinite { field }),
            None => Ok(()),
        }
    }
}

impl ValidConfig {
    /// The bounding rectangle of the ground window's image, clipped to the frame. `None` when the
    /// far end of the window is not visible, or when its pixel backprojects above the horizon
    /// under one of the extremal attitudes.
    fn image_roi(&self) -> Option<(ImageRoi, Polygon)> {
        let w = &self.config.window;
        let size = &self.config.image;
        let (max_u, max_v) = (f32::from(size.width_px - 1), f32::from(size.height_px - 1));
        let proj = &self.projection;
        let far_px = proj.nominal.project(self.window_point(w.far_m, 0.0))?;
        let inside = (0.0..=max_u).contains(&far_px.u_px) && (0.0..=max_v).contains(&far_px.v_px);
        if !inside || proj.observe(far_px).is_none() {
            return None;
        }
        // The window rectangle, cut to the part in front of the camera, projected, cut to the
        // frame: its image is convex, so clipping by half-planes is exact.
        let mut ground = Polygon::default();
        for (ahead, left) in [
            (w.near_m, -1.0),
            (w.far_m, -1.0),
            (w.far_m, 1.0),
            (w.near_m, 1.0),
        ] {
            let p = self.window_point(ahead, left * w.half_width_m);
            ground.push([p.x_m, p.y_m]);
        }
        let seen =
            ground.clip(|[x, y]| proj.nominal.depth_m(GroundPoint { x_m: x, y_m: y }) - 0.01);
        let mut image = Polygon::default();
        for &[x, y] in seen.points() {
            let px = proj.nominal.project(GroundPoint { x_m: x, y_m: y })?;
            image.push([px.u_px, px.v_px]);
        }
        let image = image
            .clip(|[u, _]| u)
            .clip(|[u, _]| max_u - u)
            .clip(|[_, v]| v)
            .clip(|[_, v]| max_v - v);
        // Not empty: it holds the far end's pixel, inside the frame.
        let (lo, hi) = image.bounds()?;
        // Rounding outwards; the casts cannot wrap, the values lie in the frame.
        let roi = ImageRoi {
            left_px: libm::floorf(lo[0]) as u16,
            right_px: libm::ceilf(hi[0]) as u16,
            top_px: libm::floorf(lo[1]) as u16,
            bottom_px: libm::ceilf(hi[1]) as u16,
        };
        Some((roi, image))
    }
}

/// A small convex polygon for clipping: four corners, each half-plane cut adds at most one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Polygon {
    points: [[f32; 2]; 8],
    len: usize,
}

impl Polygon {
    const EMPTY: Self = Self {
        points: [[0.0; 2]; 8],
        len: 0,
    };

    /// The lowest and highest coordinates of the corners, `None` when there are none.
    fn bounds(&self) -> Option<([f32; 2], [f32; 2])> {
        let (first, rest) = self.points().split_first()?;
        let (mut lo, mut hi) = (*first, *first);
        for p in rest {
            for ((lo, hi), &x) in lo.iter_mut().zip(hi.iter_mut()).zip(p) {
                (*lo, *hi) = (lo.min(x), hi.max(x));
            }
        }
        Some((lo, hi))
    }

    fn points(&self) -> &[[f32; 2]] {
        &self.points[..self.len.min(self.points.len())]
    }

    fn push(&mut self, p: [f32; 2]) {
        if let Some(slot) = self.points.get_mut(self.len) {
            *slot = p;
            self.len += 1;
        }
    }

    /// Sutherland-Hodgman: keeps the part where `side(p) >= 0`.
    fn clip(&self, side: impl Fn([f32; 2]) -> f32) -> Polygon {
        let mut out = Polygon::default();
        let pts = self.points();
        for (i, &a) in pts.iter().enumerate() {
            let b = pts[(i + 1) % pts.len()];
            let (sa, sb) = (side(a), side(b));
            if sa >= 0.0 {
                out.push(a);
            }
            if (sa >= 0.0) != (sb >= 0.0) {
                let t = sa / (sa - sb);
                out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        out
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::projection::Pixel;

    const DEG: f32 = core::f32::consts::PI / 180.0;

    /// The KITTI camera 0 with the paper's KITTI settings.
    pub(crate) fn kitti_config() -> Config {
        Config::with_defaults(
            ImageSize {
                width_px: 1241,
                height_px: 376,
            },
            Intrinsics {
                fx_px: 718.856,
                fy_px: 718.856,
                cx_px: 607.1928,
                cy_px: 185.2157,
            },
            Mount {
                x_m: 1.0,
                y_m: 0.0,
                height_m: 1.65,
                yaw_rad: 0.0,
                pitch_rad: 0.0,
                roll_rad: 0.0,
            },
        )
    }

    #[test]
    fn kitti_config_is_valid_and_roi_is_the_lower_band() {
        let v = kitti_config().validate().unwrap();
        let roi = v.roi();
        // Far cutoff 11 m ahead of a 1.65 m camera: row cy + f * 1.65 / 12 = 284.
        assert!((283..=285).contains(&roi.top_px), "{roi:?}");
        assert_eq!(roi.bottom_px, 375);
        assert!(roi.left_px > 0 && roi.right_px < 1240, "{roi:?}");
        assert!(v.in_window(GroundPoint { x_m: 8.0, y_m: 1.0 }));
        assert!(!v.in_window(GroundPoint {
            x_m: 14.0,
            y_m: 0.0
        }));
        assert!(!v.in_window(GroundPoint {
            x_m: 8.0,
            y_m: -3.5
        }));
    }

    #[test]
    fn roi_rows_hold_every_window_pixel_of_their_columns() {
        // Level, and a mount turned and tilted so that the window's image is skewed.
        for (yaw, pitch, roll) in [(0.0, 0.0, 0.0), (4.0, -2.0, 1.5), (-6.0, 1.0, -2.0)] {
            let mut c = kitti_config();
            (c.mount.yaw_rad, c.mount.pitch_rad, c.mount.roll_rad) =
                (yaw * DEG, pitch * DEG, roll * DEG);
            let v = c.validate().unwrap();
            let roi = v.roi();
            let mut fewer = false;
            for left in (roi.left_px..=roi.right_px).step_by(64) {
                let right = (left + 63).min(roi.right_px);
                let rows = v.roi_rows(left, right);
                let (top, bottom) = rows.unwrap_or((u16::MAX, 0));
                fewer |= rows.is_some_and(|(t, b)| b - t < roi.bottom_px - roi.top_px);
                for u in left..=right {
                    for row in roi.top_px..=roi.bottom_px {
                        // Anywhere within half a pixel of the pixel's centre.
                        for (du, dv) in [(-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5), (0.5, 0.5)] {
                            let px = Pixel {
                                u_px: f32::from(u) + du,
                                v_px: f32::from(row) + dv,
                            };
                            let inside = v
                                .projection()
                                .nominal
                                .backproject(px)
                                .is_some_and(|g| v.in_window(g));
                            assert!(
                                !inside || (top..=bottom).contains(&row),
                                "pixel ({u}, {row}) of columns {left}..={right} outside rows \
                                 {rows:?} (mount {yaw}/{pitch}/{roll} deg)"
                            );
                        }
                    }
                }
            }
            assert!(fewer, "no band narrower than the ROI: {roi:?}");
        }
    }

    #[test]
    fn every_bad_value_has_its_error() {
        let ok = kitti_config();
        let check = |f: &dyn Fn(&mut Config), want: ConfigError| {
            let mut c = ok;
            f(&mut c);
            assert_eq!(c.validate().unwrap_err(), want);
        };
        check(
            &|c| c.intrinsics.cx_px = f32::NAN,
            ConfigError::NonFinite {
                field: "intrinsics.cx_px",
            },
        );
        check(
            &|c| c.window.far_m = f32::INFINITY,
            ConfigError::NonFinite {
                field: "window.far_m",
            },
        );
        check(&|c| c.image.width_px = 0, ConfigError::EmptyImage);
        check(
            &|c| c.intrinsics.fx_px = 0.0,
            ConfigError::FocalLengthNotPositive,
        );
        check(
            &|c| c.intrinsics.fy_px = -700.0,
            ConfigError::FocalLengthNotPositive,
        );
        check(
            &|c| c.mount.height_m = 0.0,
            ConfigError::CameraNotAboveGround,
        );
        check(
            &|c| c.mount.height_m = -1.0,
            ConfigError::CameraNotAboveGround,
        );
        check(
            &|c| c.attitude_bounds.roll_rad = -0.1,
            ConfigError::AttitudeBoundOutOfRange {
                field: "attitude_bounds.roll_rad",
            },
        );
        check(
            &|c| c.dynamics.max_longitudinal_accel_m_s2 = 0.0,
            ConfigError::DynamicsNotPositive {
                field: "dynamics.max_longitudinal_accel_m_s2",
            },
        );
        check(&|c| c.window.far_m = 0.0, ConfigError::EmptyWindow);
        check(&|c| c.window.half_width_m = 0.0, ConfigError::EmptyWindow);
        check(
            &|c| c.features_per_side = 0,
            ConfigError::ZeroCount {
                field: "features_per_side",
            },
        );
        check(
            &|c| c.pitch_vote.pitch_steps = 20,
            ConfigError::PitchVoteOutOfRange {
                field: "pitch_vote.pitch_steps",
            },
        );
        check(
            &|c| c.pitch_vote.lateral_tolerance_m = 0.0,
            ConfigError::PitchVoteOutOfRange {
                field: "pitch_vote.lateral_tolerance_m",
            },
        );
        check(
            &|c| c.pitch_vote.roll_steps = 16,
            ConfigError::PitchVoteOutOfRange {
                field: "pitch_vote.roll_steps",
            },
        );
        check(
            &|c| c.pitch_vote.corner_sigma_px = -0.5,
            ConfigError::PitchVoteOutOfRange {
                field: "pitch_vote.corner_sigma_px",
            },
        );
        check(
            &|c| c.pitch_vote.pitch_settle_s = f32::NAN,
            ConfigError::NonFinite {
                field: "pitch_vote.pitch_settle_s",
            },
        );
        // Settings that may be 0 but not negative, nor infinite or NaN.
        type Field = fn(&mut Config) -> &mut f32;
        let not_negative: [(Field, &str); 3] = [
            (
                |c| &mut c.pitch_vote.roll_settle_s,
                "pitch_vote.roll_settle_s",
            ),
            (
                |c| &mut c.pitch_vote.prior_matches,
                "pitch_vote.prior_matches",
            ),
            (
                |c| &mut c.pitch_vote.pivot_s2_per_m,
                "pitch_vote.pivot_s2_per_m",
            ),
        ];
        for (value, field) in not_negative {
            for bad in [f32::NAN, f32::INFINITY] {
                check(&|c| *value(c) = bad, ConfigError::NonFinite { field });
            }
            check(
                &|c| *value(c) = -0.001,
                ConfigError::PitchVoteOutOfRange { field },
            );
        }
        check(
            &|c| c.min_inlier_ratio = 1.5,
            ConfigError::RatioOutOfRange {
                field: "min_inlier_ratio",
            },
        );
        check(
            &|c| c.track_max_misses = 0,
            ConfigError::ZeroCount {
                field: "track_max_misses",
            },
        );
        // Looking up at the sky: the window is above the frame.
        check(
            &|c| c.mount.pitch_rad = 30.0 * DEG,
            ConfigError::RoiOutsideImage,
        );
        // A far cutoff beyond the horizon once the body pitches up by the bound.
        check(&|c| c.window.far_m = 500.0, ConfigError::RoiOutsideImage);
        // A frame too small to hold the window.
        check(
            &|c| {
                c.image = ImageSize {
                    width_px: 100,
                    height_px: 100,
                }
            },
            ConfigError::RoiOutsideImage,
        );
        // A focal length so long that the window is a sliver of the frame.
        check(&|c| c.intrinsics.fx_px = 1.0e38, ConfigError::RoiTooSmall);
    }

    #[test]
    fn rear_camera_window_lies_behind_the_vehicle() {
        let mut c = kitti_config();
        c.mount.x_m = -0.8;
        c.mount.yaw_rad = core::f32::consts::PI;
        let v = c.validate().unwrap();
        assert!(v.in_window(GroundPoint {
            x_m: -6.0,
            y_m: 0.0
        }));
        assert!(!v.in_window(GroundPoint { x_m: 6.0, y_m: 0.0 }));
    }

    #[test]
    fn errors_display_their_field() {
        let e = ConfigError::NonFinite { field: "mount.x_m" };
        assert_eq!(std::format!("{e}"), "mount.x_m is not a finite number");
    }
}
