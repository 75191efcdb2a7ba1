//! The mount file (`mount.toml`): a vehicle's camera, its mount and the odometer's settings, as a
//! user writes them. Angles are in degrees here (radians in the core); every `[odometer]` entry is
//! optional and defaults to the paper's value. `[camera]` may be left out where the sequence
//! carries its calibration (KITTI's `calib.txt` and the frames' size): one mount file then serves
//! every sequence of a vehicle, whatever its image size (`mounts/kitti.toml`).
//!
//! ```toml
//! [camera]            # pinhole intrinsics of the rectified image
//! width_px = 1241
//! height_px = 376
//! fx_px = 718.856
//! fy_px = 718.856
//! cx_px = 607.1928
//! cy_px = 185.2157
//!
//! [mount]             # camera centre in the vehicle frame (origin on the road under the
//! x_m = 1.0           # rear-axle centre, x forward, y left, z up) and its orientation
//! y_m = 0.0
//! height_m = 1.65
//! yaw_deg = 0.0       # 180 for a rear-facing camera
//! pitch_deg = 0.0     # positive looking up
//! roll_deg = 0.0      # positive lifts the camera's left side
//!
//! [odometer]
//! method = "default"                  # or "paper": the paper's method as written
//! pitch_bound_deg = 1.0               # body pitch on the suspension, each side (paper: 1)
//! roll_bound_deg = 2.0                # body roll, each side (paper: 2)
//! max_heading_accel_deg_s2 = 10.0     # paper: 10
//! max_longitudinal_accel_m_s2 = 1.5   # paper: 1.5
//! window_near_m = 0.0                 # 0: where the image ends
//! window_far_m = 12.0                 # paper, KITTI: 12
//! window_half_width_m = 3.0           # paper, KITTI: 3
//! features_per_side = 32              # paper: 32
//! track_max_misses = 5                # paper: 3 to 5
//! corner_threshold = 2000             # smallest Harris response (Sobel^4 / 2^16)
//! min_inlier_ratio = 0.125            # below: keep the previous motion (paper: 1/8)
//! pitch_range_deg = 1.0               # default method: pitch hypotheses over +-1 deg
//! pitch_steps = 21                    #   in 0.1 deg steps
//! max_pitch_change_steps = 5          #   at most 0.5 deg between frames
//! heading_window_deg = 1.0            #   heading change window, per frame
//! distance_window_m = 0.15            #   distance window, per frame
//! lateral_tolerance_m = 0.04          #   largest residual that votes
//! ```

use crate::kitti::Sequence;
use anyhow::{Context, Result, bail};
use roadvo::{
    Attitude, Config, Dynamics, GroundWindow, ImageSize, Intrinsics, Method, Mount,
    PitchVoteSettings,
};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `[camera]`: image size and pinhole intrinsics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    /// Columns.
    pub width_px: u16,
    /// Rows.
    pub height_px: u16,
    /// Horizontal focal length, pixels.
    pub fx_px: f32,
    /// Vertical focal length, pixels.
    pub fy_px: f32,
    /// Principal point column, pixels.
    pub cx_px: f32,
    /// Principal point row, pixels.
    pub cy_px: f32,
}

/// `[mount]`: camera position and orientation in the vehicle frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountSection {
    /// Ahead of the rear-axle centre, metres.
    pub x_m: f32,
    /// Left of the centre line, metres.
    #[serde(default)]
    pub y_m: f32,
    /// Above the road, metres.
    pub height_m: f32,
    /// Degrees, counter-clockwise; 180 faces backwards.
    #[serde(default)]
    pub yaw_deg: f32,
    /// Degrees, positive up.
    #[serde(default)]
    pub pitch_deg: f32,
    /// Degrees, positive lifts the camera's left side.
    #[serde(default)]
    pub roll_deg: f32,
}

/// The estimator, as written in the file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum MethodName {
    /// The joint pitch, heading and distance vote.
    #[default]
    Default,
    /// The paper's method as written.
    Paper,
}

impl MethodName {
    /// The core's method.
    pub fn to_core(self) -> Method {
        match self {
            Self::Default => Method::PitchVote,
            Self::Paper => Method::Paper,
        }
    }
}

