//! Synthetic drives: what `roadvo simulate` renders. A scenario is a TOML file (or one of the
//! built-ins, whose TOML `roadvo simulate --print-scenario NAME` prints as a starting point):
//!
//! ```toml
//! name = "my-drive"
//! frames_per_second = 10.0
//!
//! [camera]                   # as in mount.toml
//! width_px = 640
//! height_px = 480
//! fx_px = 560.0
//! fy_px = 560.0
//! cx_px = 320.0
//! cy_px = 240.0
//!
//! [mount]                    # the mount the images are rendered with, as in mount.toml
//! x_m = 1.5
//! height_m = 2.7
//! pitch_deg = -20.0
//!
//! [[segment]]                # the path: straights, arcs, clothoids, in order
//! kind = "straight"
//! length_m = 30.0
//! [[segment]]
//! kind = "clothoid"          # curvature changes linearly to end_curvature_per_m
//! length_m = 15.0
//! end_curvature_per_m = 0.2094
//! [[segment]]
//! kind = "arc"
//! radius_m = 50.0
//! angle_deg = -45.0          # positive turns left
//!
//! [[speed]]                  # speed along the path, piecewise linear in distance
//! at_m = 0.0
//! speed_m_s = 2.5
//!
//! [render]                   # all optional
//! supersample = 2            # samples per pixel along each axis
//! noise_dn = 1.5             # sensor noise, standard deviation, grey levels
//! lane_width_m = 3.5
//! texture_density = 1.0      # texture patches, about four per square metre
//! bare_half_width_m = 0.0    # no patches this close to our lane's centre
//!
//! [suspension]               # optional: body pitch and roll oscillation
//! pitch_amplitude_deg = 0.5
//! pitch_frequency_hz = 1.5
//! roll_amplitude_deg = 1.0
//! roll_frequency_hz = 1.2
//!
//! [[vehicle]]                # optional, any number: boxes driving along the road
//! lateral_m = 0.0            # offset from our lane's centre, metres, positive left
//! ahead_m = 7.0              # distance ahead of us when it appears
//! speed_m_s = 2.5            # omitted: keeps its distance to us; negative: oncoming
//! cross_speed_m_s = 0.0      # across the road, positive to the left (0.0 with speed_m_s = 0.0:
//!                            # a car crossing at a junction ahead)
//! appear_s = 10.0
//! disappear_s = 12.0
//!
//! [kerb]                     # optional: a raised strip (paper appendix)
//! from_m = -3.0              # lateral range, metres, positive left
//! to_m = -2.0
//! height_m = 0.15
//!
//! [crown]                    # optional: the road falls away beyond these offsets
//! left_from_m = 1.0
//! left_slope = 0.04
//! right_from_m = 1.0
//! right_slope = 0.0
//!
//! [calibration_error]        # optional: added to the mount written into mount.toml
//! pitch_deg = 1.0
//!
//! # Above-ground structure, all optional and off unless its table is present. Placed along the
//! # whole path from the seed; anything that would stand on the asphalt of any stretch of the
//! # road is left out. Lateral distances are beyond the road's edge: the asphalt's outer border,
//! # 0.6 m outside the painted edge line (0.5 lane + 0.6 m right of our lane's centre, 1.5 lanes
//! # + 0.6 m left of it). Pairs are [min, max] ranges, drawn per item.
//!
//! [facades]                  # buildings: textured boxes (windows, doors, bricks or panels)
//! sides = "both"             # "left", "right" or "both"
//! setback_m = [3.0, 10.0]    # the front's distance beyond the road's edge
//! length_m = [8.0, 25.0]     # along the road
//! gap_m = [2.0, 10.0]        # between neighbours along the road
//! height_m = [6.0, 15.0]
//! depth_m = [8.0, 14.0]
//!
//! [poles]                    # street lights (lamp on an arm) and sign posts (a plate)
//! sides = "both"
//! spacing_m = 25.0           # mean distance between neighbours along a side, +-30%
//! offset_m = 1.6             # beyond the road's edge
//! sign_fraction = 0.4        # share of sign posts; the rest are street lights
//!
//! [trees]                    # a trunk and a leafy ellipsoid crown
//! sides = "both"
//! spacing_m = 15.0           # mean distance between neighbours along a side, +-30%
//! offset_m = 2.6             # the trunk beyond the road's edge
//! height_m = [5.0, 9.0]
//!
//! [parked]                   # parked cars (static boxes) along the road's edge
//! sides = "right"
//! gap_m = [1.0, 12.0]        # free space between neighbours
//! offset_m = -0.5            # the road-side flank beyond the road's edge (negative: on the
//!                            # asphalt; -0.5 leaves it just outside the edge line)
//! ```
//!
//! Every number is bounded at load time, so that a render's memory and time are known before it
//! starts: the path at most [`MAX_PATH_M`] (20 km, over at most [`MAX_SEGMENTS`] segments, none
//! sharper than a 1 m radius), speeds at most [`MAX_SPEED_M_S`], the frame rate within
//! [`FRAMES_PER_SECOND`], a drive at most [`MAX_DRIVE_S`] and [`MAX_FRAMES`] frames, a frame at
//! most [`MAX_IMAGE_PIXELS`], at most [`MAX_VEHICLES`] other road users, sizes and distances
//! beside the road at most [`MAX_EXTENT_M`]. Errors name the scenario, the key and the limit.

