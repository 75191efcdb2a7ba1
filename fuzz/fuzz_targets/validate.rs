//! `Config::validate` on arbitrary settings (every float any bit pattern: NaN, infinities,
//! subnormals), and an odometer on whatever passes, fed one frame of its size. Nothing may panic.
#![no_main]

use arbitrary::{Arbitrary, Unstructured};
use libfuzzer_sys::fuzz_target;
use roadvo::{
    Attitude, Config, Dynamics, GroundWindow, ImageSize, Intrinsics, Method, Mount, Odometer,
    PitchVoteSettings, SliceFrame,
};

fn config(u: &mut Unstructured) -> arbitrary::Result<Config> {
    let mut f = || f32::arbitrary(u);
    let floats: [f32; 31] = std::array::from_fn(|_| f().unwrap_or(0.0));
    Ok(Config {
        image: ImageSize {
            width_px: u.arbitrary()?,
            height_px: u.arbitrary()?,
        },
        intrinsics: Intrinsics {
            fx_px: floats[0],
            fy_px: floats[1],
            cx_px: floats[2],
            cy_px: floats[3],
        },
        mount: Mount {
            x_m: floats[4],
            y_m: floats[5],
            height_m: floats[6],
            yaw_rad: floats[7],
            pitch_rad: floats[8],
            roll_rad: floats[9],
        },
        attitude_bounds: Attitude {
            pitch_rad: floats[10],
            roll_rad: floats[11],
        },
        dynamics: Dynamics {
            max_heading_accel_rad_s2: floats[12],
            max_longitudinal_accel_m_s2: floats[13],
        },
        window: GroundWindow {
            near_m: floats[14],
            far_m: floats[15],
            half_width_m: floats[16],
        },
        features_per_side: u.arbitrary()?,
        track_max_misses: u.arbitrary()?,
        method: if u.arbitrary()? {
            Method::Paper
        } else {
            Method::PitchVote
        },
        pitch_vote: PitchVoteSettings {
            pitch_range_rad: floats[17],
            pitch_steps: u.arbitrary()?,
            max_pitch_change_steps: u.arbitrary()?,
            heading_half_rad: floats[18],
            distance_half_m: floats[19],
            lateral_tolerance_m: floats[20],
            corner_sigma_px: floats[24],
            roll_range_rad: floats[25],
            roll_steps: u.arbitrary()?,
            max_roll_change_steps: u.arbitrary()?,
            absolute_gain: floats[26],
            pitch_settle_s: floats[27],
            roll_settle_s: floats[30],
            prior_matches: floats[28],
            refine_heading: u.arbitrary()?,
            pivot_s2_per_m: floats[29],
            startup_heading_half_rad: floats[21],
            startup_distance_max_m: floats[22],
        },
        min_inlier_ratio: floats[23],
        corner_threshold: u.arbitrary()?,
    })
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let Ok(config) = config(&mut u) else {
        return;
    };
    let Ok(valid) = config.validate() else {
        return;
    };
    let Ok(mut odometer) = Odometer::<128, 32, 64>::new(valid).map(Box::new) else {
        return;
    };
    let size = valid.config().image;
    let (w, h) = (usize::from(size.width_px), usize::from(size.height_px));
    if w * h > 4 << 20 {
        return;
    }
    let pixels: Vec<u8> = (0..w * h).map(|i| ((i * 7919) >> 3) as u8).collect();
    let frame = SliceFrame::new(&pixels, w as u16, h as u16, w).expect("buffer fits");
    for t in [0, 100_000, 200_000] {
        let _ = odometer.process(&frame, t);
    }
});