/// `[odometer]`: the method's settings; each defaults to the paper's value, or for the default
/// method's own settings to BRIEF §7's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OdometerSection {
    /// `"default"` or `"paper"`.
    pub method: MethodName,
    /// Body pitch bound each side, degrees.
    pub pitch_bound_deg: f32,
    /// Body roll bound each side, degrees.
    pub roll_bound_deg: f32,
    /// Heading acceleration limit, deg/s^2.
    pub max_heading_accel_deg_s2: f32,
    /// Longitudinal acceleration limit, m/s^2.
    pub max_longitudinal_accel_m_s2: f32,
    /// Near cutoff, metres ahead of the camera (0: the image's edge).
    pub window_near_m: f32,
    /// Far cutoff, metres ahead of the camera.
    pub window_far_m: f32,
    /// Lateral cutoff each side, metres.
    pub window_half_width_m: f32,
    /// Corners per side of straight ahead.
    pub features_per_side: u16,
    /// Frames a track survives unmatched.
    pub track_max_misses: u8,
    /// Smallest Harris response of a corner (see the core's `Config::corner_threshold`).
    pub corner_threshold: u32,
    /// Below this share of matched tracks per detected feature, keep the previous motion.
    pub min_inlier_ratio: f32,
    /// Default method: pitch hypotheses span +- this, degrees.
    pub pitch_range_deg: f32,
    /// Default method: number of pitch hypotheses (odd).
    pub pitch_steps: u8,
    /// Default method: largest pitch change between frames, in pitch steps.
    pub max_pitch_change_steps: u8,
    /// Default method: heading window half width per frame, degrees.
    pub heading_window_deg: f32,
    /// Default method: distance window half width per frame, metres.
    pub distance_window_m: f32,
    /// Default method: largest lateral residual that votes, metres.
    pub lateral_tolerance_m: f32,
    /// Default method: standard deviation of a corner's row, pixels (0: one bin a pair).
    pub corner_sigma_px: f32,
    /// Default method: roll hypotheses span +- this, degrees.
    pub roll_range_deg: f32,
    /// Default method: number of roll hypotheses (odd; 1: no roll search).
    pub roll_steps: u8,
    /// Default method: largest roll change between frames, in roll steps.
    pub max_roll_change_steps: u8,
    /// Default method: share of the measured common pitch error applied each frame.
    pub absolute_gain: f32,
    /// Default method: time constant of the pitch's return to level, seconds (0: never).
    pub pitch_settle_s: f32,
    /// Default method: time constant of the roll's return to level, seconds (0: never).
    pub roll_settle_s: f32,
    /// Default method: how many matched tracks the previous motion weighs as (0: none).
    pub prior_matches: f32,
    /// Default method: the heading from the matched pairs' residuals across the chord alone,
    /// refined after the vote (false: the vote's).
    pub refine_heading: bool,
    /// Default method: the pivot the vehicle's arc is drawn from lies this many s^2/m times the
    /// speed squared ahead of the rear axle (tyre slip; 0: the rear axle).
    pub pivot_s2_per_m: f32,
    /// Default method: frames of lag of the trajectory's heading smoother (0: none, the
    /// odometer's own estimates; see the core's `smoother`). Not the core's setting: the host
    /// feeds the odometer's estimates through a `Smoother`.
    pub smooth_lag_frames: u8,
}

