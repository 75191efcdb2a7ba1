//! Bad inputs and faults, one case a finding: each is refused (or, for a bad frame, ends the run
//! with a partial result), its message names the file (and line where there is one), and no
//! input or earlier output is touched.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One bad input: the files it needs, the command, and what the refusal must say.
struct Case {
    name: &'static str,
    args: Vec<String>,
    /// Each must appear in the error output.
    says: Vec<String>,
    /// Files that must be byte for byte as before the command.
    unchanged: Vec<PathBuf>,
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_owned()
}

fn args(words: &[&str]) -> Vec<String> {
    words.iter().map(|w| w.to_string()).collect()
}

fn roadvo(args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_roadvo"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("roadvo runs")
}

/// A rendered drive of 12 frames (KITTI layout, with its own mount file) in `dir/drive`.
fn drive(dir: &Path) -> PathBuf {
    let out = dir.join("drive");
    let done = roadvo(&args(&[
        "simulate",
        "--scenario",
        "s-course",
        "--frames",
        "12",
        "--out",
        &s(&out),
    ]));
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    out
}

/// A copy of the drive's sequence folder in `dir/name`, to break.
fn copy_of(seq: &Path, dir: &Path, name: &str) -> PathBuf {
    let to = dir.join(name);
    std::fs::create_dir_all(to.join("image_0")).unwrap();
    for f in ["times.txt", "calib.txt", "mount.toml"] {
        std::fs::copy(seq.join(f), to.join(f)).unwrap();
    }
    for e in std::fs::read_dir(seq.join("image_0")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join("image_0").join(e.file_name())).unwrap();
    }
    to
}

fn write(path: &Path, text: &str) -> PathBuf {
    std::fs::write(path, text).unwrap();
    path.to_owned()
}

