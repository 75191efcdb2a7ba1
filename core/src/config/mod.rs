//! The odometer's configuration, checked once: [`Config::validate`] turns a [`Config`] into a
//! [`ValidConfig`] holding everything derived from it (the ground homographies, the image of the
//! ground window), so that no invalid setting and no per-config computation reaches the
//! per-frame path.
//!
//! A configuration is the camera ([`Camera`]), where it sits ([`Mount`]) and how the odometer runs
//! ([`Settings`]): the three sections of a mount file. Every setting is
//! defined once, with its unit, default and range (`docs/mount-file.md` lists them all).

mod error;
mod settings;
mod window;

pub use error::ConfigError;
pub use settings::{MAX_PITCH_HYPOTHESES, MAX_ROLL_HYPOTHESES, Method, Settings};
pub(crate) use window::inside_border;
pub use window::{DETECTOR_BORDER_PX, ImageRoi, MIN_ROI_PX};

use crate::motion::CameraLift;
use crate::projection::{Attitude, Camera, GroundProjection, Homography, Mount, RollMap};
use crate::setting::Field;
use window::WindowImage;

/// Everything the odometer needs to know, in physical units. Build one, then
/// [`validate`](Config::validate) it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The camera: frame size and intrinsics.
    pub camera: Camera,
    /// Camera extrinsics on the vehicle.
    pub mount: Mount,
    /// How the odometer runs.
    pub settings: Settings,
}

/// A [`Config`] that passed validation, with what is derived from it once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValidConfig {
    config: Config,
    projection: GroundProjection,
    lift: CameraLift,
    window: WindowImage,
}

impl Config {
    /// A configuration for a camera and its mount, every setting at its documented default.
    pub fn with_defaults(camera: Camera, mount: Mount) -> Self {
        Self {
            camera,
            mount,
            settings: Settings::DEFAULT,
        }
    }

    /// The description of the setting the core calls `name` (a field of [`Camera`], [`Mount`]
    /// or [`Settings`]), as [`ConfigError`] names it.
    pub fn field(name: &str) -> Option<&'static Field> {
        [Camera::FIELDS, Mount::FIELDS, Settings::FIELDS]
            .into_iter()
            .flatten()
            .find(|f| f.name == name)
    }

    /// The body's attitude bounds each side of level (paper §2.1).
    pub fn attitude_bounds(&self) -> Attitude {
        Attitude {
            pitch_rad: self.settings.pitch_bound_rad,
            roll_rad: self.settings.roll_bound_rad,
        }
    }

    /// Checks every setting and derives the homographies and the ground window's image.
    pub fn validate(self) -> Result<ValidConfig, ConfigError> {
        let (k, m, s) = (&self.camera, &self.mount, &self.settings);
        let non_finite = |field| ConfigError::NonFinite { field };
        k.check_finite().map_err(non_finite)?;
        m.check_finite().map_err(non_finite)?;
        s.check_finite().map_err(non_finite)?;
        if k.width_px == 0 || k.height_px == 0 {
            return Err(ConfigError::EmptyImage);
        }
        if k.fx_px <= 0.0 || k.fy_px <= 0.0 {
            return Err(ConfigError::FocalLengthNotPositive);
        }
        check_intrinsics(k)?;
        if m.height_m <= 0.0 {
            return Err(ConfigError::CameraNotAboveGround);
        }
        let out_of_range = |field| ConfigError::OutOfRange { field };
        k.check_ranges().map_err(out_of_range)?;
        m.check_ranges().map_err(out_of_range)?;
        s.check_ranges().map_err(out_of_range)?;
        if !k.is_pinhole() && k.ideal_frame_bounds().is_none() {
            return Err(ConfigError::ImplausibleCamera { field: "k1" });
        }
        if s.window_far_m <= s.window_near_m {
            return Err(ConfigError::EmptyWindow);
        }
        for (steps, field) in [(s.pitch_steps, "pitch_steps"), (s.roll_steps, "roll_steps")] {
            if steps % 2 == 0 {
                return Err(ConfigError::EvenHypotheses { field });
            }
        }
        let projection = GroundProjection::new(k, m, self.attitude_bounds())
            .ok_or(ConfigError::DegenerateGeometry)?;
        // The pitch vote's hypotheses (built again when an odometer takes the configuration).
        for i in 0..usize::from(s.pitch_steps) {
            let attitude = Attitude {
                pitch_rad: hypothesis_rad(s.pitch_range_rad, s.pitch_steps, i),
                roll_rad: 0.0,
            };
            Homography::new(k, m, attitude).ok_or(ConfigError::DegenerateGeometry)?;
        }
        for i in 0..usize::from(s.roll_steps) {
            let roll_rad = hypothesis_rad(s.roll_range_rad, s.roll_steps, i);
            RollMap::new(k, m, roll_rad).ok_or(ConfigError::DegenerateGeometry)?;
        }
        let mut valid = ValidConfig {
            config: self,
            projection,
            lift: CameraLift::new(m),
            window: WindowImage::ZERO,
        };
        valid.window = WindowImage::of(&valid).ok_or(ConfigError::RoiOutsideImage)?;
        let roi = valid.window.roi;
        if roi.right_px - roi.left_px < MIN_ROI_PX || roi.bottom_px - roi.top_px < MIN_ROI_PX {
            return Err(ConfigError::RoiTooSmall);
        }
        Ok(valid)
    }
}

