//! Faults midway through a command: a write that fails (a file-size limit, `ulimit -f`, standing
//! in for a full disk) and a Ctrl-C. Every earlier output stays as it was, and no temporary file
//! is left behind; `run` interrupted keeps the frames it finished, as a partial result.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_roadvo")
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_owned()
}

/// `roadvo ARGS` under a file-size limit of `blocks` 1 KiB blocks (bash's `ulimit -f`).
fn limited(blocks: u32, args: &[String]) -> std::process::Output {
    Command::new("bash")
        .arg("-c")
        .arg(format!("ulimit -f {blocks}; exec \"$0\" \"$@\""))
        .arg(bin())
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("bash runs")
}

/// Starts `roadvo ARGS`, waits until a temporary file or folder whose name starts with
/// `temp_prefix` appears in `dir` (with something in it, if `filled`: the command is midway),
/// sends it SIGINT and waits for it.
fn interrupted(
    args: &[String],
    dir: &Path,
    temp_prefix: &str,
    filled: bool,
) -> std::process::Output {
    let child: Child = Command::new(bin())
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("roadvo starts");
    let start = Instant::now();
    let midway = || {
        temporaries(dir, temp_prefix)
            .iter()
            .any(|n| std::fs::metadata(dir.join(n)).is_ok_and(|m| !filled || m.len() > 0))
    };
    while !midway() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no {temp_prefix}* appeared"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    child.wait_with_output().unwrap()
}

/// Names in `dir` that start with `prefix`.
fn temporaries(dir: &Path, prefix: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

/// `roadvo run` over `seq`, writing `est` and `quality`.
fn run_args(seq: &Path, est: &Path, quality: &Path) -> Vec<String> {
    words(&["run", &s(seq), "--out", &s(est), "--quality", &s(quality)])
}

/// Asserts that `what` left no hidden temporary file or folder in `dir`.
fn no_temporaries(dir: &Path, what: &str) {
    let left = temporaries(dir, ".");
    assert!(left.is_empty(), "{what} left {left:?}");
}

/// Every file under `root`, with its bytes.
fn snapshot(root: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![root.to_owned()];
    while let Some(p) = stack.pop() {
        if p.is_dir() {
            stack.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
        } else {
            files.push((p.clone(), std::fs::read(&p).unwrap()));
        }
    }
    files.sort();
    files
}

fn ok(args: &[String]) {
    let out = Command::new(bin()).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn words(w: &[&str]) -> Vec<String> {
    w.iter().map(|x| x.to_string()).collect()
}

/// A rendered drive (s-course, `frames` frames) in `out`.
fn render(out: &Path, frames: usize, seed: u64) -> Vec<String> {
    words(&[
        "simulate",
        "--frames",
        &frames.to_string(),
        "--seed",
        &seed.to_string(),
        "--out",
        &s(out),
    ])
}

/// A rendered drive of `frames` frames in `dir/drive`: the drive's folder, its sequence and its
/// ground truth.
fn drive_in(dir: &Path, frames: usize) -> (PathBuf, PathBuf, PathBuf) {
    let drive = dir.join("drive");
    ok(&render(&drive, frames, 1));
    let seq = drive.join("sequences/00");
    let gt = drive.join("poses/00.txt");
    (drive, seq, gt)
}

#[test]
fn a_failed_write_leaves_every_earlier_output_and_no_temporary() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (drive, seq, gt) = drive_in(dir, 30);
    let (est, quality, store, plot) = (
        dir.join("est.txt"),
        dir.join("q.jsonl"),
        dir.join("store.bin"),
        dir.join("top.png"),
    );
    let run = run_args(&seq, &est, &quality);
    let pack = words(&["pack", &s(&seq), "--out", &s(&store)]);
    let eval = words(&["eval", &s(&gt), &s(&est), "--plot", &s(&plot)]);
    for c in [&run, &pack, &eval] {
        ok(c);
    }
    let before = snapshot(dir);
    // Each with the file that could not be written.
    for (what, args, said) in [
        ("run", run, "cannot write q.jsonl"),
        ("pack", pack, "cannot write store.bin"),
        ("eval --plot", eval, "cannot write top.png"),
        ("simulate", render(&drive, 30, 2), "rendering into drive"),
    ] {
        let out = limited(4, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{what} succeeded under the limit");
        assert!(err.contains("File too large"), "{what}: {err}");
        let (verb, file) = said.rsplit_once(' ').unwrap();
        assert!(
            err.contains(&format!("{verb} {}", s(&dir.join(file)))),
            "{what}: {err}"
        );
        assert_eq!(snapshot(dir), before, "{what} changed an earlier output");
        no_temporaries(dir, what);
    }
}

#[test]
fn ctrl_c_leaves_earlier_outputs_and_run_keeps_what_it_finished() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (drive, seq, gt) = drive_in(dir, 80);
    let (est, quality, store) = (
        dir.join("est.txt"),
        dir.join("q.jsonl"),
        dir.join("store.bin"),
    );
    let plot = dir.join("top.png");
    let pack = words(&["pack", &s(&seq), "--out", &s(&store)]);
    let eval = words(&["eval", &s(&gt), &s(&gt), "--plot", &s(&plot)]);
    ok(&pack);
    ok(&eval);
    let before = snapshot(dir);
    // A plot takes milliseconds: the Ctrl-C may come when it is already whole, and then the
    // new plot stands (a whole PNG) and nothing else may have changed.
    for (what, args, temp, filled) in [
        ("pack", pack, ".store.bin.", true),
        ("simulate", render(&drive, 80, 2), ".drive.", true),
        ("eval --plot", eval, ".top.png.", false),
    ] {
        let out = interrupted(&args, dir, temp, filled);
        let err = String::from_utf8_lossy(&out.stderr);
        if what == "eval --plot" && out.status.success() {
            image::open(&plot).expect("the new plot is whole");
            no_temporaries(dir, what);
            continue;
        }
        assert!(!out.status.success(), "{what}: {err}");
        assert!(err.contains("interrupted"), "{what}: {err}");
        assert_eq!(snapshot(dir), before, "{what} changed an earlier output");
        no_temporaries(dir, what);
    }

    let run = run_args(&seq, &est, &quality);
    let out = interrupted(&run, dir, ".q.jsonl.", true);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("partial"),
        "{err}"
    );
    let kept = std::fs::read_to_string(&est).unwrap().lines().count();
    let lines = std::fs::read_to_string(&quality).unwrap().lines().count();
    assert!(kept > 0 && kept < 80, "{kept} poses of 80 frames");
    assert_eq!(lines, kept, "a quality line for every pose kept");
    no_temporaries(dir, "run");
}