use crate::input::{Input, read_text};
use crate::mount::MountFile;
use crate::path::{Segment, SpeedKnot, check_speed_profile};
use anyhow::{Context, Result, bail};
use roadvo::{Camera, Mount, Settings};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Rendering options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderOptions {
    /// Samples per pixel along each axis (anti-aliasing): 2 gives 4 samples a pixel.
    pub supersample: u8,
    /// Sensor noise, standard deviation in grey levels.
    pub noise_dn: f64,
    /// Lane width, metres; our lane is centred on the path, one more lane lies to its left.
    pub lane_width_m: f64,
    /// Scales how many texture patches the asphalt carries (1: about four per square metre).
    pub texture_density: f64,
    /// No texture patches within this distance of our lane's centre, metres (the paper
    /// appendix's worst case: features only at the road's edges). 0: patches everywhere.
    pub bare_half_width_m: f64,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            supersample: 2,
            noise_dn: 1.5,
            lane_width_m: 3.5,
            texture_density: 1.0,
            bare_half_width_m: 0.0,
        }
    }
}

/// Body oscillation on the suspension: sinusoids in pitch and roll.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Suspension {
    /// Pitch amplitude, degrees.
    pub pitch_amplitude_deg: f64,
    /// Pitch frequency, Hz.
    pub pitch_frequency_hz: f64,
    /// Roll amplitude, degrees.
    pub roll_amplitude_deg: f64,
    /// Roll frequency, Hz.
    pub roll_frequency_hz: f64,
}

/// Another road user: a textured box driving along the road.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vehicle {
    /// Offset from our lane's centre, metres, positive left.
    pub lateral_m: f64,
    /// Distance ahead of our rear axle when it appears, metres (negative: behind).
    pub ahead_m: f64,
    /// Its speed along the path, m/s; omitted, it keeps its distance to us. Negative: oncoming.
    #[serde(default)]
    pub speed_m_s: Option<f64>,
    /// Its speed across the road, m/s, positive to the left: `lateral_m` is where it starts.
    /// The box turns to face the way it goes.
    #[serde(default)]
    pub cross_speed_m_s: f64,
    /// Time it appears, seconds.
    #[serde(default)]
    pub appear_s: f64,
    /// Time it vanishes, seconds.
    #[serde(default = "forever")]
    pub disappear_s: f64,
    /// Length, metres.
    #[serde(default = "car_length")]
    pub length_m: f64,
    /// Width, metres.
    #[serde(default = "car_width")]
    pub width_m: f64,
    /// Height, metres.
    #[serde(default = "car_height")]
    pub height_m: f64,
}

fn forever() -> f64 {
    f64::INFINITY
}
fn car_length() -> f64 {
    4.5
}
fn car_width() -> f64 {
    1.8
}
fn car_height() -> f64 {
    1.5
}

/// A strip of road raised above the plane the vehicle drives on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Kerb {
    /// Lateral start of the strip, metres from our lane's centre, positive left.
    pub from_m: f64,
    /// Lateral end of the strip.
    pub to_m: f64,
    /// Height, metres (paper: 0.15).
    pub height_m: f64,
}

/// A crowned road: beyond an offset on each side the surface falls away with a slope.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Crown {
    /// Where the left side starts to fall, metres left of our lane's centre.
    pub left_from_m: f64,
    /// Fall per metre on the left (0.04: 4%).
    pub left_slope: f64,
    /// Where the right side starts to fall, metres right of our lane's centre.
    pub right_from_m: f64,
    /// Fall per metre on the right.
    pub right_slope: f64,
}

/// Tyre slip: in a bend the rear tyres carry their share of the side force by slipping
/// outwards, so the point of the body that follows the path lies ahead of the rear axle, by
/// `pivot_s2_per_m` times the speed squared (the linear single-track model). Without it the
/// rear axle follows the path (the paper's Ackermann model).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Slip {
    /// How far ahead of the rear axle the point on the path lies per (m/s)^2, s^2/m.
    pub pivot_s2_per_m: f64,
}

/// Errors added to the true mount in the mount file written beside the images.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MountError {
    /// Metres.
    pub x_m: f32,
    /// Metres.
    pub y_m: f32,
    /// Metres.
    pub height_m: f32,
    /// Degrees.
    pub yaw_deg: f32,
    /// Degrees.
    pub pitch_deg: f32,
    /// Degrees.
    pub roll_deg: f32,
}

/// Which sides of the road a row of structures stands on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sides {
    /// Left of the road only.
    Left,
    /// Right of the road only.
    Right,
    /// Both sides.
    #[default]
    Both,
}

impl Sides {
    /// The sides as lateral signs: +1 left, -1 right.
    pub fn signs(self) -> &'static [f64] {
        match self {
            Sides::Left => &[1.0],
            Sides::Right => &[-1.0],
            Sides::Both => &[1.0, -1.0],
        }
    }
}

