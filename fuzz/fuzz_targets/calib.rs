//! `kitti::parse_calib_p0` on arbitrary text: a `calib.txt`. Nothing may panic, and a P0 it
//! takes is a rectified camera's.
#![no_main]

mod text;

use libfuzzer_sys::fuzz_target;
use roadvo_sim::kitti::parse_calib_p0;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Some(text) = text::text(data)
        && let Ok(p) = parse_calib_p0(text, Path::new("calib.txt"))
    {
        assert!(p[0] > 0.0 && p[5] > 0.0, "{p:?}");
        assert_eq!(
            [p[1], p[4], p[8], p[9], p[10], p[11]],
            [0.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        );
    }
});
