//! What the command-line tests share: running `roadvo` as a user does. (Each test file uses
//! part of it.)
#![allow(dead_code)]

use std::path::Path;
use std::process::Command;

/// Runs `roadvo` with `args`, expecting success; its output.
pub fn roadvo(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_roadvo"))
        .args(args)
        .output()
        .expect("roadvo runs");
    assert!(
        out.status.success(),
        "roadvo {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs `roadvo` with `args`, expecting a refusal; its error output.
pub fn refused(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_roadvo"))
        .args(args)
        .output()
        .expect("roadvo runs");
    assert!(!out.status.success(), "roadvo {args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Renders the first `frames` frames of `scenario` into `out`.
pub fn simulate(scenario: &str, out: &Path, frames: usize) {
    let frames = frames.to_string();
    roadvo(&[
        "simulate",
        "--scenario",
        scenario,
        "--out",
        out.to_str().unwrap(),
        "--frames",
        &frames,
    ]);
}
