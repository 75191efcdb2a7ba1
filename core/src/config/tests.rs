use super::*;
use crate::projection::{GroundPoint, Pixel};

const DEG: f32 = core::f32::consts::PI / 180.0;

/// The KITTI camera 0 with the paper's KITTI settings.
pub(crate) fn kitti_config() -> Config {
    Config::with_defaults(
        Camera::KITTI_00,
        Mount {
            x_m: 1.0,
            y_m: 0.0,
            height_m: 1.65,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
            roll_rad: 0.0,
        },
    )
}

#[test]
fn kitti_config_is_valid_and_roi_is_the_lower_band() {
    let v = kitti_config().validate().unwrap();
    let roi = v.roi();
    // Far cutoff 11 m ahead of a 1.65 m camera: row cy + f * 1.65 / 12 = 284.
    assert!((283..=285).contains(&roi.top_px), "{roi:?}");
    assert_eq!(roi.bottom_px, 375);
    assert!(roi.left_px > 0 && roi.right_px < 1240, "{roi:?}");
    assert!(v.in_window(GroundPoint { x_m: 8.0, y_m: 1.0 }));
    assert!(!v.in_window(GroundPoint {
        x_m: 14.0,
        y_m: 0.0
    }));
    assert!(!v.in_window(GroundPoint {
        x_m: 8.0,
        y_m: -3.5
    }));
    // The whole frame for the heading from the whole image; else the ground window's rows.
    assert_eq!(v.rows_read(), 0..376);
    let mut ground_only = kitti_config();
    ground_only.settings.image_heading = false;
    assert_eq!(
        ground_only.validate().unwrap().rows_read(),
        roi.top_px - 3..376
    );
}

#[test]
fn a_wide_lens_s_roi_holds_the_window_as_the_lens_draws_it() {
    let mut c = kitti_config();
    (c.camera.k1, c.camera.k2) = (-0.3, 0.1);
    let v = c.validate().unwrap();
    let (roi, pinhole_roi) = (v.roi(), kitti_config().validate().unwrap().roi());
    // Barrel distortion draws the window nearer the centre: its far edge (below the centre)
    // higher; and more of the road is seen to the sides.
    assert!(roi.top_px < pinhole_roi.top_px, "{roi:?} {pinhole_roi:?}");
    assert!(roi.left_px < pinhole_roi.left_px, "{roi:?} {pinhole_roi:?}");
    let k = &c.camera;
    for ahead in [3.0, 6.0, 9.0, 12.0] {
        for left in [-3.0, -1.5, 0.0, 1.5, 3.0] {
            let p = v.window_point(ahead, left);
            let Some(ideal) = v.projection().nominal.project(p) else {
                continue;
            };
            let px = k.distort(ideal);
            let in_frame = (0.0..=1240.0).contains(&px.u_px) && (0.0..=375.0).contains(&px.v_px);
            if in_frame {
                let (u, row) = (px.u_px, px.v_px);
                assert!(
                    f32::from(roi.left_px) <= u && u <= f32::from(roi.right_px),
                    "{px:?}"
                );
                assert!(
                    f32::from(roi.top_px) <= row && row <= f32::from(roi.bottom_px),
                    "{px:?}"
                );
            }
        }
    }
}

#[test]
fn roi_rows_hold_every_window_pixel_of_their_columns() {
    // Level, and a mount turned and tilted so that the window's image is skewed.
    for (yaw, pitch, roll) in [(0.0, 0.0, 0.0), (4.0, -2.0, 1.5), (-6.0, 1.0, -2.0)] {
        let mut c = kitti_config();
        (c.mount.yaw_rad, c.mount.pitch_rad, c.mount.roll_rad) =
            (yaw * DEG, pitch * DEG, roll * DEG);
        let v = c.validate().unwrap();
        let roi = v.roi();
        let mut fewer = false;
        for left in (roi.left_px..=roi.right_px).step_by(64) {
            let right = (left + 63).min(roi.right_px);
            let rows = v.roi_rows(left, right);
            let (top, bottom) = rows.unwrap_or((u16::MAX, 0));
            fewer |= rows.is_some_and(|(t, b)| b - t < roi.bottom_px - roi.top_px);
            for u in left..=right {
                for row in roi.top_px..=roi.bottom_px {
                    // Anywhere within half a pixel of the pixel's centre.
                    for (du, dv) in [(-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5), (0.5, 0.5)] {
                        let px = Pixel {
                            u_px: f32::from(u) + du,
                            v_px: f32::from(row) + dv,
                        };
                        let inside = v
                            .projection()
                            .nominal
                            .backproject(px)
                            .is_some_and(|g| v.in_window(g));
                        assert!(
                            !inside || (top..=bottom).contains(&row),
                            "pixel ({u}, {row}) of columns {left}..={right} outside rows \
                             {rows:?} (mount {yaw}/{pitch}/{roll} deg)"
                        );
                    }
                }
            }
        }
        assert!(fewer, "no band narrower than the ROI: {roi:?}");
    }
}

