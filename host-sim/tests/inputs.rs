//! The layouts a sequence may have besides KITTI's, run as a user runs them: a video (through
//! ffmpeg, which scripts/test installs), a folder or glob of JPEG or PNG frames, and the
//! refusals of paths that are none of them. One rendered drive serves every test.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Frames of the rendered drive.
const FRAMES: usize = 40;

/// `roadvo args`: its output, and whether it succeeded.
fn roadvo(args: &[&Path]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_roadvo"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("roadvo runs");
    let text = String::from_utf8_lossy(&out.stdout) + String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text.into_owned())
}

/// `roadvo run SEQ --out OUT --trace OUT.trace extra...`, expecting success: the poses and the
/// trace (each estimate's f32 bit patterns).
fn run(seq: &Path, out: &Path, extra: &[&str]) -> (String, String) {
    let trace = out.with_extension("trace");
    let mut args = vec![
        Path::new("run"),
        seq,
        Path::new("--out"),
        out,
        Path::new("--trace"),
        &trace,
    ];
    args.extend(extra.iter().map(Path::new));
    let (ok, said) = roadvo(&args);
    assert!(ok, "roadvo {args:?} failed:\n{said}");
    let read = |p: &Path| std::fs::read_to_string(p).unwrap();
    (read(out), read(&trace))
}

/// `roadvo run SEQ --out ... extra...`, expecting a refusal: what it said.
fn refused(seq: &Path, extra: &[&str]) -> String {
    let out = work().join("refused.txt");
    let mut args = vec![Path::new("run"), seq, Path::new("--out"), &out];
    args.extend(extra.iter().map(Path::new));
    let (ok, said) = roadvo(&args);
    assert!(!ok, "roadvo {args:?} succeeded:\n{said}");
    said
}

/// A folder for this test binary, emptied at its first use.
fn work() -> &'static Path {
    static WORK: OnceLock<PathBuf> = OnceLock::new();
    WORK.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("inputs");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

/// The drive rendered once (s-course, its first [`FRAMES`] frames), in KITTI layout, its
/// mount.toml with `[camera]`; its trajectory and trace as `roadvo run` gives them.
struct Drive {
    seq: PathBuf,
    mount: PathBuf,
    poses: String,
    trace: String,
}

fn drive() -> &'static Drive {
    static DRIVE: OnceLock<Drive> = OnceLock::new();
    DRIVE.get_or_init(|| {
        let out = work().join("drive");
        let frames = FRAMES.to_string();
        let (ok, said) = roadvo(&[
            Path::new("simulate"),
            Path::new("--out"),
            &out,
            Path::new("--frames"),
            Path::new(&frames),
        ]);
        assert!(ok, "{said}");
        let seq = out.join("sequences/00");
        let (poses, trace) = run(&seq, &work().join("kitti.txt"), &[]);
        Drive {
            mount: seq.join("mount.toml"),
            seq,
            poses,
            trace,
        }
    })
}

/// The drive's frame `i` (a KITTI PNG).
fn png(i: usize) -> PathBuf {
    drive().seq.join(format!("image_0/{i:06}.png"))
}

