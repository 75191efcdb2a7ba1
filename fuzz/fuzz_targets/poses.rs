//! `kitti::parse_poses` on arbitrary text: a pose file's lines of 12 numbers. Nothing may panic.
#![no_main]

mod text;

use libfuzzer_sys::fuzz_target;
use roadvo_sim::kitti::parse_poses;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Some(text) = text::text(data)
        && let Ok(poses) = parse_poses(text, Path::new("poses.txt"))
    {
        assert!(!poses.is_empty());
    }
});
