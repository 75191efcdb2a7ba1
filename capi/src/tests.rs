//! The API through its C signatures, from Rust: storage checks, a refused configuration and its
//! reason, frames through a strided buffer and through a row function, every status named.

use super::*;
use roadvo::wire::config_words;
use roadvo::{Camera, Config, Learned, LearnedLine, Mount};

/// Storage as a C program declares it.
#[repr(C, align(8))]
struct Storage([u8; ROADVO_ODOMETER_SIZE]);

fn kitti() -> Config {
    let camera = Camera::KITTI_00;
    let mount = Mount {
        x_m: 1.0,
        height_m: 1.65,
        ..Mount::DEFAULT
    };
    Config::with_defaults(camera, mount)
}

fn new_odometer(storage: &mut Storage) -> *mut RoadvoOdometer {
    let mut odo = core::ptr::null_mut();
    // SAFETY: the storage outlives the odometer in each test.
    let s =
        unsafe { roadvo_odometer_init(storage.0.as_mut_ptr().cast(), storage.0.len(), &mut odo) };
    assert_eq!(s, RoadvoStatus::Ok);
    odo
}

fn describe(odo: *const RoadvoOdometer) -> String {
    let mut text = [0 as c_char; 160];
    // SAFETY: a live odometer and a buffer of that size.
    let n = unsafe { roadvo_describe(odo, text.as_mut_ptr(), text.len()) };
    let bytes: Vec<u8> = text[..n].iter().map(|&c| c as u8).collect();
    String::from_utf8(bytes).unwrap()
}

#[test]
fn sizes_are_those_the_header_exports() {
    println!(
        "size_of::<RoadvoOdometer>() = {} of ROADVO_ODOMETER_SIZE {}",
        size_of::<RoadvoOdometer>(),
        ROADVO_ODOMETER_SIZE
    );
    assert_eq!(roadvo_odometer_size(), ROADVO_ODOMETER_SIZE);
}

#[test]
fn storage_that_is_small_misaligned_or_null_is_refused() {
    let mut storage = Box::new(Storage([0; ROADVO_ODOMETER_SIZE]));
    let mut odo = core::ptr::null_mut();
    let p: *mut c_void = storage.0.as_mut_ptr().cast();
    // SAFETY: the pointers are live or NULL, the sizes theirs.
    unsafe {
        assert_eq!(
            roadvo_odometer_init(p, ROADVO_ODOMETER_SIZE - 1, &mut odo),
            RoadvoStatus::StorageTooSmall
        );
        let off = p.cast::<u8>().add(1).cast();
        assert_eq!(
            roadvo_odometer_init(off, ROADVO_ODOMETER_SIZE - 1, &mut odo),
            RoadvoStatus::StorageTooSmall
        );
        assert_eq!(
            roadvo_odometer_init(core::ptr::null_mut(), 1 << 20, &mut odo),
            RoadvoStatus::NullPointer
        );
    }
    let mut big = vec![0u64; ROADVO_ODOMETER_SIZE / 8 + 2];
    let misaligned = big.as_mut_ptr().cast::<u8>().wrapping_add(4).cast();
    // SAFETY: inside `big`, which has room for the size given.
    let s = unsafe { roadvo_odometer_init(misaligned, ROADVO_ODOMETER_SIZE, &mut odo) };
    assert_eq!(s, RoadvoStatus::StorageMisaligned);
}

#[test]
fn a_bad_configuration_is_refused_with_its_reason() {
    let mut storage = Box::new(Storage([0; ROADVO_ODOMETER_SIZE]));
    let odo = new_odometer(&mut storage);
    let mut nan = kitti();
    nan.mount.height_m = f32::NAN;
    let mut outside = kitti();
    outside.mount.pitch_rad = 30f32.to_radians();
    let mut bad_word = config_words(&kitti());
    bad_word[Camera::WORDS + Mount::WORDS] = 9; // the method
    for (words, status, says) in [
        (
            config_words(&nan),
            RoadvoStatus::NonFinite,
            "height_m is not a finite number",
        ),
        (
            config_words(&outside),
            RoadvoStatus::RoiOutsideImage,
            "ground window is not visible",
        ),
        (
            bad_word,
            RoadvoStatus::ConfigBadWord,
            "makes no value of its setting's type",
        ),
    ] {
        // SAFETY: a live odometer, `words` holds the count given.
        let s = unsafe { roadvo_configure(odo, words.as_ptr(), words.len()) };
        assert_eq!(s, status);
        let text = describe(odo);
        assert!(text.contains(says), "{text}");
    }
    let good = config_words(&kitti());
    // SAFETY: as above.
    unsafe {
        assert_eq!(
            roadvo_configure(odo, good.as_ptr(), good.len() - 1),
            RoadvoStatus::ConfigLength
        );
        assert_eq!(
            roadvo_configure(odo, good.as_ptr(), good.len()),
            RoadvoStatus::Ok
        );
    }
    assert_eq!(describe(odo), "");
    // A reason cut to the buffer, NUL-terminated.
    let mut short = [1 as c_char; 4];
    // SAFETY: a live odometer and a buffer of that size.
    let n = unsafe {
        roadvo_configure(odo, nan_words().as_ptr(), CONFIG_WORDS);
        roadvo_describe(odo, short.as_mut_ptr(), short.len())
    };
    assert_eq!((n, short[3]), (3, 0));
}