fn cases(dir: &Path) -> Vec<Case> {
    let root = drive(dir);
    let seq = root.join("sequences/00");
    let est = dir.join("est.txt");
    let earlier = write(&dir.join("earlier.txt"), "an earlier output\n");
    let identity = "1 0 0 0 0 1 0 0 0 0 1 0\n";
    // Outputs that would overwrite an input or each other.
    let mut cases = vec![
        Case {
            name: "--out onto the sequence's times.txt",
            args: args(&["run", &s(&seq), "--out", &s(&seq.join("times.txt"))]),
            says: vec!["times.txt".into(), "is an input".into()],
            unchanged: vec![seq.join("times.txt")],
        },
        Case {
            name: "--out and --quality on one path",
            args: args(&[
                "run",
                &s(&seq),
                "--out",
                &s(&earlier),
                "--quality",
                &s(&earlier),
            ]),
            says: vec!["--quality".into(), "--out".into(), "earlier.txt".into()],
            unchanged: vec![earlier.clone()],
        },
        Case {
            name: "--out into the frames' folder",
            args: args(&["run", &s(&seq), "--out", &s(&seq.join("image_0/x.txt"))]),
            says: vec!["image_0".into(), "inside the input folder".into()],
            unchanged: vec![],
        },
        // Checked before any frame is run, and before --out is touched.
        Case {
            name: "--plot in an unknown format",
            args: args(&["run", &s(&seq), "--out", &s(&earlier), "--plot", "top.jpg"]),
            says: vec!["top.jpg".into(), ".png or .svg".into()],
            unchanged: vec![earlier.clone()],
        },
    ];
    let a_file = write(&dir.join("a-file"), "");
    cases.push(Case {
        name: "--out under a file",
        args: args(&["run", &s(&seq), "--out", &s(&a_file.join("est.txt"))]),
        says: vec!["a-file/est.txt".into()],
        unchanged: vec![],
    });
    let other = dir.join("not-a-drive");
    std::fs::create_dir_all(&other).unwrap();
    let kept = write(&other.join("notes.txt"), "mine\n");
    cases.push(Case {
        name: "simulate into a folder holding something else",
        args: args(&["simulate", "--frames", "3", "--out", &s(&other)]),
        says: vec!["not-a-drive".into(), "not empty".into()],
        unchanged: vec![kept],
    });

    // Nonsense refused.
    let rolled = write(
        &dir.join("rolled.toml"),
        &std::fs::read_to_string(seq.join("mount.toml"))
            .unwrap()
            .replace("roll_deg = 0.0", "roll_deg = 1e30"),
    );
    cases.push(Case {
        name: "a roll of 1e30 deg",
        args: args(&["run", &s(&seq), "--mount", &s(&rolled), "--out", &s(&est)]),
        says: vec![
            "rolled.toml".into(),
            "roll_deg".into(),
            "between -180 and 180".into(),
        ],
        unchanged: vec![],
    });
    cases.push(Case {
        name: "pack --frames 0",
        args: args(&["pack", &s(&seq), "--frames", "0", "--out", &s(&earlier)]),
        says: vec!["--frames".into(), "0 is not in 1..".into()],
        unchanged: vec![earlier.clone()],
    });
    cases.push(Case {
        name: "bench --repeats 0",
        args: args(&["bench", &s(&seq), "--repeats", "0"]),
        says: vec!["--repeats".into(), "0 is not in 1..".into()],
        unchanged: vec![],
    });
    let zero_rotation = write(
        &dir.join("zero-rotation.txt"),
        &format!("{identity}0 0 0 1 0 0 0 0 0 0 0 2\n"),
    );
    cases.push(Case {
        name: "eval of a pose whose rotation is all zeros",
        args: args(&["eval", &s(&zero_rotation), &s(&zero_rotation)]),
        says: vec!["zero-rotation.txt line 2".into(), "not orthonormal".into()],
        unchanged: vec![],
    });
    let far = write(
        &dir.join("far.txt"),
        &format!("{identity}1 0 0 1e160 0 1 0 0 0 0 1 1e160\n"),
    );
    cases.push(Case {
        name: "eval --plot of coordinates of 1e160 m",
        args: args(&[
            "eval",
            &s(&far),
            &s(&far),
            "--plot",
            &s(&dir.join("far.png")),
        ]),
        says: vec!["pose 2".into(), "beyond".into()],
        unchanged: vec![],
    });

    // Surplus and nonsense in the sequence's files.
    let edited = |name: &str, file: &str, edit: &dyn Fn(String) -> String| {
        let copy = copy_of(&seq, dir, name);
        let text = std::fs::read_to_string(copy.join(file)).unwrap();
        write(&copy.join(file), &edit(text));
        copy
    };
    // A copy whose P0 has its number `k` (1-based) made `value`.
    let p0_with = |name: &str, k: usize, value: &'static str| {
        edited(name, "calib.txt", &move |t: String| {
            let mut words: Vec<&str> = t.split_whitespace().collect();
            words[k] = value;
            words.join(" ") + "\n"
        })
    };
    let skewed = p0_with("skewed", 2, "5");
    let third_row = p0_with("third-row", 11, "2");
    let narrow = p0_with("narrow", 1, "5");
    let two_p0 = edited("two-p0", "calib.txt", &|t| {
        t + "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n"
    });
    let surplus_times = edited("surplus-times", "times.txt", &|t| t + "1.3\n");
    let negative_time = edited("negative-time", "times.txt", &|t| {
        t.replacen("0.000000e0", "-0.1", 1)
    });
    let mut doubled = std::fs::read_to_string(root.join("poses/00.txt")).unwrap();
    doubled += &doubled.clone();
    let doubled = write(&dir.join("doubled.txt"), &doubled);
    let scenario = write(
        &dir.join("long.toml"),
        &std::fs::read_to_string(seq.join("scenario.toml"))
            .unwrap()
            .replacen("length_m = 30.0", "length_m = 1e7", 1),
    );
    cases.extend([
        Case {
            name: "calib.txt with skew",
            args: args(&["run", &s(&skewed), "--out", &s(&est)]),
            says: vec!["skewed/calib.txt line 1".into(), "skewed camera".into()],
            unchanged: vec![],
        },
        Case {
            name: "calib.txt whose third row is not 0 0 1 0",
            args: args(&["run", &s(&third_row), "--out", &s(&est)]),
            says: vec!["third-row/calib.txt line 1".into(), "0 0 1 0".into()],
            unchanged: vec![],
        },
        Case {
            name: "calib.txt with a focal length of 5 px for a 640 px frame",
            args: args(&[
                "run",
                &s(&narrow),
                "--mount",
                concat!(env!("CARGO_MANIFEST_DIR"), "/../mounts/kitti.toml"),
                "--out",
                &s(&est),
            ]),
            says: vec!["narrow/calib.txt".into(), "field of view".into()],
            unchanged: vec![],
        },
        Case {
            name: "calib.txt with a second P0",
            args: args(&["run", &s(&two_p0), "--out", &s(&est)]),
            says: vec!["two-p0/calib.txt line 2".into(), "second `P0:`".into()],
            unchanged: vec![],
        },
        Case {
            name: "more timestamps than frames",
            args: args(&["run", &s(&surplus_times), "--out", &s(&est)]),
            says: vec!["surplus-times/times.txt".into(), "13 timestamps".into()],
            unchanged: vec![],
        },
        Case {
            name: "a negative timestamp",
            args: args(&["run", &s(&negative_time), "--out", &s(&est)]),
            says: vec!["negative-time/times.txt line 1".into(), "-0.1".into()],
            unchanged: vec![],
        },
        Case {
            name: "calibrate with more ground truth than frames",
            args: args(&[
                "calibrate",
                &s(&seq),
                "--gt",
                &s(&doubled),
                "--out",
                &s(&est),
            ]),
            says: vec!["doubled.txt".into(), "24 ground-truth poses".into()],
            unchanged: vec![],
        },
        Case {
            name: "sensitivity --set with an unknown key, before any rendering",
            args: args(&[
                "sensitivity",
                "--set",
                "bogus=1",
                "--out",
                &s(&dir.join("sens")),
            ]),
            says: vec!["--set bogus=1".into(), "no key `bogus`".into()],
            unchanged: vec![],
        },
        Case {
            name: "/dev/zero as the mount file",
            args: args(&["run", &s(&seq), "--mount", "/dev/zero", "--out", &s(&est)]),
            says: vec!["/dev/zero".into(), "larger than".into()],
            unchanged: vec![],
        },
        Case {
            name: "a scenario segment of 1e7 m",
            args: args(&[
                "simulate",
                "--scenario",
                &s(&scenario),
                "--frames",
                "3",
                "--out",
                &s(&dir.join("long")),
            ]),
            says: vec!["long.toml".into(), "length".into(), "20000 m".into()],
            unchanged: vec![],
        },
    ]);

    // Resources bounded.
    let huge = copy_of(&seq, dir, "huge");
    std::fs::write(huge.join("image_0/000000.png"), png_header(20_000, 20_000)).unwrap();
    cases.push(Case {
        name: "a 20000x20000 frame",
        args: args(&["run", &s(&huge), "--out", &s(&est)]),
        says: vec!["000000.png".into(), "20000x20000".into(), "8192".into()],
        unchanged: vec![],
    });
    let tiny = copy_of(&seq, dir, "tiny");
    image::GrayImage::new(1, 1)
        .save(tiny.join("image_0/000000.png"))
        .unwrap();
    cases.push(Case {
        name: "a 1x1 frame",
        args: args(&["run", &s(&tiny), "--out", &s(&est)]),
        says: vec!["tiny/image_0/000000.png".into(), "1x1".into()],
        unchanged: vec![],
    });

    // A bad frame: the run stops there and keeps the frames before it.
    let broken = copy_of(&seq, dir, "broken");
    let frame = broken.join("image_0/000005.png");
    let bytes = std::fs::read(&frame).unwrap();
    std::fs::write(&frame, &bytes[..bytes.len() / 3]).unwrap();
    cases.push(Case {
        name: "a truncated frame 5 of 12",
        args: args(&["run", &s(&broken), "--out", &s(&dir.join("partial.txt"))]),
        says: vec![
            "stopped at frame 000005 of 12".into(),
            "broken/image_0/000005.png".into(),
            "frames 000000 to 000004".into(),
        ],
        unchanged: vec![],
    });
    cases
}

