//! `kitti::parse_times` on arbitrary text: a `times.txt`. Nothing may panic, and what it takes
//! is within 0 to `MAX_TIME_S`, each at least a microsecond after the one before.
#![no_main]

mod text;

use libfuzzer_sys::fuzz_target;
use roadvo_sim::kitti::{MAX_TIME_S, parse_times};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Some(text) = text::text(data)
        && let Ok(times) = parse_times(text, Path::new("times.txt"))
    {
        for t in &times {
            assert!((0.0..=MAX_TIME_S).contains(t), "{t}");
        }
        for w in times.windows(2) {
            assert!((w[1] * 1e6).round() > (w[0] * 1e6).round(), "{w:?}");
        }
    }
});