/// Runs ffmpeg with `args`, expecting success.
fn ffmpeg(args: &[&Path]) {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-y"])
        .args(args)
        .output()
        .expect("ffmpeg runs (scripts/test installs it: apt-get install ffmpeg)");
    assert!(
        out.status.success(),
        "ffmpeg {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `video`: the frames `image_0/%06d.png` of `seq` (or `%06d.png` of a flat folder), lossless
/// (FFV1 in Matroska, grey 8-bit as the PNGs are), at 10 frames/s.
fn lossless_video(seq: &Path, video: &Path) {
    let kitti = seq.join("image_0");
    let pattern = if kitti.is_dir() {
        kitti
    } else {
        seq.to_owned()
    }
    .join("%06d.png");
    ffmpeg(&[
        Path::new("-framerate"),
        Path::new("10"),
        Path::new("-i"),
        &pattern,
        Path::new("-c:v"),
        Path::new("ffv1"),
        video,
    ]);
}

/// A lossless video (FFV1 in Matroska, grey 8-bit as the PNGs are) of the drive's frames at its
/// 10 frames/s gives the very trajectory of the frames: every estimate's bits equal. The
/// container's timestamps (milliseconds) are the times.txt ones, to the microsecond the
/// odometer sees.
#[test]
fn a_lossless_video_gives_the_trajectory_of_its_frames_bit_for_bit() {
    let d = drive();
    let video = work().join("drive.mkv");
    lossless_video(&d.seq, &video);
    let mount = d.mount.to_str().unwrap();
    let (poses, trace) = run(&video, &work().join("video.txt"), &["--mount", mount]);
    assert_eq!(poses.lines().count(), FRAMES);
    assert_eq!(
        poses, d.poses,
        "the video's trajectory differs from the PNGs'"
    );
    assert_eq!(
        trace, d.trace,
        "the video's estimates differ from the PNGs'"
    );
    // A video needs a mount file with [camera], and says so.
    let e = refused(&video, &[]);
    assert!(
        e.contains("drive.mkv is a video file, which carries no camera calibration")
            && e.contains("[camera]")
            && e.contains("--mount FILE"),
        "{e}"
    );
    let kitti = concat!(env!("CARGO_MANIFEST_DIR"), "/../mounts/kitti.toml");
    let e = refused(&video, &["--mount", kitti]);
    assert!(e.contains("kitti.toml has none"), "{e}");
    // Its timestamps come from the container.
    let e = refused(&video, &["--mount", mount, "--fps", "10"]);
    assert!(e.contains("takes the container's timestamps"), "{e}");
}

/// A lossless video of a shared KITTI clip (the first 40 frames of sequence 05, at 10 frames/s)
/// runs to the very trajectory of the same PNG frames given `--fps 10`: the video's pixels are
/// the PNGs'. (Against the clip's own times.txt the trajectories differ only by the timing.)
/// Skipped where ../shared holds no KITTI data.
#[test]
fn a_lossless_video_of_a_kitti_clip_runs_as_its_png_frames() {
    let kitti = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/kitti"
    ));
    let seq = kitti.join("sequences/05");
    if !seq.exists() {
        eprintln!("no KITTI data at {}: skipped", kitti.display());
        return;
    }
    // The mount file of KITTI's camera 0: mounts/kitti.toml with calib.txt's P0 as [camera].
    let p0: Vec<f64> = std::fs::read_to_string(seq.join("calib.txt"))
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("P0:"))
        .unwrap()
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    let (w, h) = image::image_dimensions(seq.join("image_0/000000.png")).unwrap();
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../mounts/kitti.toml");
    let mount = work().join("kitti-camera.toml");
    std::fs::write(
        &mount,
        format!(
            "[camera]\nwidth_px = {w}\nheight_px = {h}\nfx_px = {}\nfy_px = {}\ncx_px = {}\n\
             cy_px = {}\n\n{}",
            p0[0],
            p0[5],
            p0[2],
            p0[6],
            std::fs::read_to_string(shipped).unwrap()
        ),
    )
    .unwrap();
    let video = work().join("kitti05.mkv");
    let frames = work().join("kitti05-frames");
    std::fs::create_dir_all(&frames).unwrap();
    for i in 0..FRAMES {
        let name = format!("{i:06}.png");
        std::fs::copy(seq.join("image_0").join(&name), frames.join(&name)).unwrap();
    }
    lossless_video(&frames, &video);
    let mount = mount.to_str().unwrap();
    let by_video = run(
        &video,
        &work().join("kitti05-video.txt"),
        &["--mount", mount],
    );
    let by_frames = run(
        &frames,
        &work().join("kitti05-frames.txt"),
        &["--mount", mount, "--fps", "10"],
    );
    assert_eq!(by_video.0.lines().count(), FRAMES);
    assert_eq!(
        by_video, by_frames,
        "the video's estimates differ from its frames'"
    );
}

/// JPEG frames named frame1.jpg..frame40.jpg (natural order: frame2 before frame10), timed by
/// `--fps`: one pose a frame, the same for the folder and for a glob of it.
#[test]
fn a_folder_or_glob_of_jpeg_frames_runs_at_a_given_rate() {
    let d = drive();
    let folder = work().join("jpeg");
    std::fs::create_dir_all(&folder).unwrap();
    for i in 0..FRAMES {
        let img = image::open(png(i)).unwrap().into_luma8();
        img.save(folder.join(format!("frame{}.jpg", i + 1)))
            .unwrap();
    }
    std::fs::write(folder.join("notes.txt"), "not a frame\n").unwrap();
    let mount = d.mount.to_str().unwrap();
    let args = ["--mount", mount, "--fps", "10"];
    let (poses, _) = run(&folder, &work().join("jpeg.txt"), &args);
    assert_eq!(poses.lines().count(), FRAMES, "{poses}");
    let glob = folder.join("frame*.jpg");
    let (from_glob, _) = run(&glob, &work().join("jpeg-glob.txt"), &args);
    assert_eq!(from_glob, poses);
    // Out of order, the frames would drive another trajectory: the order is natural.
    let last_pose = |text: &str| -> Vec<f64> {
        let line = text.lines().last().unwrap();
        line.split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect()
    };
    let (last, truth) = (last_pose(&poses), last_pose(&d.poses));
    let gap = ((last[3] - truth[3]).powi(2) + (last[11] - truth[11]).powi(2)).sqrt();
    assert!(gap < 0.05, "JPEG and PNG runs end {gap} m apart");
    // A folder of frames needs their timestamps.
    let e = refused(&folder, &["--mount", mount]);
    assert!(e.contains("--times FILE") && e.contains("--fps N"), "{e}");
}

