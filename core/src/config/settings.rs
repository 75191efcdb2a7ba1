//! The odometer's settings: a mount file's `[odometer]` section, each setting defined once here
//! with its unit, default and range (see [`crate::setting`]).

use crate::setting::settings;

/// Which estimator turns the frame's corners into motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// A joint vote over the body's pitch and roll, the heading change and the distance, each
    /// corner backprojected exactly per attitude hypothesis ([`crate::method::pitch_vote`]).
    #[default]
    PitchVote,
    /// The paper's §2 as written ([`crate::method::paper`]): observation and prediction
    /// quadrilaterals, overlap matching, a vote over the dynamics patch.
    Paper,
}

impl Method {
    /// Every method, in the order of their names.
    pub const ALL: [Method; 2] = [Method::PitchVote, Method::Paper];

    /// The method's name in a mount file and on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Self::PitchVote => "pitch-vote",
            Self::Paper => "paper",
        }
    }

    /// The method called `name` in a mount file.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

#[cfg(feature = "serde")]
impl serde::Serialize for Method {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

#[cfg(feature = "serde")]
impl<'de> serde::Deserialize<'de> for Method {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Name;
        impl serde::de::Visitor<'_> for Name {
            type Value = Method;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("a method: \"pitch-vote\" or \"paper\"")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Method, E> {
                const NAMES: &[&str] = &[Method::PitchVote.name(), Method::Paper.name()];
                Method::from_name(v).ok_or_else(|| E::unknown_variant(v, NAMES))
            }
        }
        d.deserialize_str(Name)
    }
}

/// Most pitch hypotheses the pitch vote may use.
pub const MAX_PITCH_HYPOTHESES: usize = 31;
/// Most roll hypotheses the pitch vote may use.
pub const MAX_ROLL_HYPOTHESES: usize = 15;

