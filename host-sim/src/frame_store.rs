//! The firmware example's frame store: a recorded drive packed as the camera memory of the ECU
//! would hold it, for the firmware to replay under QEMU (`roadvo pack`), and the per-frame trace
//! that the firmware and `roadvo run --trace` both print, so that the two runs can be compared
//! bit for bit.
//!
//! The store keeps only the rows the odometer reads ([`roadvo::ValidConfig::rows_read`]), as a
//! camera with a readout window would deliver them: a KITTI-size drive of 60 frames then fits the
//! board's 16 MiB PSRAM. Layout, little-endian (the reader is `firmware-example/src/frame_store.rs`):
//!
//! | offset | type     | field                                              |
//! |--------|----------|----------------------------------------------------|
//! | 0      | [u8; 4]  | magic `RVFS`                                       |
//! | 4      | u16      | format version, 1                                  |
//! | 6      | u16      | 0                                                  |
//! | 8      | u16 x 4  | frame width, frame height, first stored row, rows  |
//! | 16     | u32      | frames                                             |
//! | 20     | u8       | method: 0 default (pitch vote), 1 paper            |
//! | 21     | [u8; 3]  | 0                                                  |
//! | 24     | f32 x 4  | fx, fy, cx, cy, pixels                             |
//! | 40     | f32 x 6  | mount x, y, height (m), yaw, pitch, roll (rad)     |
//! | 64     | frames   | each: timestamp u64 (us), then `rows x width` bytes |
//!
//! Every other setting is the core's default ([`roadvo::Config::with_defaults`]): `pack` refuses a
//! mount file that changes one.

use crate::kitti::Sequence;
use crate::mount::{MethodName, MountFile};
use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use roadvo::{Config, Estimate, ImageSize, Method};
use std::io::Write;
use std::path::Path;

/// Bytes before the first frame.
pub const HEADER_BYTES: usize = 64;
/// The store's first four bytes.
pub const MAGIC: [u8; 4] = *b"RVFS";
/// The layout's version.
pub const VERSION: u16 = 1;

/// What `pack` wrote.
#[derive(Debug)]
pub struct Packed {
    /// Frames stored.
    pub frames: usize,
    /// Rows stored per frame, `first..end`.
    pub rows: std::ops::Range<u16>,
    /// Size of the store, bytes.
    pub bytes: usize,
}

/// Writes the first `frames` frames of `seq` (all if `None`) with the camera of `mount` to `out`.
pub fn pack(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<MethodName>,
    frames: Option<usize>,
    out: &Path,
) -> Result<Packed> {
    let config = crate::run::config_for(seq, mount, method)?;
    let c = config.config();
    let defaults = Config {
        method: c.method,
        ..Config::with_defaults(c.image, c.intrinsics, c.mount)
    };
    if *c != defaults {
        bail!(
            "the frame store carries the camera and the mount only, and the firmware uses the \
             default odometer settings: remove the [odometer] entries other than `method` from \
             the mount file"
        );
    }
    let rows = config.rows_read();
    let n = frames.unwrap_or(seq.frames).min(seq.frames);
    let ImageSize {
        width_px,
        height_px,
    } = c.image;
    let mut header = Vec::with_capacity(HEADER_BYTES);
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&VERSION.to_le_bytes());
    header.extend_from_slice(&0u16.to_le_bytes());
    for v in [width_px, height_px, rows.start, rows.end - rows.start] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    header.extend_from_slice(&(n as u32).to_le_bytes());
    header.push(match c.method {
        Method::PitchVote => 0,
        Method::Paper => 1,
    });
    header.extend_from_slice(&[0; 3]);
    let (k, m) = (c.intrinsics, c.mount);
    for v in [
        k.fx_px,
        k.fy_px,
        k.cx_px,
        k.cy_px,
        m.x_m,
        m.y_m,
        m.height_m,
        m.yaw_rad,
        m.pitch_rad,
        m.roll_rad,
    ] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    debug_assert_eq!(header.len(), HEADER_BYTES);
    let file =
        std::fs::File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut w = std::io::BufWriter::new(file);
    w.write_all(&header)?;
    let bar = ProgressBar::new(n as u64).with_style(
        ProgressStyle::with_template("packing {bar:40} {pos}/{len} frames")
            .expect("valid template"),
    );
    let width = usize::from(width_px);
    let band = usize::from(rows.start) * width..usize::from(rows.end) * width;
    for i in 0..n {
        let img = seq.load(i)?;
        w.write_all(&timestamp_us(seq, i).to_le_bytes())?;
        w.write_all(&img.as_raw()[band.clone()])?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    w.flush()
        .with_context(|| format!("cannot write {}", out.display()))?;
    Ok(Packed {
        frames: n,
        bytes: HEADER_BYTES + n * (8 + band.len()),
        rows,
    })
}

/// Frame `i`'s timestamp, microseconds, as every run of the odometer on `seq` gives it.
pub fn timestamp_us(seq: &Sequence, i: usize) -> u64 {
    (seq.times_s[i] * 1e6).round() as u64
}

/// One frame's estimate as the firmware example logs it: `kind` (`estimate`, the odometer's,
/// or `smoothed`, the smoother's), the frame number, the bit patterns of the motion (distance,
/// heading change), the pose (x, y, heading), the pitch and the inlier ratio, then features
/// detected, tracks matched, the fallback flag and the features set aside.
pub fn trace_line(kind: &str, frame: usize, e: &Estimate) -> String {
    let q = &e.quality;
    format!(
        "{kind} {frame} {} {} {} {} {} {} {} {} {} {} {}",
        e.motion.distance_m.to_bits(),
        e.motion.heading_change_rad.to_bits(),
        e.pose.x_m.to_bits(),
        e.pose.y_m.to_bits(),
        e.pose.heading_rad.to_bits(),
        q.pitch_rad.to_bits(),
        q.inlier_ratio.to_bits(),
        q.features_detected,
        q.tracks_matched,
        u8::from(q.fallback),
        q.features_comoving,
    )
}
