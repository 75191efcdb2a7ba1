//! roadvo on a Cortex-M7: the configuration an ECU would hold, validated once at start-up, then
//! the geometry the odometer runs on every frame. The engine's per-frame loop joins this once it
//! exists; for now the example proves that the core links and runs without std or a heap.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use panic_halt as _;
use roadvo::{
    Attitude, Config, Dynamics, GroundWindow, ImageSize, Intrinsics, Method, Motion, Mount,
    PitchVoteSettings, Pixel, Pose2,
};

/// The KITTI camera 0 with the paper's settings.
fn kitti_config() -> Config {
    const DEG: f32 = core::f32::consts::PI / 180.0;
    Config {
        image: ImageSize {
            width_px: 1241,
            height_px: 376,
        },
        intrinsics: Intrinsics {
            fx_px: 718.856,
            fy_px: 718.856,
            cx_px: 607.1928,
            cy_px: 185.2157,
        },
        mount: Mount {
            x_m: 1.2,
            y_m: 0.0,
            height_m: 1.65,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
            roll_rad: 0.0,
        },
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