/// Buildings along the road: textured boxes with their fronts to the road.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Facades {
    /// Which sides.
    pub sides: Sides,
    /// Distance of a front beyond the road's edge, metres, [min, max].
    pub setback_m: [f64; 2],
    /// Length along the road, metres, [min, max].
    pub length_m: [f64; 2],
    /// Free space between neighbours along the road, metres, [min, max].
    pub gap_m: [f64; 2],
    /// Height, metres, [min, max].
    pub height_m: [f64; 2],
    /// Depth away from the road, metres, [min, max].
    pub depth_m: [f64; 2],
}

impl Default for Facades {
    fn default() -> Self {
        Self {
            sides: Sides::Both,
            setback_m: [3.0, 10.0],
            length_m: [8.0, 25.0],
            gap_m: [2.0, 10.0],
            height_m: [6.0, 15.0],
            depth_m: [8.0, 14.0],
        }
    }
}

/// Street lights and sign posts along the verges.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Poles {
    /// Which sides.
    pub sides: Sides,
    /// Mean distance between neighbours along a side, metres (each gap drawn within +-30%).
    pub spacing_m: f64,
    /// Distance beyond the road's edge, metres.
    pub offset_m: f64,
    /// Share of sign posts (a plate on a 2 m post); the rest are street lights.
    pub sign_fraction: f64,
}

impl Default for Poles {
    fn default() -> Self {
        Self {
            sides: Sides::Both,
            spacing_m: 25.0,
            offset_m: 1.6,
            sign_fraction: 0.4,
        }
    }
}

/// Trees along the verges: a trunk and a leafy ellipsoid crown.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Trees {
    /// Which sides.
    pub sides: Sides,
    /// Mean distance between neighbours along a side, metres (each gap drawn within +-30%).
    pub spacing_m: f64,
    /// Distance of the trunk beyond the road's edge, metres.
    pub offset_m: f64,
    /// Height, metres, [min, max].
    pub height_m: [f64; 2],
}

impl Default for Trees {
    fn default() -> Self {
        Self {
            sides: Sides::Both,
            spacing_m: 15.0,
            offset_m: 2.6,
            height_m: [5.0, 9.0],
        }
    }
}

/// Parked cars along the road's edge: static boxes like the moving vehicles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Parked {
    /// Which sides.
    pub sides: Sides,
    /// Free space between neighbours, metres, [min, max].
    pub gap_m: [f64; 2],
    /// Distance of the road-side flank beyond the road's edge, metres; negative: on the asphalt.
    pub offset_m: f64,
}

impl Default for Parked {
    fn default() -> Self {
        Self {
            sides: Sides::Right,
            gap_m: [1.0, 12.0],
            offset_m: -0.5,
        }
    }
}

/// A whole scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// A name for reports.
    pub name: String,
    /// Frame rate, frames per second.
    pub frames_per_second: f64,
    /// Camera intrinsics and image size.
    pub camera: Camera,
    /// The true mount.
    pub mount: Mount,
    /// Odometer settings written into mount.toml.
    #[serde(default)]
    pub odometer: Settings,
    /// The path, in order.
    #[serde(rename = "segment")]
    pub segments: Vec<Segment>,
    /// The speed profile.
    #[serde(rename = "speed")]
    pub speed: Vec<SpeedKnot>,
    /// Rendering options.
    #[serde(default)]
    pub render: RenderOptions,
    /// Body oscillation.
    #[serde(default)]
    pub suspension: Suspension,
    /// Other road users.
    #[serde(default, rename = "vehicle", skip_serializing_if = "Vec::is_empty")]
    pub vehicles: Vec<Vehicle>,
    /// A raised strip.
    #[serde(default)]
    pub kerb: Option<Kerb>,
    /// A crowned road.
    #[serde(default)]
    pub crown: Option<Crown>,
    /// Calibration error written into mount.toml.
    #[serde(default)]
    pub calibration_error: MountError,
    /// Tyre slip of the vehicle.
    #[serde(default)]
    pub slip: Option<Slip>,
    /// Buildings along the road.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub facades: Option<Facades>,
    /// Street lights and sign posts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poles: Option<Poles>,
    /// Trees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trees: Option<Trees>,
    /// Parked cars.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parked: Option<Parked>,
}

/// The built-in scenarios' names.
pub const BUILT_IN: [&str; 3] = ["s-course", "kitti-like", "town"];

/// The built-in overlays' names: partial scenarios merged over a scenario (`--overlay`).
pub const BUILT_IN_OVERLAYS: [&str; 5] = ["suspension", "traffic", "slip", "crossing", "wide-lens"];

/// Merges `overlay` into `base`: tables merge key by key, arrays of tables (`[[vehicle]]`)
/// are appended to, anything else is replaced.
fn merge(base: &mut toml::Table, overlay: toml::Table) {
    for (key, value) in overlay {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (Some(toml::Value::Array(b)), toml::Value::Array(o))
                if o.iter().all(toml::Value::is_table) && key != "segment" =>
            {
                b.extend(o)
            }
            (_, v) => {
                base.insert(key, v);
            }
        }
    }
}