impl Default for OdometerSection {
    /// The core's defaults ([`Config::with_defaults`]), in the file's units.
    fn default() -> Self {
        let c = Config::with_defaults(ImageSize::ZERO, Intrinsics::ZERO, Mount::ZERO);
        let pv = &c.pitch_vote;
        Self {
            method: MethodName::Default,
            pitch_bound_deg: c.attitude_bounds.pitch_rad.to_degrees(),
            roll_bound_deg: c.attitude_bounds.roll_rad.to_degrees(),
            max_heading_accel_deg_s2: c.dynamics.max_heading_accel_rad_s2.to_degrees(),
            max_longitudinal_accel_m_s2: c.dynamics.max_longitudinal_accel_m_s2,
            window_near_m: c.window.near_m,
            window_far_m: c.window.far_m,
            window_half_width_m: c.window.half_width_m,
            features_per_side: c.features_per_side,
            track_max_misses: c.track_max_misses,
            corner_threshold: c.corner_threshold,
            min_inlier_ratio: c.min_inlier_ratio,
            pitch_range_deg: pv.pitch_range_rad.to_degrees(),
            pitch_steps: pv.pitch_steps,
            max_pitch_change_steps: pv.max_pitch_change_steps,
            heading_window_deg: pv.heading_half_rad.to_degrees(),
            distance_window_m: pv.distance_half_m,
            lateral_tolerance_m: pv.lateral_tolerance_m,
            corner_sigma_px: pv.corner_sigma_px,
            roll_range_deg: pv.roll_range_rad.to_degrees(),
            roll_steps: pv.roll_steps,
            max_roll_change_steps: pv.max_roll_change_steps,
            absolute_gain: pv.absolute_gain,
            pitch_settle_s: pv.pitch_settle_s,
            roll_settle_s: pv.roll_settle_s,
            prior_matches: pv.prior_matches,
            refine_heading: pv.refine_heading,
            pivot_s2_per_m: pv.pivot_s2_per_m,
            smooth_lag_frames: 0,
        }
    }
}

impl CameraSection {
    /// The camera of a KITTI-layout sequence: `P0` of its `calib.txt` and its frames' size.
    pub fn of_sequence(seq: &Sequence) -> Result<Self> {
        let (w, h) = seq.size;
        let size = |v: u32, what| {
            u16::try_from(v)
                .with_context(|| format!("{} frames are {v} pixels {what}", seq.dir.display()))
        };
        Ok(Self {
            width_px: size(w, "wide")?,
            height_px: size(h, "high")?,
            fx_px: seq.p0[0] as f32,
            fy_px: seq.p0[5] as f32,
            cx_px: seq.p0[2] as f32,
            cy_px: seq.p0[6] as f32,
        })
    }
}

/// A mount file as written: `[camera]` may be missing.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MountFileText {
    #[serde(skip_serializing_if = "Option::is_none")]
    camera: Option<CameraSection>,
    mount: MountSection,
    #[serde(default)]
    odometer: OdometerSection,
}

/// A whole mount file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountFile {
    /// `[camera]`.
    pub camera: CameraSection,
    /// `[mount]`.
    pub mount: MountSection,
    /// `[odometer]`.
    #[serde(default)]
    pub odometer: OdometerSection,
}