#[test]
fn every_bad_value_has_its_error() {
    let ok = kitti_config();
    let check = |f: &dyn Fn(&mut Config), want: ConfigError| {
        let mut c = ok;
        f(&mut c);
        assert_eq!(c.validate().unwrap_err(), want);
    };
    let non_finite = |field| ConfigError::NonFinite { field };
    let out_of_range = |field| ConfigError::OutOfRange { field };
    check(&|c| c.camera.cx_px = f32::NAN, non_finite("cx_px"));
    check(
        &|c| c.settings.window_far_m = f32::INFINITY,
        non_finite("window_far_m"),
    );
    check(
        &|c| c.settings.pitch_settle_s = f32::NAN,
        non_finite("pitch_settle_s"),
    );
    check(&|c| c.camera.width_px = 0, ConfigError::EmptyImage);
    check(
        &|c| c.camera.fx_px = 0.0,
        ConfigError::FocalLengthNotPositive,
    );
    check(
        &|c| c.camera.fy_px = -700.0,
        ConfigError::FocalLengthNotPositive,
    );
    let implausible = |field| ConfigError::ImplausibleCamera { field };
    check(&|c| c.camera.fx_px = 1.0, implausible("fx_px"));
    check(&|c| c.camera.fy_px = 1e5, implausible("fy_px"));
    check(&|c| c.camera.cx_px = -1e4, implausible("cx_px"));
    check(&|c| c.camera.cy_px = 1e4, implausible("cy_px"));
    // A lens whose polynomial folds within the frame.
    check(&|c| c.camera.k1 = -3.0, implausible("k1"));
    check(&|c| c.camera.k1 = -11.0, out_of_range("k1"));
    check(
        &|c| c.mount.height_m = 0.0,
        ConfigError::CameraNotAboveGround,
    );
    check(
        &|c| c.mount.height_m = -1.0,
        ConfigError::CameraNotAboveGround,
    );
    check(&|c| c.mount.roll_rad = 1e30, out_of_range("roll_rad"));
    check(
        &|c| c.settings.roll_bound_rad = -0.1,
        out_of_range("roll_bound_rad"),
    );
    check(
        &|c| c.settings.max_longitudinal_accel_m_s2 = 0.0,
        out_of_range("max_longitudinal_accel_m_s2"),
    );
    check(
        &|c| c.settings.window_far_m = 0.0,
        out_of_range("window_far_m"),
    );
    check(
        &|c| c.settings.window_half_width_m = 0.0,
        out_of_range("window_half_width_m"),
    );
    check(
        &|c| c.settings.window_near_m = 13.0,
        ConfigError::EmptyWindow,
    );
    check(
        &|c| c.settings.features_per_side = 0,
        out_of_range("features_per_side"),
    );
    check(
        &|c| c.settings.track_max_misses = 0,
        out_of_range("track_max_misses"),
    );
    check(
        &|c| c.settings.pitch_steps = 20,
        ConfigError::EvenHypotheses {
            field: "pitch_steps",
        },
    );
    check(&|c| c.settings.roll_steps = 17, out_of_range("roll_steps"));
    check(
        &|c| c.settings.lateral_tolerance_m = 0.0,
        out_of_range("lateral_tolerance_m"),
    );
    check(
        &|c| c.settings.corner_sigma_px = -0.5,
        out_of_range("corner_sigma_px"),
    );
    check(
        &|c| c.settings.min_inlier_ratio = 1.5,
        out_of_range("min_inlier_ratio"),
    );
    // Settings that may be 0 but not negative, nor infinite or NaN.
    type FieldRef = fn(&mut Config) -> &mut f32;
    let not_negative: [(FieldRef, &str); 3] = [
        (|c| &mut c.settings.roll_settle_s, "roll_settle_s"),
        (|c| &mut c.settings.prior_matches, "prior_matches"),
        (|c| &mut c.settings.pivot_s2_per_m, "pivot_s2_per_m"),
    ];
    for (value, field) in not_negative {
        for bad in [f32::NAN, f32::INFINITY] {
            check(&|c| *value(c) = bad, non_finite(field));
        }
        check(&|c| *value(c) = -0.001, out_of_range(field));
        let mut c = ok;
        *value(&mut c) = 0.0;
        assert!(c.validate().is_ok(), "{field} = 0");
    }
    // Looking up at the sky: the window is above the frame.
    check(
        &|c| c.mount.pitch_rad = 30.0 * DEG,
        ConfigError::RoiOutsideImage,
    );
    // A far cutoff beyond the horizon once the body pitches up by the bound.
    check(
        &|c| c.settings.window_far_m = 150.0,
        ConfigError::RoiOutsideImage,
    );
    // A frame too small to hold the window.
    check(
        &|c| {
            (c.camera.width_px, c.camera.height_px) = (100, 100);
            (c.camera.cx_px, c.camera.cy_px) = (50.0, 50.0);
        },
        ConfigError::RoiOutsideImage,
    );
    // A window so narrow that its image is a sliver of the frame.
    check(
        &|c| c.settings.window_half_width_m = 0.01,
        ConfigError::RoiTooSmall,
    );
}