settings! {
    /// How the odometer runs: a mount file's `[odometer]` section. Defaults are the paper's
    /// values, and for the pitch vote's own settings BRIEF §7's prototype's unless said.
    pub struct Settings {
        /// Which estimator runs: `pitch-vote` (the default) or `paper` (the paper's method as
        /// written, for comparison).
        method: Method = val(Method::PitchVote) => "method";
        /// Body pitch on the suspension, each side of level (paper §2.1, town driving: 1 deg):
        /// the paper's observation regions, and the ground window's margin to the horizon.
        pitch_bound_rad: f32 = deg(1.0), min 0.0, max 10.0 => "pitch_bound_deg";
        /// Body roll on the suspension, each side of level (paper: 2 deg).
        roll_bound_rad: f32 = deg(2.0), min 0.0, max 10.0 => "roll_bound_deg";
        /// Largest angular acceleration of the heading (paper §2.2: 10 deg/s^2, which covers 92%
        /// of 22 km of driving); the paper's method's motion patch.
        max_heading_accel_rad_s2: f32 = deg(10.0), above 0.0, max 3600.0
            => "max_heading_accel_deg_s2";
        /// Largest longitudinal acceleration or deceleration, m/s^2 (paper: 1.5); the paper's
        /// method's motion patch.
        max_longitudinal_accel_m_s2: f32 = val(1.5), above 0.0, max 100.0
            => "max_longitudinal_accel_m_s2";
        /// Near end of the ground window, metres ahead of the camera along its look direction;
        /// 0: where the image ends.
        window_near_m: f32 = val(0.0), min 0.0, max 100.0 => "window_near_m";
        /// Far end of the ground window, metres ahead of the camera (paper, KITTI: 12).
        window_far_m: f32 = val(12.0), above 0.0, max 200.0 => "window_far_m";
        /// Half width of the ground window each side of the camera's look direction, metres
        /// (paper, KITTI: 3).
        window_half_width_m: f32 = val(3.0), above 0.0, max 50.0 => "window_half_width_m";
        /// Corners kept on each side of straight ahead (paper: 32); at most the odometer's
        /// `MAX_FEATURES`.
        features_per_side: u16 = val(32), min 1, max 1024 => "features_per_side";
        /// Frames a track may go unmatched before it is dropped (paper: 3 to 5).
        track_max_misses: u8 = val(5), min 1 => "track_max_misses";
        /// Smallest Harris response of a corner, in (Sobel gradient)^4 / 2^16: 2000 is about a
        /// 25-grey-level step at a right-angled corner; sensor noise of 2 grey levels scores
        /// under 10.
        corner_threshold: u32 = val(2000) => "corner_threshold";
        /// Below this ratio of matched tracks to detected corners the frame keeps the previous
        /// motion (paper §5: 1/8).
        min_inlier_ratio: f32 = val(0.125), min 0.0, max 1.0 => "min_inlier_ratio";
        /// Pitch vote: body pitch hypotheses span +- this (1 deg).
        pitch_range_rad: f32 = deg(1.0), min 0.0, max 10.0 => "pitch_range_deg";
        /// Pitch vote: number of pitch hypotheses, odd so that level is one (21: 0.1 deg steps);
        /// at most 31.
        pitch_steps: u8 = val(21), min 1, max 31 => "pitch_steps";
        /// Pitch vote: largest change of body pitch between two frames, in pitch steps (5:
        /// 0.5 deg; a suspension's +-0.5 deg at 1.5 Hz changes by up to 0.47 deg in 0.1 s). 0:
        /// the pitch follows the absolute measurement alone (a stiff body, see
        /// `docs/mount-file.md`).
        max_pitch_change_steps: u8 = val(5) => "max_pitch_change_steps";
        /// Pitch vote: half width of the heading-change window around the previous motion, per
        /// frame (1 deg: wide enough to see real changes, unlike the paper's 0.1 deg patch).
        heading_window_rad: f32 = deg(1.0), above 0.0, max 45.0 => "heading_window_deg";
        /// Pitch vote: half width of the distance window around the previous motion, metres per
        /// frame (0.15: 15 m/s^2 at 10 frames/s, beyond any braking; the prototype's 0.3 let a
        /// car holding its distance ahead pull the estimate to a stop).
        distance_window_m: f32 = val(0.15), above 0.0, max 10.0 => "distance_window_m";
        /// Pitch vote: largest residual across the chord of a track and an observation that
        /// still votes, metres (0.04).
        lateral_tolerance_m: f32 = val(0.04), above 0.0, max 1.0 => "lateral_tolerance_m";
        /// Pitch vote: standard deviation of a corner's row, pixels (0.5; 0: one bin a pair). A
        /// pair votes for the distances its corners' rows allow, a tent two standard deviations
        /// wide each side.
        corner_sigma_px: f32 = val(0.5), min 0.0, max 10.0 => "corner_sigma_px";
        /// Pitch vote: body roll hypotheses span +- this (1.4 deg: a swing of +-1 deg and a
        /// margin).
        roll_range_rad: f32 = deg(1.4), min 0.0, max 10.0 => "roll_range_deg";
        /// Pitch vote: number of roll hypotheses, odd (15: 0.2 deg steps); at most 15. 1: no
        /// roll search.
        roll_steps: u8 = val(15), min 1, max 15 => "roll_steps";
        /// Pitch vote: largest change of body roll between two frames, in roll steps (3:
        /// 0.6 deg; a +-1 deg roll at 1.2 Hz changes by up to 0.75 deg in 0.1 s). 0: the roll
        /// stays the mount's.
        max_roll_change_steps: u8 = val(3) => "max_roll_change_steps";
        /// Pitch vote: share of each frame's measured common pitch error (the slope of matched
        /// distances against range) that moves both frames' pitch (0.2).
        absolute_gain: f32 = val(0.2), min 0.0, max 1.0 => "absolute_gain";
        /// Pitch vote: time constant with which the body pitch estimate returns to level,
        /// seconds (0.5; 0: never). A body on its suspension swings about level with a period
        /// near a second; an offset that lasts longer is the estimate's drift.
        pitch_settle_s: f32 = val(0.5), min 0.0, max 3600.0 => "pitch_settle_s";
        /// Pitch vote: time constant with which the body roll estimate returns to level, seconds
        /// (0.5; 0: never).
        roll_settle_s: f32 = val(0.5), min 0.0, max 3600.0 => "roll_settle_s";
        /// Pitch vote: how many matched tracks the previous motion weighs as against a frame's
        /// vote (3; 0: the vote alone): a vote most tracks support moves the estimate nearly
        /// all the way, one a vehicle ahead leaves to a handful moves it part of the way.
        prior_matches: f32 = val(3.0), min 0.0, max 1000.0 => "prior_matches";
        /// Pitch vote: the heading from the matched pairs' residuals across the chord alone,
        /// refined after the vote (false: the vote's, which also answers to distances that
        /// disagree between the two sides: a kerb, a crown, a roll estimate off).
        refine_heading: bool = val(false) => "refine_heading";
        /// Pitch vote: the vehicle's arc is drawn from a pivot this many s^2/m times the speed
        /// squared ahead of the rear axle (0: the rear axle, the paper's Ackermann model). A
        /// car's rear tyres slip outwards in a bend; the linear single-track model puts the
        /// point that follows the arc `mass * (front axle to centre of mass) / (wheelbase * rear
        /// cornering stiffness) * v^2` ahead: 0.003 to 0.007 s^2/m for a mid-size car.
        pivot_s2_per_m: f32 = val(0.0), min 0.0, max 1.0 => "pivot_s2_per_m";
        /// Pitch vote: heading window half width with no previous motion (4 deg: 40 deg/s at
        /// 10 frames/s; KITTI 01 starts in a bend at 2.5 deg a frame).
        startup_heading_window_rad: f32 = deg(4.0), above 0.0, max 45.0
            => "startup_heading_window_deg";
        /// Pitch vote: distance window's upper end with no previous motion, metres per frame
        /// (2.6: 94 km/h at 10 frames/s); the lower end is 0.
        startup_distance_max_m: f32 = val(2.6), above 0.0, max 20.0 => "startup_distance_max_m";
        /// Frames of lag of the heading smoother a trajectory is fed through (0: none, the
        /// odometer's own estimates; see [`crate::Smoother`]), pitch vote only: the paper's
        /// method stays as written. The odometer's estimates are never smoothed.
        smooth_lag_frames: u8 = val(0), max 4 => "smooth_lag_frames";
        /// Pitch vote: the heading change from corners over the whole image (true), the ground
        /// window's vote giving the distance at that heading; false: the ground window's vote
        /// gives both (the method before the whole image was used).
        image_heading: bool = val(true) => "image_heading";
        /// Whole-image heading: the FAST threshold of a corner, grey levels (20).
        image_corner_threshold: u8 = val(20), min 1 => "image_corner_threshold";
        /// Whole-image heading: cells across the frame's grid, each keeping its strongest
        /// corners (16).
        image_grid_columns: u8 = val(16), min 1 => "image_grid_columns";
        /// Whole-image heading: cells down the frame's grid (4).
        image_grid_rows: u8 = val(4), min 1 => "image_grid_rows";
        /// Whole-image heading: corners kept a cell (2): with the grid, at most the odometer's
        /// `IMAGE_FEATURES` a frame.
        image_corners_per_cell: u8 = val(2), min 1, max 4 => "image_corners_per_cell";
        /// Whole-image heading: largest root mean square difference of a feature's patch (its
        /// 5x5 interior) and the place it is found again, each less its mean, grey levels (20).
        image_max_unlikeness_dn: f32 = val(20.0), above 0.0, max 255.0
            => "image_max_unlikeness_dn";
        /// Whole-image heading: the finest vote's kernel, pixels: a pair's vote falls to nothing
        /// at this distance from the motion (0.7).
        image_kernel_px: f32 = val(0.7), above 0.0, max 20.0 => "image_kernel_px";
        /// Whole-image heading: largest distance of a pair from the motion that the refinement
        /// takes in, pixels (1).
        image_inlier_px: f32 = val(1.0), above 0.0, max 20.0 => "image_inlier_px";
        /// Whole-image heading: fewest pairs the motion must hold for its heading to be taken
        /// (20).
        image_min_inliers: u16 = val(20), min 6, max 1000 => "image_min_inliers";
        /// Whole-image heading: the largest standard deviation of the image's heading change
        /// (how well its pairs determine it, the rest of the motion free) for it to be taken
        /// (0.05 deg): pairs that lie on one plane (a frame of nothing but road) cannot tell a
        /// turn from a sideways step, and the ground window's vote is the better there.
        image_max_heading_sd_rad: f32 = deg(0.05), above 0.0, max 10.0
            => "image_max_heading_sd_deg";
        /// Pitch vote: the mount's yaw learned while driving (true): the step across the chord
        /// that the ground's matched pairs show in every frame, and with `image_heading` the
        /// whole image's direction of travel on frames that see more than the road, averaged
        /// over the road, turn the configured mount ([`crate::calibration`]); false: the mount
        /// file's yaw stands.
        learn_yaw: bool = val(true) => "learn_yaw";
        /// Pitch vote with `image_heading`: the mount's pitch learned while driving (true): the
        /// whole image's direction of travel on frames that see more than the road, the road's
        /// plane under its pairs on frames that see nothing else, averaged over the road, turn
        /// the configured mount ([`crate::calibration`]); false: the mount file's pitch stands.
        learn_pitch: bool = val(true) => "learn_pitch";
        /// Pitch vote with `image_heading`: the mount's roll learned while driving (true): the
        /// road's plane under the whole image's pairs on it, averaged over the road, turns the
        /// configured mount ([`crate::calibration`]); false: the mount file's roll stands.
        learn_roll: bool = val(true) => "learn_roll";
        /// Pitch vote with `image_heading`: the frame's distance measured by the road's plane
        /// too, its homography's travel over the camera's height where the whole image's pairs
        /// and the ground window's on the road determine it, and the geometric mean of it and
        /// the ground vote's taken ([`crate::road_distance`]) where the two agree within a few
        /// spreads of their running disagreement (the default); false: the ground vote's
        /// distance alone.
        road_distance: bool = val(true) => "road_distance";
        /// Pitch vote with `image_heading`: where the whole image's heading rests on the road
        /// alone (fewer than [`crate::calibration::MIN_INLIERS_ABOVE_HORIZON`] inliers above
        /// the horizon), the ground window's tracks vote for their own heading too and the two
        /// are weighed by the variances their running disagreements give them
        /// ([`crate::road_heading`]; the default); false: the image's heading stands.
        weigh_road_heading: bool = val(true) => "weigh_road_heading";
        /// Pitch vote with `image_heading`: the camera's distance ahead of the rear axle
        /// learned while driving (true): the whole image's direction of travel in the bends,
        /// against the curvature, moves the configured camera ([`crate::calibration`]); false:
        /// the mount file's `x_m` stands.
        learn_x: bool = val(true) => "learn_x";
    }
}