/// The narrowest field of view a camera may have across its frame's width or height, degrees.
pub const MIN_FIELD_OF_VIEW_DEG: f32 = 1.0;
/// The widest field of view across a frame's width or height, degrees: beyond this a pinhole
/// model cannot hold the image.
pub const MAX_FIELD_OF_VIEW_DEG: f32 = 170.0;

/// Focal lengths that give a field of view between the bounds, and a principal point within a
/// frame of the image.
fn check_intrinsics(k: &Camera) -> Result<(), ConfigError> {
    let axes = [
        (k.width_px, k.fx_px, k.cx_px, "fx_px", "cx_px"),
        (k.height_px, k.fy_px, k.cy_px, "fy_px", "cy_px"),
    ];
    for (size_px, focal_px, centre_px, focal, centre) in axes {
        let size_px = f32::from(size_px);
        let fov_deg = 2.0 * libm::atanf(size_px / (2.0 * focal_px)) / crate::setting::RAD_PER_DEG;
        if !(MIN_FIELD_OF_VIEW_DEG..=MAX_FIELD_OF_VIEW_DEG).contains(&fov_deg) {
            return Err(ConfigError::ImplausibleCamera { field: focal });
        }
        if !(-size_px..=2.0 * size_px).contains(&centre_px) {
            return Err(ConfigError::ImplausibleCamera { field: centre });
        }
    }
    Ok(())
}

/// Angle of hypothesis `i` of `steps` spread evenly over +-`range_rad`, level in the middle.
pub(crate) fn hypothesis_rad(range_rad: f32, steps: u8, i: usize) -> f32 {
    let half = (usize::from(steps) / 2) as f32;
    if half == 0.0 {
        0.0
    } else {
        range_rad * (i as f32 - half) / half
    }
}

impl ValidConfig {
    /// No configuration, all zeros (a 0x0 frame, no geometry): the placeholder of an
    /// unconfigured odometer, so that one can be a zero-initialised `static`. Validation never
    /// produces it (a valid frame has pixels).
    pub(crate) const UNSET: Self = Self {
        config: Config {
            camera: Camera::ZERO,
            mount: Mount::ZERO,
            settings: Settings::ZERO,
        },
        projection: GroundProjection {
            nominal: Homography::ZERO,
            extremes: [Homography::ZERO; 4],
        },
        lift: CameraLift::ZERO,
        window: WindowImage::ZERO,
    };

    /// Whether this is a validated configuration rather than [`Self::UNSET`].
    pub(crate) fn is_set(&self) -> bool {
        self.config.camera.width_px != 0
    }

    /// The configuration as given.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The settings as given.
    pub fn settings(&self) -> &Settings {
        &self.config.settings
    }

    /// The nominal and extremal-attitude homographies.
    pub fn projection(&self) -> &GroundProjection {
        &self.projection
    }

    /// Lifts planar poses to KITTI camera poses through the mount.
    pub fn lift(&self) -> &CameraLift {
        &self.lift
    }
}

#[cfg(test)]
pub(crate) mod tests;