#[test]
fn rear_camera_window_lies_behind_the_vehicle() {
    let mut c = kitti_config();
    c.mount.x_m = -0.8;
    c.mount.yaw_rad = core::f32::consts::PI;
    let v = c.validate().unwrap();
    assert!(v.in_window(GroundPoint {
        x_m: -6.0,
        y_m: 0.0
    }));
    assert!(!v.in_window(GroundPoint { x_m: 6.0, y_m: 0.0 }));
}

#[test]
fn errors_say_the_file_key_and_the_range() {
    let e = ConfigError::NonFinite { field: "x_m" };
    assert_eq!(std::format!("{e}"), "x_m is not a finite number");
    let e = ConfigError::OutOfRange {
        field: "roll_bound_rad",
    };
    assert_eq!(
        std::format!("{e}"),
        "roll_bound_deg is out of range: between 0 and 10"
    );
    let e = ConfigError::OutOfRange {
        field: "window_far_m",
    };
    assert_eq!(
        std::format!("{e}"),
        "window_far_m is out of range: above 0, at most 200"
    );
}

#[test]
fn settings_by_key_convert_degrees_and_refuse_what_does_not_fit() {
    use crate::setting::{SetError, Value};
    let mut s = Settings::DEFAULT;
    assert_eq!(s.get("heading_window_deg"), Some(Value::F32(1.0)));
    assert_eq!(s.heading_window_rad, DEG);
    s.set("heading_window_deg", Value::F32(2.0)).unwrap();
    assert_eq!(s.heading_window_rad, 2.0f32.to_radians());
    // An integer where a real number is written, as a file may.
    s.set("prior_matches", Value::U32(2)).unwrap();
    assert_eq!(s.prior_matches, 2.0);
    assert_eq!(
        s.set("pitch_steps", Value::U32(300)),
        Err(SetError::WrongType)
    );
    assert_eq!(
        s.set("pitch_steps", Value::F32(3.0)),
        Err(SetError::WrongType)
    );
    assert_eq!(
        s.set("refine_heading", Value::U8(1)),
        Err(SetError::WrongType)
    );
    assert_eq!(
        s.set("no_such_key", Value::U8(1)),
        Err(SetError::UnknownKey)
    );
    s.set("method", Value::Method(Method::Paper)).unwrap();
    assert_eq!(s.method, Method::Paper);
    // Every key reads back what its default says, and every name has a key.
    for f in Settings::FIELDS {
        let v = Settings::DEFAULT.get(f.key).unwrap();
        let mut t = Settings::ZERO;
        t.set(f.key, v).unwrap();
        assert_eq!(t.get(f.key), Some(v), "{}", f.key);
        assert_eq!(Config::field(f.name), Some(f));
    }
}

#[test]
fn the_defaults_are_valid_and_zero_is_all_zero_bits() {
    assert!(Settings::DEFAULT.check_ranges().is_ok());
    assert!(Settings::DEFAULT.check_finite().is_ok());
    for f in Settings::FIELDS {
        let v = Settings::ZERO.get(f.key).unwrap();
        let zero = match v {
            crate::setting::Value::F32(x) => x.to_bits() == 0,
            crate::setting::Value::U8(x) => x == 0,
            crate::setting::Value::U16(x) => x == 0,
            crate::setting::Value::U32(x) => x == 0,
            crate::setting::Value::Bool(b) => !b,
            crate::setting::Value::Method(m) => m == Method::PitchVote,
        };
        assert!(zero, "{}", f.key);
    }
}