/// The longest path, metres (the sum of its segments): 20 km. The path is integrated every
/// centimetre at 32 bytes a step, so it takes at most 64 MiB.
pub const MAX_PATH_M: f64 = 20_000.0;
/// The most `[[segment]]` entries.
pub const MAX_SEGMENTS: usize = 1_000;
/// The sharpest curvature of a segment, 1/m: an arc's radius is at least 1 m.
pub const MAX_CURVATURE_PER_M: f64 = 1.0;
/// The most `[[speed]]` entries.
pub const MAX_SPEED_KNOTS: usize = 1_000;
/// The fastest speed of us or another road user, along or across the road, m/s (360 km/h).
pub const MAX_SPEED_M_S: f64 = 100.0;
/// The frame rate's range, frames per second.
pub const FRAMES_PER_SECOND: [f64; 2] = [0.1, 1_000.0];
/// The longest drive, seconds: a drive that has not reached the path's end by then is refused
/// (the distance is integrated in 1 ms steps).
pub const MAX_DRIVE_S: f64 = 3_600.0;
/// The most frames a drive renders (each frame's state is held until the drive is written).
pub const MAX_FRAMES: usize = 100_000;
/// The most pixels of a frame (2048 x 2048); rendering holds one frame a thread.
pub const MAX_IMAGE_PIXELS: u32 = 2048 * 2048;
/// The most `[[vehicle]]` entries.
pub const MAX_VEHICLES: usize = 32;
/// The largest distance across the scene, metres: lateral offsets, sizes, setbacks, gaps,
/// spacings and heights of anything placed beside the road.
pub const MAX_EXTENT_M: f64 = 1_000.0;
/// The largest angle written in degrees: suspension amplitudes, calibration errors.
pub const MAX_ANGLE_DEG: f64 = 90.0;
/// The highest suspension frequency, Hz.
pub const MAX_FREQUENCY_HZ: f64 = 100.0;

/// Checks that `key` is a number within `lo..=hi`, either of which may be infinite (`unit`
/// after the numbers, for messages).
fn within(key: &str, x: f64, [lo, hi]: [f64; 2], unit: &str) -> Result<()> {
    if !(lo..=hi).contains(&x) {
        let limits = match (lo.is_finite(), hi.is_finite()) {
            (false, _) => format!("is more than {hi}{unit}, the limit"),
            (_, false) => format!("is less than {lo}{unit}, the limit"),
            _ => format!("is outside {lo} to {hi}{unit}, the limits"),
        };
        bail!("{key} = {x} {limits} of a scenario");
    }
    Ok(())
}

/// Checks that a list of `what` holds at most `max` entries.
fn at_most(what: &str, n: usize, max: usize) -> Result<()> {
    if n > max {
        bail!("{n} {what} entries, more than the limit of {max}");
    }
    Ok(())
}

/// `x` within `-max..=max`.
fn plus_minus(max: f64) -> [f64; 2] {
    [-max, max]
}

/// The length of a segment, metres, and its curvature at either end, 1/m.
fn segment_shape(seg: &Segment, k_before: f64) -> (f64, f64, f64) {
    match *seg {
        Segment::Straight { length_m } => (length_m, 0.0, 0.0),
        Segment::Arc {
            radius_m,
            angle_deg,
        } => {
            let k = angle_deg.signum() / radius_m;
            (radius_m * angle_deg.to_radians().abs(), k, k)
        }
        Segment::Clothoid {
            length_m,
            end_curvature_per_m,
        } => (length_m, k_before, end_curvature_per_m),
    }
}

