//! `roadvo pack`: a sequence written as the firmware example's frame store (the layout is the
//! core's, [`roadvo::wire::frame_store`]): the whole configuration, then per frame its timestamp
//! and only the rows the odometer reads, as a camera with a readout window would deliver them.

use crate::kitti::Sequence;
use crate::mount::MountFile;
use crate::output::OutputFile;
use crate::run::config_for;
use anyhow::{Context, Result, bail};
use roadvo::Method;
use roadvo::wire::frame_store::{HEADER_BYTES, Header};
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
/// `mount` (its method replaced by `method` if given) to `out`, whole or not at all (a failed or
/// interrupted pack leaves an earlier `out` as it was); `progress` hears of each frame.
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
    if n == 0 {
        bail!(
            "{}: no frame to pack (--frames 0, or --max-bytes below one frame of {} bytes)",
            out.display(),
            HEADER_BYTES + header.frame_bytes()
        );
    }
    header.frames = u32::try_from(n).context("too many frames for a frame store")?;
    let mut w = OutputFile::create(out)?;
    w.write_all(&header.to_bytes())?;
    let width = usize::from(config.config().camera.width_px);
    let band = usize::from(rows.start) * width..usize::from(rows.end) * width;
    for i in 0..n {
        crate::interrupt::check()?;
        let img = seq.load(i)?;
        w.write_all(&seq.timestamp(i).total_micros().to_le_bytes())?;
        w.write_all(&img.as_raw()[band.clone()])?;
        progress();
    }
    w.commit()?;
    Ok(Packed {
        frames: n,
        bytes: HEADER_BYTES + n * header.frame_bytes(),
        rows,
    })
}
