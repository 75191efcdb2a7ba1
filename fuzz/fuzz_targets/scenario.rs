//! `Scenario::parse` on arbitrary text: a scenario file, checked against its limits. Nothing may
//! panic; a short path that passes is integrated, and what passes is written back as TOML.
#![no_main]

mod text;

use libfuzzer_sys::fuzz_target;
use roadvo_sim::path::Path;
use roadvo_sim::scenario::Scenario;

/// The longest path integrated here, metres (the limit is 20 km; integrating it takes a while).
const INTEGRATE_M: f64 = 2_000.0;

fuzz_target!(|data: &[u8]| {
    let Some(text) = text::text(data) else {
        return;
    };
    let Ok(s) = Scenario::parse(text, "scenario.toml") else {
        return;
    };
    let _ = s.to_toml();
    if s.total_length_m() <= INTEGRATE_M {
        let path = Path::new(&s.segments);
        assert!(path.is_ok(), "{:?}", path.err());
    }
});
