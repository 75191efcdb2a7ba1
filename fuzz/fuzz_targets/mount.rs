//! `MountFile::parse` on arbitrary text, with and without a sequence's camera; what it takes
//! is written back (`to_text`), read again, and set up as the core's configuration. Nothing may
//! panic.
#![no_main]

mod text;

use libfuzzer_sys::fuzz_target;
use roadvo::Camera;
use roadvo_sim::mount::MountFile;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some(text) = text::text(data) else {
        return;
    };
    let path = Path::new("mount.toml");
    let _ = MountFile::parse(text, path, None);
    let camera = Camera::KITTI_00;
    if let Ok(file) = MountFile::parse(text, path, Some(&camera)) {
        let again = MountFile::parse(&file.to_text(true, ""), path, None);
        assert!(again.is_ok(), "{again:?}");
        let _ = file.to_config().validate();
    }
});
