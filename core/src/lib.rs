//! # roadvo: monocular visual odometry for road vehicles
//!
//! One ordinary camera that sees the road ahead (or behind) gives the vehicle's planar trajectory
//! and its per-frame motion at metric scale, after Van Hamme et al., "Robust monocular visual
//! odometry for road vehicles using uncertain perspective projection" (EURASIP JIVP, 2015).
//!
//! The crate is `#![no_std]` without `alloc`: every buffer is sized by const generics and lives in
//! the caller's value, and every fallible call returns its error as a value. Floats are `f32`
//! computed through `libm`, never through a platform's float functions, so the host and a
//! Cortex-M7 give bit-identical results.
//!
//! ## Use
//! ```
//! use roadvo::{Camera, Config, Instant, Mount, Odometer, SliceFrame};
//!
//! // The camera and where it sits; every other setting keeps its documented default.
//! let camera = Camera {
//!     width_px: 1241, height_px: 376,
//!     fx_px: 718.856, fy_px: 718.856, cx_px: 607.19, cy_px: 185.22,
//!     ..Camera::DEFAULT // no lens distortion
//! };
//! let mount = Mount { x_m: 1.2, height_m: 1.65, ..Mount::DEFAULT };
//! let config = Config::with_defaults(camera, mount).validate()?;
//! // All state in one value (the README's results give its size).
//! let mut odometer: Odometer = Odometer::new(config)?;
//! let pixels = vec![0u8; 1241 * 376]; // a camera buffer
//! let frame = SliceFrame::new(&pixels, 1241, 376, 1241).expect("buffer holds the frame");
//! let estimate = odometer.process(&frame, Instant::from_micros(0)).expect("first frame");
//! assert!(estimate.quality.startup);
//! # Ok::<(), roadvo::ConfigError>(())
//! ```
//!
//! ## On a microcontroller
//! The odometer is too large for a small stack: keep it in a `static` initialised with
//! [`Odometer::UNCONFIGURED`] (every byte zero, so it lands in `.bss` and costs no flash) and
//! [`configure`](Odometer::configure) it in place at start-up. A camera need deliver only the rows
//! [`ValidConfig::rows_read`] names. `firmware-example/` in the repository does both on a
//! Cortex-M7, and proves its estimates bit-identical to the host's under QEMU.
//!
//! `micromath` was weighed and left out: its approximations (a square root off by up to 5%)
//! would bend the geometry and break the agreement between host and target.
//!
//! ## Modules, in the order the method uses them
//! - [`config`]: the settings ([`setting`] defines each once), validated once into a
//!   [`ValidConfig`]; the ground window and its image.
//! - [`frame`]: the [`Frame`] trait through which images arrive, a row at a time; [`time`]:
//!   the frames' [`Instant`]s.
//! - [`projection`]: camera intrinsics, the mount, and the ground-plane homographies that turn a
//!   pixel into a point on the road, or into the quadrilateral where it may lie given the body's
//!   attitude on its suspension (paper §2.1).
//! - [`lens`]: the lens's distortion (OpenCV's radial-tangential model): corner positions
//!   undistorted to the ideal image before they become rays or road points.
//! - [`harris`]: integer Harris corners inside the ground window, the strongest per side.
//! - [`heading`]: the heading change from corners over the whole image: FAST corners, patches
//!   matched between frames, a consensus over the planar motion's epipolar constraint.
//! - [`motion`]: the Ackermann arc between frames, planar poses, and the lift of a planar pose to
//!   a KITTI camera pose (paper §2.2).
//! - [`vote`]: the motion window and the integer accumulator over it (paper §2.3).
//! - [`method`]: the estimators, each in a room of its own: [`method::pitch_vote`] (the default,
//!   a joint vote over the body's attitude, heading change and distance) and [`method::paper`]
//!   (the paper's method as written).
//! - [`tracks`]: the pool of tracked ground features.
//! - [`ground_patches`]: the ground's matched corners found again by patch, pairs for the road's
//!   plane.
//! - [`odometer`]: [`Odometer::process`], the per-frame flow through all of the above.
//! - [`smoother`]: an optional fixed-lag smoother of the heading, fed the odometer's estimates.
//! - [`wire`]: the byte layouts shared with tools: a recorded drive for the firmware, the trace
//!   of estimates compared bit for bit.
#![no_std]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

pub mod calibration;
pub mod config;
pub mod frame;
pub mod ground_patches;
pub mod harris;
pub mod heading;
pub mod lens;
pub mod method;
pub mod motion;
pub mod odometer;
pub mod projection;
pub mod road_distance;
pub mod road_heading;
pub mod running_mean;
pub mod setting;
pub mod smoother;
mod sort;
#[cfg(test)]
mod test_rng;
pub mod time;
pub mod tracks;
pub mod vote;
pub mod wire;

pub use calibration::{AngleEstimate, Calibration, CalibrationError, Learned, LearnedLine};
pub use config::{Config, ConfigError, ImageRoi, Method, Settings, ValidConfig};
pub use frame::{Frame, ImageSize, SliceFrame};
pub use harris::{Corner, Corners, HarrisScratch};
pub use motion::{CameraLift, CameraPose, Motion, Pose2};
pub use odometer::{Estimate, FrameError, Odometer, Quality};
pub use projection::{
    Attitude, Camera, GroundPoint, GroundProjection, Homography, Mount, Pixel, Quad, RollMap,
};
pub use smoother::{Smoother, SmootherError};
pub use time::{Duration, Instant};
