//! `Odometer::process` on arbitrary frames: sizes (right or wrong), contents, timestamps (repeated,
//! decreasing, huge gaps) and cameras, with either method. Nothing may panic.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use roadvo::{Camera, Config, Instant, Method, Mount, Odometer, SliceFrame};

/// A camera drawn from plausible ranges, so that most inputs validate and reach the vote.
#[derive(Arbitrary, Debug)]
struct Rig {
    width: u16,
    height: u16,
    focal: u8,
    cx: u8,
    cy: u8,
    height_cm: u8,
    pitch: i8,
    yaw: i8,
    roll: i8,
    paper: bool,
}

#[derive(Arbitrary, Debug)]
struct Shot {
    /// Microseconds after the previous frame (negative and zero included).
    step_us: i32,
    /// Tiled over the frame.
    pattern: Vec<u8>,
    /// Shift of the pattern, pixels, so consecutive frames can move.
    shift: u16,
    /// Deliver a frame one column too narrow.
    wrong_size: bool,
}

#[derive(Arbitrary, Debug)]
struct Input {
    camera: Rig,
    shots: Vec<Shot>,
}

fn config(c: &Rig) -> Config {
    let (w, h) = (16 + c.width % 1300, 16 + c.height % 400);
    let (wf, hf) = (f32::from(w), f32::from(h));
    let mut config = Config::with_defaults(
        Camera {
            width_px: w,
            height_px: h,
            fx_px: wf * (0.2 + f32::from(c.focal) / 100.0),
            fy_px: wf * (0.2 + f32::from(c.focal) / 100.0),
            cx_px: wf * f32::from(c.cx) / 255.0,
            cy_px: hf * f32::from(c.cy) / 255.0,
            ..Camera::DEFAULT
        },
        Mount {
            x_m: 1.0,
            y_m: 0.0,
            height_m: 0.2 + f32::from(c.height_cm) / 100.0,
            yaw_rad: f32::from(c.yaw).to_radians() * 1.5,
            pitch_rad: f32::from(c.pitch).to_radians() * 0.3,
            roll_rad: f32::from(c.roll).to_radians() * 0.1,
        },
    );
    if c.paper {
        config.settings.method = Method::Paper;
    }
    config
}

fuzz_target!(|input: Input| {
    let Ok(valid) = config(&input.camera).validate() else {
        return;
    };
    let Ok(mut odometer) = Odometer::<128, 32, 64>::new(valid).map(Box::new) else {
        return;
    };
    let size = valid.config().camera;
    let (w, h) = (usize::from(size.width_px), usize::from(size.height_px));
    let mut pixels = vec![0u8; w * h];
    let mut t: u64 = 1_000_000;
    for shot in input.shots.iter().take(8) {
        if !shot.pattern.is_empty() {
            for (i, p) in pixels.iter_mut().enumerate() {
                *p = shot.pattern[(i + usize::from(shot.shift)) % shot.pattern.len()];
            }
        }
        t = t.saturating_add_signed(i64::from(shot.step_us));
        let width = if shot.wrong_size { w - 1 } else { w };
        let frame = SliceFrame::new(&pixels, width as u16, h as u16, w).expect("buffer fits");
        let before = odometer.pose();
        match odometer.process(&frame, Instant::from_micros(t)) {
            Ok(e) => assert!(e.pose.x_m.is_finite() && e.pose.heading_rad.is_finite()),
            Err(_) => assert_eq!(odometer.pose(), before),
        }
    }
});
