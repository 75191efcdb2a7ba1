//! The frame source standing in for a camera driver: a recorded drive in the camera's frame
//! memory (the board's PSRAM), as `roadvo pack` writes it and QEMU's loader puts it there. Each
//! frame holds only the rows the odometer reads, as a camera with a readout window delivers them.
//!
//! Layout (little-endian; the writer documents it: `host-sim/src/frame_store.rs`): a 64-byte
//! header (magic `RVFS`, version 1, frame width and height, first stored row, rows per frame,
//! frames, method, intrinsics, mount), then per frame a `u64` timestamp in microseconds and
//! `rows x width` bytes of 8-bit grey.

use roadvo::{Frame, ImageSize, Intrinsics, Method, Mount};

const HEADER_BYTES: usize = 64;
const MAGIC: [u8; 4] = *b"RVFS";
const VERSION: u16 = 1;

/// Why the frame memory holds no usable drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum StoreError {
    /// No `RVFS` magic: nothing was loaded (see `scripts/firmware`).
    NoStore,
    /// A layout version this firmware does not read.
    Version(u16),
    /// The method byte is neither 0 (default) nor 1 (paper).
    Method(u8),
    /// The stored rows lie outside the frame, or the frames do not fit the memory.
    Truncated,
}

/// A drive in the camera's frame memory.
pub struct FrameStore<'a> {
    image: ImageSize,
    first_row: u16,
    rows: u16,
    frames: u32,
    method: Method,
    intrinsics: Intrinsics,
    mount: Mount,
    data: &'a [u8],
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_bits(u32_at(b, at))
}

impl<'a> FrameStore<'a> {
    /// Reads the header at the start of `memory` and checks that the frames fit in it.
    pub fn open(memory: &'a [u8]) -> Result<Self, StoreError> {
        let h = memory.get(..HEADER_BYTES).ok_or(StoreError::Truncated)?;
        if h[..4] != MAGIC {
            return Err(StoreError::NoStore);
        }
        let version = u16_at(h, 4);
        if version != VERSION {
            return Err(StoreError::Version(version));
        }
        let image = ImageSize {
            width_px: u16_at(h, 8),
            height_px: u16_at(h, 10),
        };
        let (first_row, rows, frames) = (u16_at(h, 12), u16_at(h, 14), u32_at(h, 16));
        let method = match h[20] {
            0 => Method::PitchVote,
            1 => Method::Paper,
            other => return Err(StoreError::Method(other)),
        };
        let f = |i: usize| f32_at(h, 24 + 4 * i);
        let store = Self {
            image,
            first_row,
            rows,
            frames,
            method,
            intrinsics: Intrinsics {
                fx_px: f(0),
                fy_px: f(1),
                cx_px: f(2),
                cy_px: f(3),
            },
            mount: Mount {
                x_m: f(4),
                y_m: f(5),
                height_m: f(6),
                yaw_rad: f(7),
                pitch_rad: f(8),
                roll_rad: f(9),
            },
            data: &memory[HEADER_BYTES..],
        };
        let rows_fit = u32::from(first_row) + u32::from(rows) <= u32::from(image.height_px);
        let bytes = store.frame_bytes().checked_mul(frames as usize);
        if !rows_fit || bytes.is_none_or(|b| b > store.data.len()) {
            return Err(StoreError::Truncated);
        }
        Ok(store)
    }

    /// Size of the camera's frames.
    pub fn image(&self) -> ImageSize {
        self.image
    }

    /// The camera's intrinsics.
    pub fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }

    /// Where the camera sits.
    pub fn mount(&self) -> Mount {
        self.mount
    }

    /// The method the drive was recorded for.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Frames stored.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Whether each stored frame holds all of `rows`.
    pub fn holds_rows(&self, rows: core::ops::Range<u16>) -> bool {
        rows.start >= self.first_row
            && u32::from(rows.end) <= u32::from(self.first_row) + u32::from(self.rows)
    }

    fn frame_bytes(&self) -> usize {
        8 + usize::from(self.rows) * usize::from(self.image.width_px)
    }

    /// Frame `i` and its timestamp, microseconds; `None` past the last frame.
    pub fn frame(&self, i: u32) -> Option<(BandFrame<'a>, u64)> {
        let size = self.frame_bytes();
        let start = (i as usize).checked_mul(size)?;
        let bytes = self.data.get(start..start.checked_add(size)?)?;
        let (time, pixels) = bytes.split_at_checked(8)?;
        let timestamp_us = u64::from_le_bytes(time.try_into().ok()?);
        let frame = BandFrame {
            image: self.image,
            first_row: self.first_row,
            pixels,
        };
        Some((frame, timestamp_us))
    }
}

/// One frame of which only a band of rows was delivered; the others read as black (the odometer
/// never asks for them: `FrameStore::holds_rows` of `ValidConfig::rows_read`).
pub struct BandFrame<'a> {
    image: ImageSize,
    first_row: u16,
    pixels: &'a [u8],
}

impl Frame for BandFrame<'_> {
    fn width(&self) -> u16 {
        self.image.width_px
    }

    fn height(&self) -> u16 {
        self.image.height_px
    }

    fn row(&self, y: u16) -> &[u8] {
        let w = usize::from(self.image.width_px);
        let Some(band_row) = y.checked_sub(self.first_row) else {
            return &[];
        };
        let start = usize::from(band_row) * w;
        self.pixels.get(start..start + w).unwrap_or(&[])
    }
}
