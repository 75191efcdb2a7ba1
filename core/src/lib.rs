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
//! use roadvo::{Config, ImageSize, Intrinsics, Mount, Odometer, SliceFrame};
//!
//! // The camera and where it sits; every other setting keeps its documented default.
//! let image = ImageSize { width_px: 1241, height_px: 376 };
//! let intrinsics = Intrinsics { fx_px: 718.856, fy_px: 718.856, cx_px: 607.19, cy_px: 185.22 };
//! let mount = Mount { x_m: 1.2, y_m: 0.0, height_m: 1.65, yaw_rad: 0.0, pitch_rad: 0.0, roll_rad: 0.0 };
//! let config = Config::with_defaults(image, intrinsics, mount).validate()?;
//! // All state in one value: 45 KiB with the default capacities.
//! let mut odometer: Odometer = Odometer::new(config)?;
//! let pixels = vec![0u8; 1241 * 376]; // a camera buffer
//! let frame = SliceFrame::new(&pixels, 1241, 376, 1241).expect("buffer holds the frame");
//! let estimate = odometer.process(&frame, 0).expect("first frame");
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
//! ## Modules, in the order the method uses them
//! - [`config`]: the settings, validated once into a [`ValidConfig`].
//! - [`projection`]: camera intrinsics, the mount, and the ground-plane homographies that turn a
//!   pixel into a point on the road, or into the quadrilateral where it may lie given the body's
//!   attitude on its suspension (paper §2.1).
//! - [`motion`]: the Ackermann arc between frames, planar poses, and the lift of a planar pose to
//!   a KITTI camera pose (paper §2.2).
//! - [`frame`]: the [`Frame`] trait through which images arrive, a row at a time.
//! - [`harris`]: integer Harris corners inside the ground window, the strongest per side.
//! - [`comoving`]: the corners that stand still in the image while the vehicle moves (a vehicle
//!   ahead at our speed), set aside before the default method's vote.
//! - [`vote`]: the motion window and the integer accumulator over it (paper §2.3).
//! - [`pitch_vote`]: the default method, a joint vote over pitch, heading change and distance.
//! - [`paper`]: the paper's method as written, for comparison.
//! - [`tracks`]: the pool of tracked ground features.
//! - [`odometer`]: [`Odometer::process`], the per-frame flow through all of the above.
//! - [`smoother`]: an optional fixed-lag smoother of the heading, fed the odometer's estimates.
#![no_std]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

pub mod comoving;
pub mod config;
pub mod frame;
pub mod harris;
pub mod motion;
pub mod odometer;
pub mod paper;
pub mod pitch_vote;
pub mod projection;
pub mod smoother;
mod sort;
pub mod tracks;
pub mod vote;

pub use config::{
    Config, ConfigError, Dynamics, GroundWindow, ImageRoi, ImageSize, Method, PitchVoteSettings,
    ValidConfig,
};
pub use frame::{Frame, SliceFrame};
pub use harris::{Corner, Corners, HarrisScratch};
pub use motion::{CameraLift, CameraPose, Motion, Pose2};
pub use odometer::{Estimate, FrameError, Odometer, Quality};
pub use projection::{
    Attitude, GroundPoint, GroundProjection, Homography, Intrinsics, Mount, Pixel, Quad, RollMap,
};
pub use smoother::{Smoother, SmootherError};