fn nan_words() -> [u32; CONFIG_WORDS] {
    let mut c = kitti();
    c.camera.fx_px = f32::INFINITY;
    config_words(&c)
}

extern "C" fn grey_row(context: *const c_void, y: u16) -> *const u8 {
    let image = context.cast::<u8>();
    image.wrapping_add(usize::from(y) * 1241)
}

#[test]
fn frames_by_buffer_and_by_row_function_give_the_same_estimates_as_the_core() {
    let mut storage = Box::new(Storage([0; ROADVO_ODOMETER_SIZE]));
    let odo = new_odometer(&mut storage);
    let mut config = kitti();
    config.settings.smooth_lag_frames = 1;
    let words = config_words(&config);
    // SAFETY: a live odometer, `words` holds the count given.
    let configured = unsafe { roadvo_configure(odo, words.as_ptr(), words.len()) };
    assert_eq!(configured, RoadvoStatus::Ok);
    let mut core: Box<Odometer> = Box::new(Odometer::UNCONFIGURED);
    core.configure(config.validate().unwrap()).unwrap();
    let (mut first, mut end) = (0u16, 0u16);
    // SAFETY: a live odometer, writable outputs.
    unsafe { roadvo_rows_read(odo, &mut first, &mut end) };
    assert_eq!(first..end, core.config().rows_read());
    // A checkerboard drifting down the image, one frame by buffer, the next by row function.
    let mut smoothed = 0;
    for i in 0..6u32 {
        let image: Vec<u8> = (0..1241 * 376)
            .map(|k| {
                let (u, v) = (k % 1241, k / 1241 + 3 * i as usize);
                if (u / 24 + v / 24) % 2 == 0 { 40 } else { 200 }
            })
            .collect();
        let by_buffer = RoadvoFrame {
            width: 1241,
            height: 376,
            data: image.as_ptr(),
            stride: 1241,
            first_row: 0,
            rows: 376,
            row: None,
            context: core::ptr::null(),
        };
        let by_function = RoadvoFrame {
            data: core::ptr::null(),
            rows: 0,
            row: Some(grey_row),
            context: image.as_ptr().cast(),
            ..by_buffer
        };
        let frame = if i % 2 == 0 { by_buffer } else { by_function };
        let t = 100_000 * u64::from(i);
        let mut e = RoadvoEstimate::default();
        // SAFETY: a live odometer; the frame's rows lie in `image`.
        let processed = unsafe { roadvo_process(odo, &frame, t, &mut e) };
        assert_eq!(processed, RoadvoStatus::Ok);
        let want = core
            .process(
                &roadvo::SliceFrame::new(&image, 1241, 376, 1241).unwrap(),
                Instant::from_micros(t),
            )
            .unwrap();
        assert_eq!(Estimate::from(&e), want);
        let mut words = [0u32; ROADVO_TRACE_WORDS];
        // SAFETY: a live estimate and ROADVO_TRACE_WORDS words.
        unsafe { roadvo_trace_record(&e, words.as_mut_ptr()) };
        assert_eq!(words, trace::record(&want));
        // SAFETY: a live odometer and estimate.
        if unsafe { roadvo_smoothed(odo, &mut e) } == RoadvoStatus::Ok {
            smoothed += 1;
        }
        // The same timestamp again: refused, with its reason.
        // SAFETY: as above.
        let again = unsafe { roadvo_process(odo, &frame, t, &mut e) };
        assert_eq!(again, RoadvoStatus::TimestampNotIncreasing);
        assert!(
            describe(odo).contains("does not follow"),
            "{}",
            describe(odo)
        );
    }
    let mut e = RoadvoEstimate::default();
    // SAFETY: a live odometer and estimate.
    while unsafe { roadvo_flush(odo, &mut e) } == RoadvoStatus::Ok {
        smoothed += 1;
    }
    assert_eq!(smoothed, 6);
}

