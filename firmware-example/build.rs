//! Puts the top-level `memory.x` (the board's memory map) where cortex-m-rt's `link.x` finds it,
//! and the configuration where `main.rs` includes it: the file `ROADVO_CONFIG_RS` names (an
//! export, `roadvo export-config MOUNT --rust`), or `src/default_config.rs`.

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let memory = here.join("../memory.x");
    std::fs::copy(&memory, out.join("memory.x")).expect("../memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());

    let config = std::env::var_os("ROADVO_CONFIG_RS")
        .filter(|p| !p.is_empty())
        .map_or_else(|| here.join("src/default_config.rs"), PathBuf::from);
    std::fs::copy(&config, out.join("config.rs"))
        .unwrap_or_else(|e| panic!("ROADVO_CONFIG_RS: cannot read {}: {e}", config.display()));
    println!("cargo:rerun-if-env-changed=ROADVO_CONFIG_RS");
    println!("cargo:rerun-if-changed={}", config.display());
    println!("cargo:rerun-if-changed=build.rs");
}
