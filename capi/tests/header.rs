//! The committed header (`include/roadvo.h`) is the one cbindgen makes from the source now:
//! CI fails on a stale header. `ROADVO_BLESS=1 cargo test -p roadvo-c --test header` writes it.

use std::path::Path;

#[test]
fn the_committed_header_is_the_generated_one() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen reads capi/src")
        .write(&mut generated);
    let path = crate_dir.join("include/roadvo.h");
    if std::env::var_os("ROADVO_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "capi/include/roadvo.h is stale: run `ROADVO_BLESS=1 cargo test -p roadvo-c --test \
         header` and commit it"
    );
}