/// The PNG frames renamed and flat in a folder, timed by `--times` (the drive's times.txt):
/// the KITTI run's trajectory exactly.
#[test]
fn a_flat_folder_of_png_frames_runs_with_a_times_file() {
    let d = drive();
    let folder = work().join("flat");
    std::fs::create_dir_all(&folder).unwrap();
    for i in 0..FRAMES {
        std::fs::copy(png(i), folder.join(format!("cam_{i}.png"))).unwrap();
    }
    let times = d.seq.join("times.txt");
    let args = [
        "--mount",
        d.mount.to_str().unwrap(),
        "--times",
        times.to_str().unwrap(),
    ];
    let (poses, trace) = run(&folder, &work().join("flat.txt"), &args);
    assert_eq!(
        (poses.as_str(), trace.as_str()),
        (d.poses.as_str(), d.trace.as_str())
    );
    // The frames' folder is an input: no output goes into it.
    let inside = folder.join("est.txt");
    let (ok, said) = roadvo(&[
        Path::new("run"),
        &folder,
        Path::new("--out"),
        &inside,
        Path::new("--fps"),
        Path::new("10"),
        Path::new("--mount"),
        &d.mount,
    ]);
    assert!(!ok && said.contains("is inside the input folder"), "{said}");
}

/// A text file as a video, an empty folder and a folder of unrelated files are refused with
/// the layouts a sequence may have.
#[test]
fn a_path_of_no_layout_is_refused_with_the_layouts() {
    let dir = work().join("bad");
    let (empty, unrelated) = (dir.join("empty"), dir.join("unrelated"));
    std::fs::create_dir_all(&empty).unwrap();
    std::fs::create_dir_all(&unrelated).unwrap();
    std::fs::write(unrelated.join("a.txt"), "hello\n").unwrap();
    std::fs::write(unrelated.join("b.csv"), "1,2\n").unwrap();
    let text = dir.join("drive.mp4");
    std::fs::write(&text, "not a video at all\n").unwrap();
    let layouts = "not a KITTI sequence folder (no image_0/), a folder or glob of .png/.jpg \
                   frames, or a video file";
    for (path, why) in [
        (&text, "(ffprobe: "),
        (&empty, "it holds no image_0/ and no .png/.jpg file"),
        (&unrelated, "it holds no image_0/ and no .png/.jpg file"),
        (&dir.join("missing"), "no such file or folder"),
    ] {
        let e = refused(path, &["--mount", drive().mount.to_str().unwrap()]);
        assert!(e.contains(layouts) && e.contains(why), "{e}");
        assert!(!e.contains("Not a directory"), "{e}");
    }
}

/// A mount file's `[camera]` makes calib.txt optional, and must agree with it where both are.
#[test]
fn camera_comes_from_the_mount_file_or_calib_txt_and_they_must_agree() {
    let d = drive();
    let seq = work().join("no-calib");
    std::fs::create_dir_all(seq.join("image_0")).unwrap();
    for i in 0..FRAMES {
        std::fs::copy(png(i), seq.join(format!("image_0/{i:06}.png"))).unwrap();
    }
    std::fs::copy(d.seq.join("times.txt"), seq.join("times.txt")).unwrap();
    std::fs::copy(&d.mount, seq.join("mount.toml")).unwrap();
    let (poses, _) = run(&seq, &work().join("no-calib.txt"), &[]);
    assert_eq!(poses, d.poses);
    // calib.txt back, with another focal length: both files named.
    let calib = std::fs::read_to_string(d.seq.join("calib.txt")).unwrap();
    let fx = calib.split_whitespace().nth(1).unwrap();
    let other = calib.replacen(fx, "7.0e2", 1);
    std::fs::write(seq.join("calib.txt"), other).unwrap();
    let e = refused(&seq, &[]);
    assert!(
        e.contains("the [camera] of mount file")
            && e.contains("no-calib/mount.toml")
            && e.contains("no-calib/calib.txt")
            && e.contains("fx_px"),
        "{e}"
    );
    // Without calib.txt and without [camera]: nothing gives the camera.
    std::fs::remove_file(seq.join("calib.txt")).unwrap();
    let kitti = concat!(env!("CARGO_MANIFEST_DIR"), "/../mounts/kitti.toml");
    let e = refused(&seq, &["--mount", kitti]);
    assert!(
        e.contains("a KITTI sequence folder without calib.txt") && e.contains("has none"),
        "{e}"
    );
}
