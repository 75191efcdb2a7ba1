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
        Self::parse(Self::built_in_text(name)?).with_context(|| format!("built-in scenario {name}"))
    }

    /// A scenario (built-in name or file) with overlays (built-in names or files) merged over
    /// it in order.
    pub fn load(name: &str, overlays: &[String]) -> Result<Self> {
        let text = |name: &str, builtin: &dyn Fn(&str) -> Option<&'static str>| -> Result<String> {
            let path = Path::new(name);
            match builtin(name) {
                Some(t) if !path.exists() => Ok(t.to_string()),
                _ => std::fs::read_to_string(path).with_context(|| {
                    format!(
                        "cannot read {} (and no built-in of that name)",
                        path.display()
                    )
                }),
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
        let s: Scenario = table
            .try_into()
            .with_context(|| format!("scenario {name} with overlays {overlays:?}"))?;
        s.check()?;
        Ok(s)
    }

    fn parse(text: &str) -> Result<Self> {
        let s: Scenario = toml::from_str(text)?;
        s.check()?;
        Ok(s)
    }

    fn check(&self) -> Result<()> {
        if !(self.frames_per_second.is_finite() && self.frames_per_second > 0.0) {
            bail!("frames_per_second must be positive");
        }
        if self.render.supersample == 0 || self.render.supersample > 8 {
            bail!("render.supersample must be 1 to 8");
        }
        let r = &self.render;
        if !(r.noise_dn >= 0.0 && r.texture_density >= 0.0 && r.bare_half_width_m >= 0.0) {
            bail!(
                "render.noise_dn, render.texture_density and render.bare_half_width_m must be >= 0"
            );
        }
        check_speed_profile(&self.speed)?;
        for (i, v) in self.vehicles.iter().enumerate() {
            if !(v.length_m > 0.0 && v.width_m > 0.0 && v.height_m > 0.0) {
                bail!("[[vehicle]] {}: sizes must be positive", i + 1);
            }
            if !v.cross_speed_m_s.is_finite() {
                bail!("[[vehicle]] {}: cross_speed_m_s must be finite", i + 1);
            }
        }
        if let Some(slip) = &self.slip
            && !(slip.pivot_s2_per_m.is_finite() && slip.pivot_s2_per_m >= 0.0)
        {
            bail!("[slip]: pivot_s2_per_m must be finite and >= 0");
        }
        if let Some(k) = &self.kerb
            && (k.to_m.is_nan() || k.to_m <= k.from_m)
        {
            bail!("[kerb]: to_m must be greater than from_m");
        }
        self.check_structures()?;
        // The true mount must make a valid odometer configuration.
        self.mount_file(false)
            .to_config()
            .validate()
            .map_err(|e| anyhow::anyhow!("camera and mount: {e}"))?;
        Ok(())
    }

    fn check_structures(&self) -> Result<()> {
        // A [min, max] range: finite, ordered, at least `floor`.
        let range = |table: &str, key: &str, r: [f64; 2], floor: f64| -> Result<()> {
            if !(r[0].is_finite() && r[1].is_finite() && r[0] >= floor && r[1] >= r[0]) {
                bail!("[{table}]: {key} must be [min, max] with {floor} <= min <= max");
            }
            Ok(())
        };
        let finite = |table: &str, key: &str, x: f64| -> Result<()> {
            if !x.is_finite() {
                bail!("[{table}]: {key} must be finite");
            }
            Ok(())
        };
        if let Some(f) = &self.facades {
            range("facades", "setback_m", f.setback_m, 0.0)?;
            range("facades", "length_m", f.length_m, 2.0)?;
            range("facades", "gap_m", f.gap_m, 0.0)?;
            range("facades", "height_m", f.height_m, 1.0)?;
            range("facades", "depth_m", f.depth_m, 1.0)?;
        }
        if let Some(p) = &self.poles {
            finite("poles", "offset_m", p.offset_m)?;
            if !(p.spacing_m.is_finite() && p.spacing_m >= 1.0) {
                bail!("[poles]: spacing_m must be at least 1");
            }
            if !(0.0..=1.0).contains(&p.sign_fraction) {
                bail!("[poles]: sign_fraction must be within 0 to 1");
            }
        }
        if let Some(t) = &self.trees {
            finite("trees", "offset_m", t.offset_m)?;
            if !(t.spacing_m.is_finite() && t.spacing_m >= 1.0) {
                bail!("[trees]: spacing_m must be at least 1");
            }
            range("trees", "height_m", t.height_m, 2.0)?;
        }
        if let Some(p) = &self.parked {
            finite("parked", "offset_m", p.offset_m)?;
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
            let again = Scenario::parse(&s.to_toml().unwrap()).unwrap();
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
        let err = Scenario::parse(&text).unwrap_err();
        assert!(err.to_string().contains("[slip]"), "{err}");
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
        let s = Scenario::parse(&text).unwrap();
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
            let err = Scenario::parse(&text).unwrap_err();
            assert!(
                err.to_string().contains(&format!("[{table}]")),
                "{bad}: {err}"
            );
        }
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