#[test]
fn every_status_has_a_text() {
    for code in 0..=RoadvoStatus::CalibrationOutOfRange as i32 {
        // The enum's values run 0.. without a gap: every one is a status.
        let status = [
            RoadvoStatus::Ok,
            RoadvoStatus::Nothing,
            RoadvoStatus::NullPointer,
            RoadvoStatus::StorageTooSmall,
            RoadvoStatus::StorageMisaligned,
            RoadvoStatus::ConfigLength,
            RoadvoStatus::ConfigBadWord,
            RoadvoStatus::NonFinite,
            RoadvoStatus::OutOfRange,
            RoadvoStatus::EmptyImage,
            RoadvoStatus::FocalLengthNotPositive,
            RoadvoStatus::CameraNotAboveGround,
            RoadvoStatus::EvenHypotheses,
            RoadvoStatus::EmptyWindow,
            RoadvoStatus::DegenerateGeometry,
            RoadvoStatus::RoiOutsideImage,
            RoadvoStatus::RoiTooSmall,
            RoadvoStatus::ExceedsCapacity,
            RoadvoStatus::SmoothingLagTooLong,
            RoadvoStatus::ConfigOther,
            RoadvoStatus::NotConfigured,
            RoadvoStatus::WrongSize,
            RoadvoStatus::TimestampNotIncreasing,
            RoadvoStatus::FrameOther,
            RoadvoStatus::ImplausibleCamera,
            RoadvoStatus::CalibrationNotSaved,
            RoadvoStatus::CalibrationCorrupted,
            RoadvoStatus::CalibrationOutOfRange,
        ][code as usize];
        assert_eq!(status as i32, code);
        assert!(!status_text(status).is_empty());
    }
}

#[test]
fn a_calibration_saved_is_restored_and_bad_bytes_are_refused() {
    let mut storage = Box::new(Storage([0; ROADVO_ODOMETER_SIZE]));
    let odo = new_odometer(&mut storage);
    // A yaw and a pitch learned over 200 m: 0.5 and -0.3 deg with standard errors of about
    // 0.05 deg.
    let angle = |deg: f32| Learned {
        rad: deg.to_radians(),
        spread_rad: 1.0f32.to_radians(),
        weight: 400.0,
        weight_sq: 1000.0,
    };
    let learned = Calibration {
        yaw_ground: angle(0.5),
        yaw_image: angle(0.5),
        pitch_image: angle(-0.3),
        pitch_road: Learned::NONE,
        roll: LearnedLine {
            mean_rad: 0.2f32.to_radians(),
            spread_rad: 1.0f32.to_radians(),
            weight: 400.0,
            weight_sq: 1000.0,
            ..LearnedLine::NONE
        },
        swing: LearnedLine::NONE,
        distance_m: 200.0,
    };
    let saved = learned.to_bytes();
    let mut bytes = [0u8; ROADVO_CALIBRATION_BYTES];
    // SAFETY: a live odometer; `saved` and `bytes` hold ROADVO_CALIBRATION_BYTES.
    unsafe {
        // Before a configuration, which would forget it: refused.
        assert_eq!(
            roadvo_calibration_restore(odo, saved.as_ptr()),
            RoadvoStatus::NotConfigured
        );
        let words = config_words(&kitti());
        assert_eq!(
            roadvo_configure(odo, words.as_ptr(), words.len()),
            RoadvoStatus::Ok
        );
        // A fresh odometer has learned nothing.
        assert_eq!(
            roadvo_calibration_save(odo, bytes.as_mut_ptr()),
            RoadvoStatus::Ok
        );
        assert_eq!(bytes, Calibration::NONE.to_bytes());
        assert_eq!(
            roadvo_calibration_restore(odo, saved.as_ptr()),
            RoadvoStatus::Ok
        );
        assert_eq!(
            roadvo_calibration_save(odo, bytes.as_mut_ptr()),
            RoadvoStatus::Ok
        );
    }
    assert_eq!(bytes, saved);
    // The mount turned as the core's odometer turns it.
    let mut core: Box<Odometer> = Box::new(Odometer::UNCONFIGURED);
    core.configure(kitti().validate().unwrap()).unwrap();
    core.restore_calibration(learned).unwrap();
    // SAFETY: a live odometer.
    let turned = unsafe { &*odo }.odometer.config().config().mount;
    assert_eq!(turned, core.config().config().mount);
    assert!(turned.yaw_rad > 0.4f32.to_radians(), "{turned:?}");
    let file = kitti().mount;
    assert!(
        turned.pitch_rad < file.pitch_rad - 0.2f32.to_radians(),
        "{turned:?}"
    );
    // Bad bytes change nothing and say why.
    let mut corrupted = saved;
    corrupted[9] ^= 0x10;
    let mut foreign = saved;
    foreign[..4].copy_from_slice(b"JFIF");
    for (bad, status, says) in [
        (corrupted, RoadvoStatus::CalibrationCorrupted, "checksum"),
        (
            foreign,
            RoadvoStatus::CalibrationNotSaved,
            "not a saved calibration",
        ),
    ] {
        // SAFETY: a live odometer; `bad` and `bytes` hold ROADVO_CALIBRATION_BYTES.
        unsafe {
            assert_eq!(roadvo_calibration_restore(odo, bad.as_ptr()), status);
            assert!(describe(odo).contains(says), "{}", describe(odo));
            roadvo_calibration_save(odo, bytes.as_mut_ptr());
        }
        assert_eq!(bytes, saved);
    }
    // SAFETY: NULL pointers are refused, not read.
    unsafe {
        assert_eq!(
            roadvo_calibration_restore(odo, core::ptr::null()),
            RoadvoStatus::NullPointer
        );
        assert_eq!(
            roadvo_calibration_save(core::ptr::null(), bytes.as_mut_ptr()),
            RoadvoStatus::NullPointer
        );
    }
}
