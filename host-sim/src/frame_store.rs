//! `roadvo pack`: a sequence written as the firmware example's frame store (the layout is the
//! core's, [`roadvo::wire::frame_store`]): the whole configuration, then per frame its timestamp
//! and only the rows the odometer reads, as a camera with a readout window would deliver them.

use crate::kitti::Sequence;
use crate::mount::MountFile;
use crate::run::config_for;
use anyhow::{Context, Result};
use roadvo::Method;
use roadvo::wire::frame_store::{HEADER_BYTES, Header};
use std::io::Write;
use std::path::Path;

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

/// How many frames to pack.
#[derive(Clone, Copy, Debug, Default)]
pub struct Limit {
    /// Frames from the start of the sequence (`None`: all).
    pub frames: Option<usize>,
    /// The store's size, bytes: as many frames as fit in a frame memory of this size (`None`:
    /// no limit).
    pub bytes: Option<usize>,
}

/// Writes the first frames of `seq`, as many as `limit` allows, with the configuration of
/// `mount` (its method replaced by `method` if given) to `out`; `progress` hears of each frame.
pub fn pack(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<Method>,
    limit: Limit,
    out: &Path,
    mut progress: impl FnMut(),
) -> Result<Packed> {
    let config = config_for(seq, mount, method)?;
    let rows = config.rows_read();
    let mut header = Header {
        config: *config.config(),
        first_row: rows.start,
        rows: rows.end - rows.start,
        frames: 0,
    };
    let fit = limit.bytes.map_or(usize::MAX, |b| {
        b.saturating_sub(HEADER_BYTES) / header.frame_bytes()
    });
    let n = limit.frames.unwrap_or(seq.frames).min(seq.frames).min(fit);
    header.frames = u32::try_from(n).context("too many frames for a frame store")?;
    let file =
        std::fs::File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut w = std::io::BufWriter::new(file);
    let write_failed = || format!("cannot write {}", out.display());
    w.write_all(&header.to_bytes()).with_context(write_failed)?;
    let width = usize::from(config.config().camera.width_px);
    let band = usize::from(rows.start) * width..usize::from(rows.end) * width;
    for i in 0..n {
        let img = seq.load(i)?;
        w.write_all(&seq.timestamp(i).total_micros().to_le_bytes())
            .with_context(write_failed)?;
        w.write_all(&img.as_raw()[band.clone()])
            .with_context(write_failed)?;
        progress();
    }
    w.flush().with_context(write_failed)?;
    Ok(Packed {
        frames: n,
        bytes: HEADER_BYTES + n * header.frame_bytes(),
        rows,
    })
}
