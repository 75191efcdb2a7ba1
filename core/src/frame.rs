//! How frames reach the core: a small trait over 8-bit grey rows, so that a camera's DMA line
//! buffer or a strided frame buffer can be read in place, without copying.

/// Size of a camera's frames, pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageSize {
    /// Columns, pixels.
    pub width_px: u16,
    /// Rows, pixels.
    pub height_px: u16,
}

/// An 8-bit grey camera frame, read a row at a time.
pub trait Frame {
    /// Columns, pixels.
    fn width(&self) -> u16;
    /// Rows, pixels.
    fn height(&self) -> u16;
    /// Row `y` (0 at the top), at least `width()` bytes long; bytes past the width are ignored.
    /// A shorter row reads as black beyond its end.
    fn row(&self, y: u16) -> &[u8];
}

/// A frame in one borrowed buffer, rows `stride` bytes apart (`stride >= width`).
#[derive(Clone, Copy, Debug)]
pub struct SliceFrame<'a> {
    data: &'a [u8],
    width: u16,
    height: u16,
    stride: usize,
}

impl<'a> SliceFrame<'a> {
    /// Wraps `data`; `None` if it is too short for `height` rows of `stride` bytes or if the
    /// stride is below the width.
    pub fn new(data: &'a [u8], width: u16, height: u16, stride: usize) -> Option<Self> {
        let needed = stride.checked_mul(usize::from(height))?;
        (stride >= usize::from(width) && data.len() >= needed).then_some(Self {
            data,
            width,
            height,
            stride,
        })
    }
}

impl Frame for SliceFrame<'_> {
    fn width(&self) -> u16 {
        self.width
    }

    fn height(&self) -> u16 {
        self.height
    }

    fn row(&self, y: u16) -> &[u8] {
        let start = usize::from(y) * self.stride;
        self.data
            .get(start..start + usize::from(self.width))
            .unwrap_or(&[])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strided_rows_skip_padding() {
        let data = [1u8, 2, 3, 0, 4, 5, 6, 0];
        let f = SliceFrame::new(&data, 3, 2, 4).unwrap();
        assert_eq!(f.row(1), &[4, 5, 6]);
        assert_eq!(f.row(2), &[] as &[u8]);
        assert!(SliceFrame::new(&data, 3, 3, 4).is_none());
        assert!(SliceFrame::new(&data, 5, 1, 4).is_none());
    }
}
