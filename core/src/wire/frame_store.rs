//! A recorded drive as a camera's frame memory would hold it: a header with the whole
//! configuration, then each frame's timestamp and the rows the odometer reads
//! ([`ValidConfig::rows_read`](crate::ValidConfig::rows_read)), as a camera with a readout window
//! delivers them. `roadvo pack` writes it, the firmware example replays it.
//!
//! Layout, little-endian ([`field`] names each range):
//!
//! | bytes | type | field |
//! |---|---|---|
//! | 0..4 | `[u8; 4]` | magic `RVFS` |
//! | 4..6 | u16 | layout version, 2 |
//! | 6..8 | u16 | header bytes ([`HEADER_BYTES`]) |
//! | 8..10 | u16 | first stored row |
//! | 10..12 | u16 | rows stored per frame |
//! | 12..16 | u32 | frames |
//! | 16.. | u32 x [`CONFIG_WORDS`] | the configuration ([`super::config_words`]) |
//! | header.. | frames | each: timestamp u64 (microseconds), then `rows x width` bytes |

use super::{CONFIG_WORDS, config_from_words, config_words};
use crate::config::Config;
use crate::frame::Frame;
use crate::frame::ImageSize;
use crate::time::Instant;

/// The byte ranges of the header's fields.
pub mod field {
    use core::ops::Range;
    /// Magic `RVFS`.
    pub const MAGIC: Range<usize> = 0..4;
    /// Layout version.
    pub const VERSION: Range<usize> = 4..6;
    /// Header bytes.
    pub const HEADER_BYTES: Range<usize> = 6..8;
    /// First stored row.
    pub const FIRST_ROW: Range<usize> = 8..10;
    /// Rows stored per frame.
    pub const ROWS: Range<usize> = 10..12;
    /// Frames stored.
    pub const FRAMES: Range<usize> = 12..16;
    /// The configuration's words.
    pub const CONFIG: Range<usize> = 16..16 + 4 * super::CONFIG_WORDS;
}

/// The store's first four bytes.
pub const MAGIC: [u8; 4] = *b"RVFS";
/// The layout's version.
pub const VERSION: u16 = 2;
/// Bytes before the first frame.
pub const HEADER_BYTES: usize = field::CONFIG.end;
/// Bytes of a frame's timestamp.
pub const TIMESTAMP_BYTES: usize = 8;

/// Why a frame memory holds no usable drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StoreError {
    /// No `RVFS` magic: nothing was loaded.
    NoStore,
    /// A layout version this build does not read.
    Version(u16),
    /// The header's size is not this layout's.
    HeaderSize(u16),
    /// A configuration word makes no value of its setting's type.
    Config,
    /// The stored rows lie outside the frame, or the frames do not fit the memory.
    Truncated,
}

impl core::fmt::Display for StoreError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoStore => f.write_str("no frame store (the magic RVFS is missing)"),
            Self::Version(v) => write!(f, "frame store layout {v}, this build reads {VERSION}"),
            Self::HeaderSize(n) => write!(
                f,
                "frame store header of {n} bytes, this build's is {HEADER_BYTES} (a build with \
                 other settings wrote it)"
            ),
            Self::Config => f.write_str("the frame store's configuration holds a bad word"),
            Self::Truncated => {
                f.write_str("the frame store's frames do not fit its memory or its frame size")
            }
        }
    }
}

impl core::error::Error for StoreError {}

/// What a store's header says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Header {
    /// The configuration the drive is to be run with (not yet validated).
    pub config: Config,
    /// First row stored of each frame.
    pub first_row: u16,
    /// Rows stored of each frame.
    pub rows: u16,
    /// Frames stored.
    pub frames: u32,
}

impl Header {
    /// The header's bytes.
    pub fn to_bytes(&self) -> [u8; HEADER_BYTES] {
        let mut b = [0u8; HEADER_BYTES];
        let mut put = |range: core::ops::Range<usize>, bytes: &[u8]| {
            if let Some(slot) = b.get_mut(range) {
                slot.copy_from_slice(bytes);
            }
        };
        put(field::MAGIC, &MAGIC);
        put(field::VERSION, &VERSION.to_le_bytes());
        put(field::HEADER_BYTES, &(HEADER_BYTES as u16).to_le_bytes());
        put(field::FIRST_ROW, &self.first_row.to_le_bytes());
        put(field::ROWS, &self.rows.to_le_bytes());
        put(field::FRAMES, &self.frames.to_le_bytes());
        for (i, w) in config_words(&self.config).iter().enumerate() {
            let at = field::CONFIG.start + 4 * i;
            put(at..at + 4, &w.to_le_bytes());
        }
        b
    }

    /// Bytes of one stored frame: its timestamp and its rows.
    pub fn frame_bytes(&self) -> usize {
        TIMESTAMP_BYTES + usize::from(self.rows) * usize::from(self.config.camera.width_px)
    }
}

/// A drive in a frame memory.
#[derive(Clone, Copy, Debug)]
pub struct FrameStore<'a> {
    header: Header,
    data: &'a [u8],
}

