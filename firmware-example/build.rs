//! Puts the top-level `memory.x` (the board's memory map) where cortex-m-rt's `link.x` finds it.

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../memory.x");
    std::fs::copy(&memory, out.join("memory.x")).expect("../memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    println!("cargo:rerun-if-changed=build.rs");
}
