//! roadvo on a Cortex-M7: the configuration an ECU would hold, validated once at start-up, then
//! the geometry the odometer runs on every frame. The engine's per-frame loop joins this once it
//! exists; for now the example proves that the core links and runs without std or a heap.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use panic_halt as _;
use roadvo::{Config, ImageSize, Intrinsics, Motion, Mount, Pixel, Pose2};

/// The KITTI camera 0 with the default settings.
fn kitti_config() -> Config {
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
            x_m: 1.2,
            y_m: 0.0,
            height_m: 1.65,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
            roll_rad: 0.0,
        },
    )
}

#[entry]
fn main() -> ! {
    let valid = match kitti_config().validate() {
        Ok(v) => v,
        // A real ECU reports the error; the example stops where a debugger sees it.
        Err(_) => loop {
            cortex_m::asm::bkpt();
        },
    };
    let roi = valid.roi();
    let corner = Pixel {
        u_px: f32::from(roi.left_px + roi.right_px) * 0.5,
        v_px: f32::from(roi.bottom_px),
    };
    let quad = valid.projection().observe(corner);
    let pose = Pose2::IDENTITY.advance(Motion {
        heading_change_rad: 0.01,
        distance_m: 1.0,
    });
    core::hint::black_box((quad, pose));
    loop {
        cortex_m::asm::wfi();
    }
}