impl MountFile {
    /// Reads and parses a mount file; errors name the file, and the line for syntax errors. A
    /// file without `[camera]` takes `camera` (a sequence's calibration), and is refused without.
    pub fn read(path: &Path, camera: Option<&CameraSection>) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read mount file {}", path.display()))?;
        let file: MountFileText =
            toml::from_str(&text).with_context(|| format!("in mount file {}", path.display()))?;
        let Some(camera) = file.camera.or_else(|| camera.cloned()) else {
            bail!(
                "mount file {} has no [camera] section, and there is no sequence to take the \
                 camera from",
                path.display()
            );
        };
        Ok(Self {
            camera,
            mount: file.mount,
            odometer: file.odometer,
        })
    }

    /// Writes the file with a header that says what it is, and `note` (comment lines) after it.
    /// Without `with_camera` the `[camera]` section is left out: each sequence's calibration
    /// then supplies it.
    pub fn write(&self, path: &Path, with_camera: bool, note: &str) -> Result<()> {
        let body = toml::to_string(&MountFileText {
            camera: with_camera.then(|| self.camera.clone()),
            mount: self.mount.clone(),
            odometer: self.odometer.clone(),
        })?;
        let text = format!(
            "# roadvo mount file: camera intrinsics, camera mount in the vehicle frame (origin on\n\
             # the road under the rear-axle centre, x forward, y left, z up; angles in degrees)\n\
             # and odometer settings. Format: see host-sim/src/mount.rs or the README.\n{note}\n{body}"
        );
        std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Sets one value as a line of the file would: `KEY=VALUE` in `[odometer]`, or
    /// `SECTION.KEY=VALUE` in `[camera]`, `[mount]` or `[odometer]`, the value written as in the
    /// file (`0`, `0.5`, `"paper"`, or a bare word for text): the `--set` option, for trying a
    /// setting without editing a file. Errors say which assignment and what was expected;
    /// nothing changes on an error.
    pub fn set(&mut self, assignment: &str) -> Result<()> {
        let context = || format!("--set {assignment}");
        let Some((path, value)) = assignment.split_once('=') else {
            bail!(
                "{}: expected KEY=VALUE, e.g. max_roll_change_steps=0",
                context()
            );
        };
        let path = path.trim();
        let (section, key) = path.split_once('.').unwrap_or(("odometer", path));
        // A word without quotes is taken as text (`method=paper`), as a shell user writes it.
        let value = value.trim();
        let value = toml::from_str::<toml::Table>(&format!("value = {value}"))
            .ok()
            .and_then(|mut t| t.remove("value"))
            .unwrap_or_else(|| toml::Value::String(value.to_owned()));
        let mut file = toml::Table::try_from(&*self)?;
        let Some(table) = file.get_mut(section).and_then(toml::Value::as_table_mut) else {
            bail!(
                "{}: no section [{section}] (camera, mount or odometer)",
                context()
            );
        };
        match table.get_mut(key) {
            Some(slot) => *slot = value,
            None => bail!(
                "{}: [{section}] has no key `{key}` (see the README's mount file)",
                context()
            ),
        }
        *self = file.try_into().with_context(context)?;
        Ok(())
    }

    /// The core's configuration (not yet validated).
    pub fn to_config(&self) -> Config {
        let (c, o) = (&self.camera, &self.odometer);
        Config {
            image: ImageSize {
                width_px: c.width_px,
                height_px: c.height_px,
            },
            intrinsics: Intrinsics {
                fx_px: c.fx_px,
                fy_px: c.fy_px,
                cx_px: c.cx_px,
                cy_px: c.cy_px,
            },
            mount: self.mount.to_core(),
            attitude_bounds: Attitude {
                pitch_rad: o.pitch_bound_deg.to_radians(),
                roll_rad: o.roll_bound_deg.to_radians(),
            },
            dynamics: Dynamics {
                max_heading_accel_rad_s2: o.max_heading_accel_deg_s2.to_radians(),
                max_longitudinal_accel_m_s2: o.max_longitudinal_accel_m_s2,
            },
            window: GroundWindow {
                near_m: o.window_near_m,
                far_m: o.window_far_m,
                half_width_m: o.window_half_width_m,
            },
            features_per_side: o.features_per_side,
            track_max_misses: o.track_max_misses,
            corner_threshold: o.corner_threshold,
            method: o.method.to_core(),
            pitch_vote: PitchVoteSettings {
                pitch_range_rad: o.pitch_range_deg.to_radians(),
                pitch_steps: o.pitch_steps,
                max_pitch_change_steps: o.max_pitch_change_steps,
                heading_half_rad: o.heading_window_deg.to_radians(),
                distance_half_m: o.distance_window_m,
                lateral_tolerance_m: o.lateral_tolerance_m,
                corner_sigma_px: o.corner_sigma_px,
                roll_range_rad: o.roll_range_deg.to_radians(),
                roll_steps: o.roll_steps,
                max_roll_change_steps: o.max_roll_change_steps,
                absolute_gain: o.absolute_gain,
                pitch_settle_s: o.pitch_settle_s,
                roll_settle_s: o.roll_settle_s,
                prior_matches: o.prior_matches,
                refine_heading: o.refine_heading,
                pivot_s2_per_m: o.pivot_s2_per_m,
                ..PitchVoteSettings::default()
            },
            min_inlier_ratio: o.min_inlier_ratio,
        }
    }
}

