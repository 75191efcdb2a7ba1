//! `FrameStore::open` on arbitrary bytes (what the firmware example and the host's tests read a
//! `roadvo pack` store with), then every row of the first frames. Nothing may panic, and a
//! store that opens holds its frames.
#![no_main]

use libfuzzer_sys::fuzz_target;
use roadvo::Frame;
use roadvo::wire::frame_store::FrameStore;

fuzz_target!(|data: &[u8]| {
    let Ok(store) = FrameStore::open(data) else {
        return;
    };
    let h = *store.header();
    let _ = store.holds_rows(h.first_row..h.first_row.saturating_add(h.rows));
    for i in 0..h.frames.min(8) {
        let (frame, _) = store.frame(i).expect("a store that opens holds its frames");
        for y in 0..frame.height() {
            let row = frame.row(y);
            assert!(row.is_empty() || row.len() == usize::from(frame.width()));
        }
    }
    assert!(store.frame(h.frames).is_none());
});