/// The start of a PNG that says it is `w`x`h` pixels of 8-bit grey (the signature, the header
/// and a first, short data chunk): what a decoder reads before it allocates.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    let mut header = w.to_be_bytes().to_vec();
    header.extend(h.to_be_bytes());
    header.extend([8, 0, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(png_chunk(b"IHDR", &header));
    png.extend(png_chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00]));
    png
}

/// A PNG chunk: length, type, data, CRC-32 of type and data.
fn png_chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut body = kind.to_vec();
    body.extend(data);
    let crc = body.iter().fold(!0u32, |mut c, &b| {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
        c
    });
    let mut chunk = (data.len() as u32).to_be_bytes().to_vec();
    chunk.extend(body);
    chunk.extend((!crc).to_be_bytes());
    chunk
}

#[test]
fn every_bad_input_is_refused_with_its_file_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for case in cases(dir.path()) {
        let before: Vec<Vec<u8>> = case
            .unchanged
            .iter()
            .map(|p| std::fs::read(p).unwrap())
            .collect();
        let out = roadvo(&case.args);
        let err = String::from_utf8_lossy(&out.stderr);
        if out.status.success() {
            failures.push(format!("{}: accepted", case.name));
        }
        for want in &case.says {
            if !err.contains(want.as_str()) {
                failures.push(format!("{}: {want:?} not in: {err}", case.name));
            }
        }
        if err.contains("panicked") {
            failures.push(format!("{}: panicked: {err}", case.name));
        }
        for (p, b) in case.unchanged.iter().zip(&before) {
            if std::fs::read(p).ok().as_ref() != Some(b) {
                failures.push(format!("{}: {} changed", case.name, p.display()));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // The partial run kept the five good frames.
    let partial = std::fs::read_to_string(dir.path().join("partial.txt")).unwrap();
    assert_eq!(partial.lines().count(), 5);
    // Told to, a run carries on past the bad frame: a pose for every frame, the bad one's
    // between its neighbours'.
    let skipped = dir.path().join("skipped.txt");
    let broken = dir.path().join("broken");
    let out = roadvo(&args(&[
        "run",
        &s(&broken),
        "--out",
        &s(&skipped),
        "--skip-bad-frames",
    ]));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("frame 000005 left out") && err.contains("000005.png"),
        "{err}"
    );
    let poses: Vec<Vec<f64>> = std::fs::read_to_string(&skipped)
        .unwrap()
        .lines()
        .map(|l| l.split_whitespace().map(|w| w.parse().unwrap()).collect())
        .collect();
    assert_eq!(poses.len(), 12);
    for k in [3, 7, 11] {
        let between = 0.5 * (poses[4][k] + poses[6][k]);
        assert!((poses[5][k] - between).abs() < 1e-6, "{k}: {:?}", poses[5]);
    }
}