fn u16_at(b: &[u8], r: core::ops::Range<usize>) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(r)?.try_into().ok()?))
}

fn u32_at(b: &[u8], r: core::ops::Range<usize>) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(r)?.try_into().ok()?))
}

impl<'a> FrameStore<'a> {
    /// Reads the header at the start of `memory` and checks that the frames fit in it.
    pub fn open(memory: &'a [u8]) -> Result<Self, StoreError> {
        let h = memory.get(..HEADER_BYTES).ok_or(StoreError::Truncated)?;
        if h.get(field::MAGIC) != Some(&MAGIC[..]) {
            return Err(StoreError::NoStore);
        }
        let version = u16_at(h, field::VERSION).ok_or(StoreError::Truncated)?;
        if version != VERSION {
            return Err(StoreError::Version(version));
        }
        let size = u16_at(h, field::HEADER_BYTES).ok_or(StoreError::Truncated)?;
        if usize::from(size) != HEADER_BYTES {
            return Err(StoreError::HeaderSize(size));
        }
        let mut words = [0u32; CONFIG_WORDS];
        for (i, w) in words.iter_mut().enumerate() {
            let at = field::CONFIG.start + 4 * i;
            *w = u32_at(h, at..at + 4).ok_or(StoreError::Truncated)?;
        }
        let header = Header {
            config: config_from_words(&words).ok_or(StoreError::Config)?,
            first_row: u16_at(h, field::FIRST_ROW).ok_or(StoreError::Truncated)?,
            rows: u16_at(h, field::ROWS).ok_or(StoreError::Truncated)?,
            frames: u32_at(h, field::FRAMES).ok_or(StoreError::Truncated)?,
        };
        let data = memory.get(HEADER_BYTES..).unwrap_or_default();
        let image = header.config.camera.image();
        let rows_fit =
            u32::from(header.first_row) + u32::from(header.rows) <= u32::from(image.height_px);
        let bytes = header.frame_bytes().checked_mul(header.frames as usize);
        if !rows_fit || bytes.is_none_or(|b| b > data.len()) {
            return Err(StoreError::Truncated);
        }
        Ok(Self { header, data })
    }

    /// What the header says.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Whether each stored frame holds all of `rows`.
    pub fn holds_rows(&self, rows: core::ops::Range<u16>) -> bool {
        let h = &self.header;
        rows.start >= h.first_row
            && u32::from(rows.end) <= u32::from(h.first_row) + u32::from(h.rows)
    }

    /// Frame `i` and its timestamp; `None` past the last frame.
    pub fn frame(&self, i: u32) -> Option<(BandFrame<'a>, Instant)> {
        if i >= self.header.frames {
            return None;
        }
        let size = self.header.frame_bytes();
        let start = (i as usize).checked_mul(size)?;
        let bytes = self.data.get(start..start.checked_add(size)?)?;
        let (time, pixels) = bytes.split_at_checked(TIMESTAMP_BYTES)?;
        let timestamp = Instant::from_micros(u64::from_le_bytes(time.try_into().ok()?));
        let frame = BandFrame {
            image: self.header.config.camera.image(),
            first_row: self.header.first_row,
            pixels,
        };
        Some((frame, timestamp))
    }
}

/// One frame of which only a band of rows was delivered; the others read as black (the odometer
/// never asks for them where the band holds [`ValidConfig::rows_read`](crate::ValidConfig::rows_read)).
#[derive(Clone, Copy, Debug)]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::kitti_config;
    use std::vec::Vec;

    #[test]
    fn a_written_store_reads_back_frame_by_frame() {
        let header = Header {
            config: kitti_config(),
            first_row: 280,
            rows: 2,
            frames: 3,
        };
        let mut bytes = header.to_bytes().to_vec();
        for i in 0..3u8 {
            bytes.extend_from_slice(&(1000 * u64::from(i)).to_le_bytes());
            bytes.extend((0..2 * 1241).map(|k| (k % 7) as u8 + i));
        }
        let store = FrameStore::open(&bytes).unwrap();
        assert_eq!(store.header(), &header);
        assert!(store.holds_rows(280..282) && !store.holds_rows(279..282));
        let (frame, t) = store.frame(2).unwrap();
        assert_eq!(t, Instant::from_micros(2000));
        assert_eq!(frame.row(281)[0], 2 + (1241 % 7) as u8);
        assert_eq!(frame.row(282), &[] as &[u8]);
        assert!(store.frame(3).is_none());
        // One byte short of the last frame; another version; nothing loaded.
        assert_eq!(
            FrameStore::open(&bytes[..bytes.len() - 1]).unwrap_err(),
            StoreError::Truncated
        );
        let mut other = bytes.clone();
        other[4] = 1;
        assert_eq!(
            FrameStore::open(&other).unwrap_err(),
            StoreError::Version(1)
        );
        let zeros: Vec<u8> = std::vec![0; HEADER_BYTES];
        assert_eq!(FrameStore::open(&zeros).unwrap_err(), StoreError::NoStore);
    }
}
