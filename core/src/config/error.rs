//! Why a configuration was refused.

use crate::setting::Field;
use core::fmt;

/// Why a [`Config`](crate::Config) was refused, or an odometer could not take it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// A number is NaN or infinite; `field` names it (the core's name, see
    /// [`Config::field`](crate::Config::field) for its key in a mount file).
    NonFinite {
        /// The setting's name.
        field: &'static str,
    },
    /// A setting is outside its range (see its documentation, or `docs/mount-file.md`).
    OutOfRange {
        /// The setting's name.
        field: &'static str,
    },
    /// Width or height of the image is zero.
    EmptyImage,
    /// A focal length is zero or negative.
    FocalLengthNotPositive,
    /// A focal length gives a field of view outside [`MIN_FIELD_OF_VIEW_DEG`]..
    /// [`MAX_FIELD_OF_VIEW_DEG`] across the image, or the principal point lies more than a
    /// frame's width or height outside the image, or the lens's distortion does not invert over
    /// the frame (field `k1`: it folds the image, [`crate::lens`]): not a camera that sees a
    /// road.
    ///
    /// [`MIN_FIELD_OF_VIEW_DEG`]: crate::config::MIN_FIELD_OF_VIEW_DEG
    /// [`MAX_FIELD_OF_VIEW_DEG`]: crate::config::MAX_FIELD_OF_VIEW_DEG
    ImplausibleCamera {
        /// The setting's name (`fx_px`, `fy_px`, `cx_px`, `cy_px`, or `k1` for the
        /// distortion).
        field: &'static str,
    },
    /// The camera is at or below the road (`mount.height_m <= 0`).
    CameraNotAboveGround,
    /// A count of attitude hypotheses is even: level must be one of them.
    EvenHypotheses {
        /// The setting's name.
        field: &'static str,
    },
    /// The ground window is empty: its far end is not beyond its near end.
    EmptyWindow,
    /// The camera sees the road plane edge-on, so no homography exists.
    DegenerateGeometry,
    /// The far end of the ground window is not in the image (behind the camera, above the horizon
    /// under the attitude bounds, or outside the frame).
    RoiOutsideImage,
    /// The ground window's image is narrower or shorter than
    /// [`MIN_ROI_PX`](crate::config::MIN_ROI_PX) pixels: too few to find corners in.
    RoiTooSmall,
    /// A setting asks for more than the odometer's capacity (a const generic parameter).
    ExceedsCapacity {
        /// The setting's name.
        field: &'static str,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite { field } => write!(f, "{} is not a finite number", key(field)),
            Self::OutOfRange { field } => {
                write!(f, "{} is out of range", key(field))?;
                match crate::Config::field(field) {
                    Some(d) => write_range(f, d),
                    None => Ok(()),
                }
            }
            Self::EmptyImage => f.write_str("image width and height must be at least 1 pixel"),
            Self::FocalLengthNotPositive => f.write_str("focal lengths must be positive"),
            Self::ImplausibleCamera { field } if field.starts_with('f') => write!(
                f,
                "{} gives a field of view outside {}..{} deg across the image: \
                 check the focal length against the frame's size",
                key(field),
                crate::config::MIN_FIELD_OF_VIEW_DEG,
                crate::config::MAX_FIELD_OF_VIEW_DEG
            ),
            Self::ImplausibleCamera { field } if field.starts_with('k') => f.write_str(
                "the lens distortion (k1, k2, p1, p2, k3) does not map the frame one to one: \
                 check the coefficients against the calibration",
            ),
            Self::ImplausibleCamera { field } => write!(
                f,
                "{} puts the principal point more than a frame outside the image",
                key(field)
            ),
            Self::CameraNotAboveGround => {
                f.write_str("the camera must be above the road (height_m > 0)")
            }
            Self::EvenHypotheses { field } => write!(
                f,
                "{} must be odd, so that level is one of the hypotheses",
                key(field)
            ),
            Self::EmptyWindow => {
                f.write_str("the ground window is empty: window_far_m must be beyond window_near_m")
            }
            Self::DegenerateGeometry => f.write_str("the camera sees the road plane edge-on"),
            Self::RoiOutsideImage => f.write_str(
                "the far end of the ground window is not visible in the image \
                 (behind the camera, above the horizon, or outside the frame)",
            ),
            Self::RoiTooSmall => write!(
                f,
                "the ground window covers less than {0}x{0} pixels of the image",
                crate::config::MIN_ROI_PX
            ),
            Self::ExceedsCapacity { field } => {
                write!(f, "{} exceeds the odometer's capacity", key(field))
            }
        }
    }
}

impl core::error::Error for ConfigError {}

/// A setting's key in a mount file, from its name in the core.
fn key(name: &str) -> &str {
    crate::Config::field(name).map_or(name, |d| d.key)
}

/// ` (between a and b)`, in the file's unit.
fn write_range(f: &mut fmt::Formatter<'_>, d: &Field) -> fmt::Result {
    let low = if d.min_exclusive { "above" } else { "at least" };
    match (d.min, d.max) {
        (Some(lo), Some(hi)) if !d.min_exclusive => write!(f, ": between {lo} and {hi}"),
        (Some(lo), Some(hi)) => write!(f, ": above {lo}, at most {hi}"),
        (Some(lo), None) => write!(f, ": {low} {lo}"),
        (None, Some(hi)) => write!(f, ": at most {hi}"),
        (None, None) => Ok(()),
    }
}