impl MountSection {
    /// The core's mount, angles in radians.
    pub fn to_core(&self) -> Mount {
        Mount {
            x_m: self.x_m,
            y_m: self.y_m,
            height_m: self.height_m,
            yaw_rad: self.yaw_deg.to_radians(),
            pitch_rad: self.pitch_deg.to_radians(),
            roll_rad: self.roll_deg.to_radians(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KITTI: &str = r#"
[camera]
width_px = 1241
height_px = 376
fx_px = 718.856
fy_px = 718.856
cx_px = 607.1928
cy_px = 185.2157

[mount]
x_m = 1.0
height_m = 1.65
"#;

    #[test]
    fn minimal_file_takes_paper_defaults_and_validates() {
        let f: MountFile = toml::from_str(KITTI).unwrap();
        assert_eq!(f.odometer, OdometerSection::default());
        let c = f.to_config();
        assert_eq!(c.features_per_side, 32);
        assert!((f.odometer.pitch_bound_deg - 1.0).abs() < 1e-5);
        assert!((f.odometer.max_heading_accel_deg_s2 - 10.0).abs() < 1e-4);
        // The file's defaults are the core's, through the unit conversions.
        let core = Config::with_defaults(c.image, c.intrinsics, c.mount);
        assert!((c.attitude_bounds.roll_rad - core.attitude_bounds.roll_rad).abs() < 1e-7);
        assert_eq!(c.pitch_vote.pitch_steps, core.pitch_vote.pitch_steps);
        c.validate().unwrap();
    }

    #[test]
    fn written_file_reads_back() {
        let f: MountFile = toml::from_str(KITTI).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mount.toml");
        f.write(&p, true, "").unwrap();
        assert_eq!(MountFile::read(&p, None).unwrap(), f);
    }

    #[test]
    fn a_file_without_camera_takes_the_sequence_camera_or_says_it_has_none() {
        let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../mounts/kitti.toml");
        let seq_camera: MountFile = toml::from_str(KITTI).unwrap();
        let f = MountFile::read(Path::new(shipped), Some(&seq_camera.camera)).unwrap();
        assert_eq!(f.camera, seq_camera.camera);
        assert_eq!(f.mount.height_m, 1.565);
        f.to_config().validate().unwrap();
        let e = format!(
            "{:#}",
            MountFile::read(Path::new(shipped), None).unwrap_err()
        );
        assert!(
            e.contains("kitti.toml") && e.contains("no [camera] section"),
            "{e}"
        );
    }

    #[test]
    fn a_setting_changes_one_value_as_a_line_of_the_file_would() {
        let mut f: MountFile = toml::from_str(KITTI).unwrap();
        let before = f.clone();
        f.set("max_roll_change_steps=0").unwrap();
        f.set(" mount.roll_deg = 1.5 ").unwrap();
        f.set("odometer.method=\"paper\"").unwrap();
        f.set("method=paper").unwrap();
        // An integer where the file holds a decimal, as a file may write it.
        f.set("pitch_settle_s=2").unwrap();
        assert_eq!(f.odometer.max_roll_change_steps, 0);
        assert_eq!(f.mount.roll_deg, 1.5);
        assert_eq!(f.odometer.method, MethodName::Paper);
        assert_eq!(f.odometer.pitch_settle_s, 2.0);
        f.odometer = before.odometer.clone();
        f.mount.roll_deg = before.mount.roll_deg;
        assert_eq!(f, before);
    }

    #[test]
    fn a_bad_setting_says_which_and_why_and_changes_nothing() {
        let mut f: MountFile = toml::from_str(KITTI).unwrap();
        let before = f.clone();
        for (assignment, says) in [
            ("max_roll_change_steps", "expected KEY=VALUE"),
            ("max_roll_change=0", "no key `max_roll_change`"),
            ("wheels.x_m=1", "no section [wheels]"),
            ("roll_steps=-1", "--set roll_steps=-1"),
            ("method=fast", "--set method=fast"),
            ("mount.height_m=tall", "--set mount.height_m"),
        ] {
            let e = format!("{:#}", f.set(assignment).unwrap_err());
            assert!(e.contains(says), "{assignment}: {e}");
        }
        assert_eq!(f, before);
    }

    #[test]
    fn unknown_key_is_reported_with_its_line() {
        let bad = KITTI.replace("height_m = 1.65", "height_m = 1.65\nheigth = 2");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mount.toml");
        std::fs::write(&p, bad).unwrap();
        let e = format!("{:#}", MountFile::read(&p, None).unwrap_err());
        assert!(e.contains("mount.toml") && e.contains("heigth"), "{e}");
        assert!(e.contains("line 13"), "{e}");
    }
}