impl Scenario {
    /// The TOML text of a built-in scenario, with its comments.
    pub fn built_in_text(name: &str) -> Result<&'static str> {
        Ok(match name {
            "s-course" => include_str!("../scenarios/s-course.toml"),
            "kitti-like" => include_str!("../scenarios/kitti-like.toml"),
            "town" => include_str!("../scenarios/town.toml"),
            _ => bail!(
                "no built-in scenario {name:?} (and no such file); built-ins: {}",
                BUILT_IN.join(", ")
            ),
        })
    }

    /// A built-in scenario by name.
    pub fn built_in(name: &str) -> Result<Self> {
        Self::parse(
            Self::built_in_text(name)?,
            &format!("built-in scenario {name}"),
        )
    }

    /// A scenario (built-in name or file) with overlays (built-in names or files) merged over
    /// it in order. Files are read up to [`MAX_SCENARIO_BYTES`](crate::input::MAX_SCENARIO_BYTES).
    pub fn load(name: &str, overlays: &[String]) -> Result<Self> {
        let text = |name: &str, builtin: &dyn Fn(&str) -> Option<&'static str>| -> Result<String> {
            let path = Path::new(name);
            match builtin(name) {
                Some(t) if !path.exists() => Ok(t.to_string()),
                _ if !path.exists() => bail!(
                    "{}: no such file (and no built-in of that name)",
                    path.display()
                ),
                _ => Ok(read_text(path, Input::Scenario)?),
            }
        };
        let base_text = text(name, &|n| Self::built_in_text(n).ok())?;
        let mut table: toml::Table =
            toml::from_str(&base_text).with_context(|| format!("in scenario {name}"))?;
        for o in overlays {
            let overlay_text = text(o, &|n| match n {
                "suspension" => Some(include_str!("../scenarios/suspension.toml")),
                "traffic" => Some(include_str!("../scenarios/traffic.toml")),
                "slip" => Some(include_str!("../scenarios/slip.toml")),
                "crossing" => Some(include_str!("../scenarios/crossing.toml")),
                "wide-lens" => Some(include_str!("../scenarios/wide-lens.toml")),
                _ => None,
            })?;
            let overlay: toml::Table =
                toml::from_str(&overlay_text).with_context(|| format!("in overlay {o}"))?;
            merge(&mut table, overlay);
        }
        let origin = if overlays.is_empty() {
            format!("scenario {name}")
        } else {
            format!("scenario {name} with overlays {overlays:?}")
        };
        let s: Scenario = table.try_into().with_context(|| origin.clone())?;
        s.check().with_context(|| origin)?;
        Ok(s)
    }

    /// Parses a scenario's TOML text and checks it, every length, speed, count and size
    /// within the limits above (so that rendering it takes known memory and time); `origin`
    /// names the text in errors (a file's path, or `built-in scenario NAME`).
    pub fn parse(text: &str, origin: &str) -> Result<Self> {
        let s: Scenario = toml::from_str(text).with_context(|| format!("in {origin}"))?;
        s.check().with_context(|| origin.to_owned())?;
        Ok(s)
    }

    fn check(&self) -> Result<()> {
        within(
            "frames_per_second",
            self.frames_per_second,
            FRAMES_PER_SECOND,
            " frames a second",
        )?;
        let pixels = u32::from(self.camera.width_px) * u32::from(self.camera.height_px);
        if pixels > MAX_IMAGE_PIXELS {
            bail!(
                "[camera]: {}x{} is {pixels} pixels, more than the limit of {MAX_IMAGE_PIXELS}",
                self.camera.width_px,
                self.camera.height_px
            );
        }
        if self.render.supersample == 0 || self.render.supersample > 8 {
            bail!("[render] supersample must be 1 to 8");
        }
        let r = &self.render;
        within(
            "[render] noise_dn",
            r.noise_dn,
            [0.0, 255.0],
            " grey levels",
        )?;
        within("[render] lane_width_m", r.lane_width_m, [0.5, 50.0], " m")?;
        within(
            "[render] texture_density",
            r.texture_density,
            [0.0, 100.0],
            "",
        )?;
        within(
            "[render] bare_half_width_m",
            r.bare_half_width_m,
            [0.0, MAX_EXTENT_M],
            " m",
        )?;
        self.check_path()?;
        at_most("[[speed]]", self.speed.len(), MAX_SPEED_KNOTS)?;
        check_speed_profile(&self.speed)?;
        for (i, k) in self.speed.iter().enumerate() {
            let key = |name| format!("[[speed]] {}: {name}", i + 1);
            within(&key("at_m"), k.at_m, plus_minus(MAX_PATH_M), " m")?;
            within(&key("speed_m_s"), k.speed_m_s, [0.0, MAX_SPEED_M_S], " m/s")?;
        }
        let sus = &self.suspension;
        for (key, x, range, unit) in [
            (
                "pitch_amplitude_deg",
                sus.pitch_amplitude_deg,
                plus_minus(MAX_ANGLE_DEG),
                " deg",
            ),
            (
                "roll_amplitude_deg",
                sus.roll_amplitude_deg,
                plus_minus(MAX_ANGLE_DEG),
                " deg",
            ),
            (
                "pitch_frequency_hz",
                sus.pitch_frequency_hz,
                [0.0, MAX_FREQUENCY_HZ],
                " Hz",
            ),
            (
                "roll_frequency_hz",
                sus.roll_frequency_hz,
                [0.0, MAX_FREQUENCY_HZ],
                " Hz",
            ),
        ] {
            within(&format!("[suspension] {key}"), x, range, unit)?;
        }
        self.check_vehicles()?;
        if let Some(slip) = &self.slip {
            within(
                "[slip] pivot_s2_per_m",
                slip.pivot_s2_per_m,
                [0.0, 1.0],
                " s^2/m",
            )?;
        }
        if let Some(k) = &self.kerb {
            within("[kerb] from_m", k.from_m, plus_minus(MAX_EXTENT_M), " m")?;
            within("[kerb] to_m", k.to_m, plus_minus(MAX_EXTENT_M), " m")?;
            within("[kerb] height_m", k.height_m, plus_minus(10.0), " m")?;
            if k.to_m <= k.from_m {
                bail!("[kerb]: to_m must be greater than from_m");
            }
        }
        if let Some(c) = &self.crown {
            within(
                "[crown] left_from_m",
                c.left_from_m,
                plus_minus(MAX_EXTENT_M),
                " m",
            )?;
            within(
                "[crown] right_from_m",
                c.right_from_m,
                plus_minus(MAX_EXTENT_M),
                " m",
            )?;
            within("[crown] left_slope", c.left_slope, plus_minus(1.0), "")?;
            within("[crown] right_slope", c.right_slope, plus_minus(1.0), "")?;
        }
        let e = &self.calibration_error;
        for (key, x, max, unit) in [
            ("x_m", e.x_m, 10.0, " m"),
            ("y_m", e.y_m, 10.0, " m"),
            ("height_m", e.height_m, 10.0, " m"),
            ("yaw_deg", e.yaw_deg, MAX_ANGLE_DEG, " deg"),
            ("pitch_deg", e.pitch_deg, MAX_ANGLE_DEG, " deg"),
            ("roll_deg", e.roll_deg, MAX_ANGLE_DEG, " deg"),
        ] {
            let key = format!("[calibration_error] {key}");
            within(&key, f64::from(x), plus_minus(max), unit)?;
        }
        self.check_structures()?;
        // The true mount must make a valid odometer configuration.
        self.mount_file(false)
            .to_config()
            .validate()
            .map_err(|e| anyhow::anyhow!("camera and mount: {e}"))?;
        Ok(())
    }

    /// The path's length, metres: the sum of its segments' (without integrating them).
    pub fn total_length_m(&self) -> f64 {
        let mut k_end = 0.0;
        self.segments
            .iter()
            .map(|seg| {
                let (length, _, k1) = segment_shape(seg, k_end);
                k_end = k1;
                length
            })
            .sum()
    }

    /// The path's segments: each of positive length, their sum at most [`MAX_PATH_M`], their
    /// curvature at most [`MAX_CURVATURE_PER_M`].
    fn check_path(&self) -> Result<()> {
        at_most("[[segment]]", self.segments.len(), MAX_SEGMENTS)?;
        if self.segments.is_empty() {
            bail!("the path has no [[segment]] entries");
        }
        let (mut total, mut k_end) = (0.0, 0.0);
        for (i, seg) in self.segments.iter().enumerate() {
            let key = |name| format!("[[segment]] {}: {name}", i + 1);
            if let Segment::Arc { radius_m, .. } = seg {
                within(
                    &key("radius_m"),
                    *radius_m,
                    [1.0 / MAX_CURVATURE_PER_M, f64::INFINITY],
                    " m",
                )?;
            }
            if let Segment::Clothoid {
                end_curvature_per_m,
                ..
            } = seg
            {
                let k = *end_curvature_per_m;
                within(
                    &key("end_curvature_per_m"),
                    k,
                    plus_minus(MAX_CURVATURE_PER_M),
                    " per m",
                )?;
            }
            let (length, _, k1) = segment_shape(seg, k_end);
            if !(length > 0.0 && length <= MAX_PATH_M) {
                bail!(
                    "[[segment]] {}: length {length} m is outside 0 (excluded) to {MAX_PATH_M} \
                     m, the limits of a scenario",
                    i + 1
                );
            }
            total += length;
            if total > MAX_PATH_M {
                bail!(
                    "[[segment]] 1 to {}: the path is {total} m long, more than the limit of \
                     {MAX_PATH_M} m",
                    i + 1
                );
            }
            k_end = k1;
        }
        Ok(())
    }

    fn check_vehicles(&self) -> Result<()> {
        at_most("[[vehicle]]", self.vehicles.len(), MAX_VEHICLES)?;
        for (i, v) in self.vehicles.iter().enumerate() {
            let key = |name| format!("[[vehicle]] {}: {name}", i + 1);
            let extent = plus_minus(MAX_EXTENT_M);
            let speed = plus_minus(MAX_SPEED_M_S);
            within(&key("lateral_m"), v.lateral_m, extent, " m")?;
            within(&key("ahead_m"), v.ahead_m, plus_minus(MAX_PATH_M), " m")?;
            within(&key("speed_m_s"), v.speed_m_s.unwrap_or(0.0), speed, " m/s")?;
            within(&key("cross_speed_m_s"), v.cross_speed_m_s, speed, " m/s")?;
            within(
                &key("appear_s"),
                v.appear_s,
                [f64::NEG_INFINITY, MAX_DRIVE_S],
                " s",
            )?;
            if v.disappear_s.is_nan() {
                bail!("{}: not a number", key("disappear_s"));
            }
            for (name, x) in [
                ("length_m", v.length_m),
                ("width_m", v.width_m),
                ("height_m", v.height_m),
            ] {
                within(&key(name), x, [0.01, MAX_EXTENT_M], " m")?;
            }
        }
        Ok(())
    }

    fn check_structures(&self) -> Result<()> {
        // A [min, max] range: ordered, from `floor` to MAX_EXTENT_M.
        let range = |table: &str, key: &str, r: [f64; 2], floor: f64| -> Result<()> {
            if !(r[0] >= floor && r[1] >= r[0] && r[1] <= MAX_EXTENT_M) {
                bail!(
                    "[{table}] {key} must be [min, max] with {floor} <= min <= max <= \
                     {MAX_EXTENT_M}, the limits of a scenario"
                );
            }
            Ok(())
        };
        let offset = |table: &str, x: f64| {
            within(
                &format!("[{table}] offset_m"),
                x,
                plus_minus(MAX_EXTENT_M),
                " m",
            )
        };
        let spacing = |table: &str, x: f64| {
            within(
                &format!("[{table}] spacing_m"),
                x,
                [1.0, MAX_EXTENT_M],
                " m",
            )
        };
        if let Some(f) = &self.facades {
            range("facades", "setback_m", f.setback_m, 0.0)?;
            range("facades", "length_m", f.length_m, 2.0)?;
            range("facades", "gap_m", f.gap_m, 0.0)?;
            range("facades", "height_m", f.height_m, 1.0)?;
            range("facades", "depth_m", f.depth_m, 1.0)?;
        }
        if let Some(p) = &self.poles {
            offset("poles", p.offset_m)?;
            spacing("poles", p.spacing_m)?;
            within("[poles] sign_fraction", p.sign_fraction, [0.0, 1.0], "")?;
        }
        if let Some(t) = &self.trees {
            offset("trees", t.offset_m)?;
            spacing("trees", t.spacing_m)?;
            range("trees", "height_m", t.height_m, 2.0)?;
        }
        if let Some(p) = &self.parked {
            offset("parked", p.offset_m)?;
            range("parked", "gap_m", p.gap_m, 0.0)?;
        }
        Ok(())
    }

    /// The mount file for this drive: the true mount, or with `with_error` the mount plus the
    /// scenario's calibration error (what `simulate` writes beside the images).
    pub fn mount_file(&self, with_error: bool) -> MountFile {
        let mut file = MountFile {
            camera: self.camera,
            mount: self.mount,
            settings: self.odometer,
        };
        if with_error {
            let e = &self.calibration_error;
            for (key, error) in [
                ("x_m", e.x_m),
                ("y_m", e.y_m),
                ("height_m", e.height_m),
                ("yaw_deg", e.yaw_deg),
                ("pitch_deg", e.pitch_deg),
                ("roll_deg", e.roll_deg),
            ] {
                file.set_mount_value(key, file.mount_value(key) + error);
            }
        }
        file
    }

    /// The scenario as TOML.
    pub fn to_toml(&self) -> Result<String> {
        Ok(toml::to_string(self)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_ins_parse_and_round_trip() {
        for name in BUILT_IN {
            let s = Scenario::built_in(name).unwrap();
            let again = Scenario::parse(&s.to_toml().unwrap(), name).unwrap();
            assert_eq!(s, again, "{name}");
        }
        assert!(Scenario::built_in("nope").is_err());
    }

    #[test]
    fn overlays_merge_tables_and_append_vehicles() {
        let s = Scenario::load("kitti-like", &["suspension".into(), "traffic".into()]).unwrap();
        assert_eq!(s.suspension.pitch_amplitude_deg, 0.5);
        assert!(!s.vehicles.is_empty());
        let plain = Scenario::built_in("kitti-like").unwrap();
        assert_eq!(s.segments, plain.segments);
        let twice = Scenario::load("kitti-like", &["traffic".into(), "traffic".into()]).unwrap();
        assert_eq!(twice.vehicles.len(), 2 * s.vehicles.len());
        assert!(Scenario::load("kitti-like", &["nope".into()]).is_err());
        let slip = Scenario::load("kitti-like", &["slip".into()]).unwrap();
        assert_eq!(slip.slip.map(|s| s.pivot_s2_per_m), Some(0.005));
        assert_eq!(plain.slip, None);
    }

    #[test]
    fn a_negative_slip_is_refused() {
        let mut text = Scenario::built_in_text("kitti-like").unwrap().to_string();
        text.push_str("\n[slip]\npivot_s2_per_m = -0.001\n");
        let err = Scenario::parse(&text, "test").unwrap_err();
        assert!(format!("{err:#}").contains("[slip]"), "{err}");
    }

    #[test]
    fn structures_are_off_unless_asked_for_and_checked() {
        for name in ["s-course", "kitti-like"] {
            let s = Scenario::built_in(name).unwrap();
            assert!(s.facades.is_none() && s.poles.is_none() && s.trees.is_none());
            assert!(s.parked.is_none());
            // Nothing about them in the scenario.toml written beside the frames.
            let text = s.to_toml().unwrap();
            assert!(
                !text.contains("facades") && !text.contains("parked"),
                "{text}"
            );
        }
        let mut text = Scenario::built_in_text("kitti-like").unwrap().to_string();
        text.push_str("\n[facades]\n[poles]\nsides = \"left\"\n[trees]\n[parked]\n");
        let s = Scenario::parse(&text, "test").unwrap();
        assert_eq!(s.facades, Some(Facades::default()));
        assert_eq!(s.poles.as_ref().map(|p| p.sides), Some(Sides::Left));
        assert_eq!(s.parked.as_ref().map(|p| p.sides), Some(Sides::Right));
        for (table, bad) in [
            ("facades", "height_m = [10.0, 5.0]"),
            ("facades", "setback_m = [-1.0, 5.0]"),
            ("trees", "height_m = [1.0, 5.0]"),
            ("poles", "sign_fraction = 1.5"),
            ("parked", "gap_m = [1.0, inf]"),
        ] {
            let mut text = Scenario::built_in_text("kitti-like").unwrap().to_string();
            text.push_str(&format!("\n[{table}]\n{bad}\n"));
            let err = Scenario::parse(&text, "test").unwrap_err();
            assert!(
                format!("{err:#}").contains(&format!("[{table}]")),
                "{bad}: {err}"
            );
        }
    }

    /// The error of kitti-like with `extra` appended (or its `from` replaced by `to`).
    fn refused(edit: &dyn Fn(&str) -> String) -> String {
        let text = edit(Scenario::built_in_text("kitti-like").unwrap());
        format!("{:#}", Scenario::parse(&text, "big.toml").unwrap_err())
    }

    #[test]
    fn lengths_speeds_counts_and_sizes_beyond_the_limits_are_refused_with_their_key() {
        let first_straight = "kind = \"straight\"\nlength_m = 60.0";
        for (edit, says) in [
            (
                (first_straight, "kind = \"straight\"\nlength_m = 1e7"),
                "big.toml: [[segment]] 1: length 10000000 m is outside 0 (excluded) to 20000 m, \
                 the limits of a scenario",
            ),
            (
                (first_straight, "kind = \"straight\"\nlength_m = 1e30"),
                "big.toml: [[segment]] 1: length 1000000000000000000000000000000 m is outside",
            ),
            (
                (first_straight, "kind = \"straight\"\nlength_m = 19900.0"),
                "big.toml: [[segment]] 1 to 5: the path is 20061.887902047863 m long, more than \
                 the limit of 20000 m",
            ),
            (
                ("radius_m = 40.0", "radius_m = 0.5"),
                "big.toml: [[segment]] 3: radius_m = 0.5 is less than 1 m, the limit of a scenario",
            ),
            (
                ("speed_m_s = 9.0", "speed_m_s = 1e9"),
                "big.toml: [[speed]] 1: speed_m_s = 1000000000 is outside 0 to 100 m/s",
            ),
            (
                ("frames_per_second = 10.0", "frames_per_second = 1e-9"),
                "big.toml: frames_per_second = 0.000000001 is outside 0.1 to 1000",
            ),
            (
                ("width_px = 1241", "width_px = 60000"),
                "big.toml: [camera]: 60000x376 is 22560000 pixels, more than the limit of 4194304",
            ),
        ] {
            let e = refused(&|t| t.replacen(edit.0, edit.1, 1));
            assert!(e.starts_with(says), "{edit:?}: {e}");
        }
        // The path's total is checked before it is integrated.
        let e = refused(&|t| t.replace("length_m = 80.0", "length_m = 15000.0"));
        assert!(e.contains("more than the limit of 20000 m"), "{e}");
        for (extra, says) in [
            (
                "[[vehicle]]\nlateral_m = 0.0\nahead_m = 10.0\nappear_s = 1e30\n",
                "big.toml: [[vehicle]] 1: appear_s = 1000000000000000000000000000000 is more \
                 than 3600 s, the limit of a scenario",
            ),
            (
                "[suspension]\npitch_frequency_hz = 1e300\n",
                "big.toml: [suspension] pitch_frequency_hz = 1000000",
            ),
            (
                "[trees]\nspacing_m = 1e6\n",
                "big.toml: [trees] spacing_m = 1000000 is outside 1 to 1000 m",
            ),
            (
                "[facades]\nheight_m = [6.0, 1e9]\n",
                "big.toml: [facades] height_m must be [min, max] with 1 <= min <= max <= 1000",
            ),
            (
                "[render]\nlane_width_m = 0.0\n",
                "big.toml: [render] lane_width_m = 0 is outside 0.5 to 50 m",
            ),
            (
                &"[[vehicle]]\nlateral_m = 0.0\nahead_m = 10.0\n".repeat(MAX_VEHICLES + 1),
                "big.toml: 33 [[vehicle]] entries, more than the limit of 32",
            ),
        ] {
            let e = refused(&|t| format!("{t}\n{extra}"));
            assert!(e.starts_with(says), "{extra}: {e}");
        }
    }

    #[test]
    fn a_scenario_file_over_its_size_limit_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("huge.toml");
        std::fs::File::create(&p)
            .unwrap()
            .set_len(crate::input::MAX_SCENARIO_BYTES + 1)
            .unwrap();
        let e = format!(
            "{:#}",
            Scenario::load(p.to_str().unwrap(), &[]).unwrap_err()
        );
        assert!(
            e.contains(
                "huge.toml: larger than 1 MiB (1048576 bytes) (the limit for a scenario file)"
            ),
            "{e}"
        );
    }

    #[test]
    fn town_turns_four_right_angles_between_its_speeds() {
        let s = Scenario::load("town", &["suspension".into(), "traffic".into()]).unwrap();
        assert_eq!((s.camera, s.mount), {
            let k = Scenario::built_in("kitti-like").unwrap();
            (k.camera, k.mount)
        });
        assert!(s.facades.is_some() && s.poles.is_some() && s.trees.is_some());
        assert!(s.parked.is_some() && s.render.texture_density <= 0.25);
        let path = crate::path::Path::new(&s.segments).unwrap();
        assert!(
            (400.0..500.0).contains(&path.length_m()),
            "{}",
            path.length_m()
        );
        // Left, right, right, left: back to the start's heading, a quarter turn at each.
        let end = path.pose_at(path.length_m());
        assert!(end.heading_rad.abs() < 1e-4, "{end:?}");
        let quarter = |a: f64, b: f64| path.pose_at(b).heading_rad - path.pose_at(a).heading_rad;
        assert!((quarter(35.0, 90.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-4);
        let speeds = s.speed.iter().map(|k| k.speed_m_s);
        assert!(speeds.clone().all(|v| (5.0..=12.0).contains(&v)));
    }

    #[test]
    fn s_course_is_the_papers() {
        let s = Scenario::built_in("s-course").unwrap();
        let path = crate::path::Path::new(&s.segments).unwrap();
        assert!((path.length_m() - 120.0).abs() < 1e-6);
        let end = path.pose_at(path.length_m());
        // Left 180 then right 180: heading back to zero.
        assert!(end.heading_rad.abs() < 1e-6, "{end:?}");
        assert!(
            (s.mount.pitch_rad + 20f32.to_radians()).abs() < 1e-6
                && (s.mount.height_m - 2.7).abs() < 1e-6
        );
    }
}
