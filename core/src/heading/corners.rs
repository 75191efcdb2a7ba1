//! Corners over the whole frame: the FAST segment test (a pixel whose ring of sixteen at radius
//! 3 holds nine in a row all brighter, or all darker, than it by the threshold), integer only,
//! kept the strongest few per cell of a grid so that no one patch of the scene holds them all.

use crate::frame::Frame;
use core::num::NonZeroU16;
use core::ops::RangeInclusive;

/// A corner of the whole frame: its pixel and its FAST score.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageCorner {
    /// Column, pixels.
    pub u: u16,
    /// Row, pixels.
    pub v: u16,
    /// How far the ring's pixels stand beyond the threshold, summed (grey levels).
    pub score: u16,
}

/// Pixels in a row of the ring that make a corner.
const ARC: u32 = 9;

/// Closest two kept corners of one cell may be, pixels (each axis).
const MIN_SEPARATION_PX: u16 = 5;

/// How the frame is shared out: a grid of `columns x rows` cells, `per_cell` corners each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    /// Cells across.
    pub columns: u16,
    /// Cells down.
    pub rows: u16,
    /// Corners kept a cell.
    pub per_cell: u16,
}

impl Grid {
    /// Corners it keeps at most.
    pub fn capacity(&self) -> usize {
        usize::from(self.columns) * usize::from(self.rows) * usize::from(self.per_cell)
    }

    /// The border [`detect`] keeps to with `border`: the ring must fit inside the frame.
    fn inner_border(border: u16) -> u16 {
        border.max(3)
    }

    /// A cell's width and height, pixels, on a `width x height` frame inside `border`, as
    /// [`detect`] shares it out (in its own lines there, which the Cortex-M7's build of its
    /// loops is the cheaper for); `None` where the frame has no inside.
    fn cell_px(&self, width: u16, height: u16, border: u16) -> Option<(NonZeroU16, NonZeroU16)> {
        let border = Self::inner_border(border);
        let inner_w = NonZeroU16::new(width.checked_sub(border.saturating_mul(2))?)?;
        let inner_h = NonZeroU16::new(height.checked_sub(border.saturating_mul(2))?)?;
        let share = |n: NonZeroU16, cells: u16| {
            n.div_ceil(NonZeroU16::new(cells).unwrap_or(NonZeroU16::MIN))
        };
        Some((share(inner_w, self.columns), share(inner_h, self.rows)))
    }

    /// The cells, as ranges of columns and rows, that hold every corner [`detect`] may find
    /// with its column in `u_px` and its row in `v_px` (both closed, pixels) on a `width x
    /// height` frame inside `border`; all of them where a bound is not a number. `None` where
    /// the frame has no inside.
    pub fn cells_within(
        &self,
        (width, height, border): (u16, u16, u16),
        u_px: (f32, f32),
        v_px: (f32, f32),
    ) -> Option<(RangeInclusive<u16>, RangeInclusive<u16>)> {
        let (cell_w, cell_h) = self.cell_px(width, height, border)?;
        let border = Self::inner_border(border);
        let all = (0..=self.columns.max(1) - 1, 0..=self.rows.max(1) - 1);
        if !(u_px.0 <= u_px.1 && v_px.0 <= v_px.1) {
            return Some(all);
        }
        // A pixel more each side: whichever way the caller's own test of the bounds rounds.
        let cell = |(lo, hi): (f32, f32), size: NonZeroU16, last: u16| {
            let at = |x: f32| ((x as u16).max(border) - border) / size;
            at(lo - 1.0).min(last)..=at(hi + 1.0).min(last)
        };
        Some((
            cell(u_px, cell_w, *all.0.end()),
            cell(v_px, cell_h, *all.1.end()),
        ))
    }
}

/// Whether a ring's mask (bit k: pixel k of the ring) holds [`ARC`] in a row, round the ring.
fn has_arc(mask: u16) -> bool {
    let m = u32::from(mask) | (u32::from(mask) << 16);
    // Runs of 2, 4 and 8 in a row, then the ninth.
    let two = m & (m >> 1);
    let four = two & (two >> 2);
    let eight = four & (four >> 4);
    eight & (m >> (ARC - 1)) != 0
}

/// Pixels between the places tested, each axis: a corner fires the test at several pixels
/// around it, so every other column of every other row finds it, in a quarter of the time
/// (and where exactly it sits does not matter: its patch is what is found again).
const STRIDE: usize = 2;

/// Pixels of a row the compass pre-test takes at once (a multiple of [`STRIDE`]).
const LANES: usize = 16;

/// The ring of sixteen at radius 3 in a 7x7 window, in order round it from straight up,
/// clockwise: (row, column).
const RING: [(usize, usize); 16] = [
    (0, 3),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 6),
    (4, 6),
    (5, 5),
    (6, 4),
    (6, 3),
    (6, 2),
    (5, 1),
    (4, 0),
    (3, 0),
    (2, 0),
    (1, 1),
    (0, 2),
];

/// Finds the corners of `frame` at least `border` pixels inside it with FAST threshold
/// `threshold` (grey levels), the `grid.per_cell` strongest of each cell kept in `out` (slot
/// `cell * per_cell + k`; `None` where a cell has fewer). `out` must hold `grid.capacity()`.
pub fn detect<F: Frame + ?Sized>(
    frame: &F,
    threshold: u8,
    grid: Grid,
    border: u16,
    out: &mut [Option<ImageCorner>],
) {
    detect_with(frame, threshold, grid, border, out, VECTOR_PRETEST);
}

/// Whether the compass pre-test takes [`LANES`] pixels at once: where the compiler has vector
/// instructions for it (x86-64, AArch64). Elsewhere (a Cortex-M) it takes one tested pixel at a
/// time after a quicker test of its top and bottom, which most pixels fail: cheaper there, and
/// the same corners.
const VECTOR_PRETEST: bool = cfg!(any(target_arch = "x86_64", target_arch = "aarch64"));

/// [`detect`], the pre-test taking [`LANES`] pixels at once where `vector`.
fn detect_with<F: Frame + ?Sized>(
    frame: &F,
    threshold: u8,
    grid: Grid,
    border: u16,
    out: &mut [Option<ImageCorner>],
    vector: bool,
) {
    out.fill(None);
    let (w, h) = (frame.width(), frame.height());
    let border = Grid::inner_border(border);
    if w <= 2 * border || h <= 2 * border || grid.capacity() == 0 || grid.capacity() > out.len() {
        return;
    }
    let (inner_w, inner_h) = (w - 2 * border, h - 2 * border);
    // Never zero (inner_w, inner_h > 0); the max says so to the compiler, which keeps no panic.
    let cell_w = inner_w.div_ceil(grid.columns.max(1)).max(1);
    let cell_h = inner_h.div_ceil(grid.rows.max(1)).max(1);
    let (first, end) = (usize::from(border), usize::from(w - border));
    for v in (border..h - border).step_by(STRIDE) {
        let rows: [&[u8]; 7] = core::array::from_fn(|k| frame.row(v - 3 + k as u16));
        let cell_row = (v - border) / cell_h;
        // The compass pixels of every tested one: up, down, left and right three away (the
        // border keeps them inside the frame).
        let [top, middle, bottom] = [0, 3, 6].map(|r| rows[r].get(first..end).unwrap_or_default());
        let left = rows[3]
            .get(first.saturating_sub(3)..end - 3)
            .unwrap_or_default();
        let right = rows[3].get(first + 3..end + 3).unwrap_or_default();
        // The segment test at the `j`th pixel from the first, of the arcs `sides` leaves.
        let mut test = |j: usize, sides: u8| {
            if sides == 0 {
                return;
            }
            let Some(corner) = segment(&rows, first + j, v, threshold, sides) else {
                return;
            };
            let cell = usize::from(cell_row) * usize::from(grid.columns)
                + usize::from((corner.u - border) / cell_w);
            let first = cell * usize::from(grid.per_cell);
            if let Some(slots) = out.get_mut(first..first + usize::from(grid.per_cell)) {
                keep(slots, corner);
            }
        };
        // Whole runs of LANES pixels at once where `vector`; the rest (all of a row on a
        // Cortex-M) one tested pixel at a time.
        let rows5 = [top, middle, bottom, left, right];
        let whole = match rows5.map(<[u8]>::len).into_iter().min() {
            Some(n) if vector => n / LANES * LANES,
            _ => 0,
        };
        for base in (0..whole).step_by(LANES) {
            let lane = |row| lanes_at(row, base);
            let (Some(up), Some(c), Some(down), Some(l), Some(r)) = (
                lane(top),
                lane(middle),
                lane(bottom),
                lane(left),
                lane(right),
            ) else {
                continue;
            };
            let lanes = [up, c, down, l, r];
            let sides = compass(lanes, threshold);
            if u128::from_ne_bytes(sides) == 0 {
                continue;
            }
            for (k, &sides) in sides.iter().enumerate().step_by(STRIDE) {
                test(base + k, sides);
            }
        }
        let [top, middle, bottom] =
            [top, middle, bottom].map(|r| r.get(whole..).unwrap_or_default());
        let rest = top.iter().zip(middle).zip(bottom).step_by(STRIDE);
        for (k, ((&up, &c), &down)) in rest.enumerate() {
            // The top or the bottom first (see `arcs`): most pixels stop here.
            if up.abs_diff(c) <= threshold && down.abs_diff(c) <= threshold {
                continue;
            }
            let j = whole + k * STRIDE;
            let side = |row: &[u8]| row.get(j).copied().unwrap_or(c);
            test(j, arcs([up, c, down, side(left), side(right)], threshold));
        }
    }
}

/// The [`LANES`] pixels of `row` from `base`, if it holds them all.
fn lanes_at(row: &[u8], base: usize) -> Option<&[u8; LANES]> {
    row.get(base..base + LANES)?.try_into().ok()
}

/// The compass pre-test of one pixel: `[up, centre, down, left, right]`, the pixels three
/// above, at, below, left and right of it. Which arcs it leaves possible ([`BRIGHT`],
/// [`DARK`]).
fn arcs([up, c, down, left, right]: [u8; 5], threshold: u8) -> u8 {
    let (hi, lo) = (c.saturating_add(threshold), c.saturating_sub(threshold));
    // Nine in a row take in two neighbouring compass pixels of the four (up and right, right
    // and down, ...), so the top or the bottom. In u8: a bound beyond 0..255 saturates, and
    // nothing lies beyond it.
    let bright = ((up > hi) | (down > hi)) & ((left > hi) | (right > hi));
    let dark = ((up < lo) | (down < lo)) & ((left < lo) | (right < lo));
    (u8::from(bright) * BRIGHT) | (u8::from(dark) * DARK)
}

/// The compass pre-test ([`arcs`]) of [`LANES`] pixels at once: `[up, centre, down, left,
/// right]`, each the pixels three above, at, below, left and right of them.
fn compass(rows: [&[u8; LANES]; 5], threshold: u8) -> [u8; LANES] {
    let [up, c, down, left, right] = rows;
    core::array::from_fn(|j| arcs([up[j], c[j], down[j], left[j], right[j]], threshold))
}

/// Which arcs the pre-test leaves possible: brighter than the centre, darker.
const BRIGHT: u8 = 1;
const DARK: u8 = 2;

/// The segment test's last stage at column `u` of row `v` (the middle one of `rows`): nine of
/// the ring in a row all brighter or all darker than the centre by `t`, of the arcs `sides`
/// ([`BRIGHT`], [`DARK`]) leaves possible; the corner with its score, or `None`.
fn segment(rows: &[&[u8]; 7], u: usize, v: u16, t: u8, sides: u8) -> Option<ImageCorner> {
    let mut win: [&[u8; 7]; 7] = [&[0; 7]; 7];
    for (w, r) in win.iter_mut().zip(rows) {
        *w = r.get(u.checked_sub(3)?..u + 4)?.try_into().ok()?;
    }
    let c = i16::from(win[3][3]);
    let (hi, lo) = (c + i16::from(t), c - i16::from(t));
    let mut ring = [0i16; 16];
    for (p, &(r, c)) in ring.iter_mut().zip(&RING) {
        *p = i16::from(*win.get(r)?.get(c)?);
    }
    let arc = |beyond: &dyn Fn(i16) -> bool| {
        let mask = ring
            .iter()
            .enumerate()
            .fold(0u16, |m, (k, &p)| m | u16::from(beyond(p)) << k);
        has_arc(mask)
    };
    let score: i32 = if sides & BRIGHT != 0 && arc(&|p| p > hi) {
        ring.iter().map(|&p| i32::from((p - hi).max(0))).sum()
    } else if sides & DARK != 0 && arc(&|p| p < lo) {
        ring.iter().map(|&p| i32::from((lo - p).max(0))).sum()
    } else {
        return None;
    };
    Some(ImageCorner {
        u: u16::try_from(u).ok()?,
        v,
        score: u16::try_from(score).unwrap_or(u16::MAX),
    })
}

/// Keeps `c` among a cell's strongest `slots`, no two closer than [`MIN_SEPARATION_PX`].
fn keep(slots: &mut [Option<ImageCorner>], c: ImageCorner) {
    let near = |o: &ImageCorner| {
        o.u.abs_diff(c.u) < MIN_SEPARATION_PX && o.v.abs_diff(c.v) < MIN_SEPARATION_PX
    };
    // One pass: a stronger neighbour keeps it out; otherwise the first of the weakest slots
    // (an empty one before any other) and whether weaker neighbours must give way.
    let (mut weakest, mut weakest_key, mut neighbours) = (None, u32::MAX, false);
    for (k, slot) in slots.iter().enumerate() {
        let key = match slot {
            Some(o) if near(o) && o.score >= c.score => return,
            Some(o) => {
                neighbours |= near(o);
                u32::from(o.score) + 1
            }
            None => 0,
        };
        if key < weakest_key {
            (weakest, weakest_key) = (Some(k), key);
        }
    }
    if neighbours {
        // Weaker neighbours give way; the first slot left empty takes it.
        for slot in slots.iter_mut() {
            if slot.is_some_and(|o| near(&o)) {
                *slot = None;
            }
        }
        weakest = slots.iter().position(Option::is_none);
        weakest_key = 0;
    }
    if let Some(slot) = weakest.and_then(|k| slots.get_mut(k))
        && weakest_key <= u32::from(c.score)
    {
        *slot = Some(c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::SliceFrame;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn a_bright_square_on_dark_has_corners_at_its_corners_only() {
        let (w, h) = (64u16, 48u16);
        let mut img = vec![20u8; usize::from(w) * usize::from(h)];
        // Its corners on the pixels the detector tests (every other one, from the border).
        for y in 16..31 {
            for x in 20..39 {
                img[y * usize::from(w) + x] = 200;
            }
        }
        let frame = SliceFrame::new(&img, w, h, usize::from(w)).unwrap();
        let grid = Grid {
            columns: 2,
            rows: 2,
            per_cell: 4,
        };
        let mut out = [None; 16];
        detect(&frame, 30, grid, 4, &mut out);
        let found: Vec<_> = out.iter().flatten().collect();
        assert!(found.len() >= 4, "{found:?}");
        for c in &found {
            let at_corner = [(20, 16), (38, 16), (20, 30), (38, 30)]
                .iter()
                .any(|&(x, y)| c.u.abs_diff(x) <= 2 && c.v.abs_diff(y) <= 2);
            assert!(at_corner, "{c:?} is not at a corner of the square");
        }
    }

    /// The detector without its pre-tests: the segment test, both arcs, at every tested pixel,
    /// each corner offered to the same cells in the same order.
    fn reference(
        frame: &SliceFrame,
        threshold: u8,
        grid: Grid,
        border: u16,
    ) -> Vec<Option<ImageCorner>> {
        let mut out = vec![None; grid.capacity()];
        let (w, h) = (frame.width(), frame.height());
        let cell_w = (w - 2 * border).div_ceil(grid.columns);
        let cell_h = (h - 2 * border).div_ceil(grid.rows);
        for v in (border..h - border).step_by(STRIDE) {
            let rows: [&[u8]; 7] = core::array::from_fn(|k| frame.row(v - 3 + k as u16));
            for u in (border..w - border).step_by(STRIDE) {
                let Some(corner) = segment(&rows, usize::from(u), v, threshold, BRIGHT | DARK)
                else {
                    continue;
                };
                let cell = usize::from((v - border) / cell_h) * usize::from(grid.columns)
                    + usize::from((u - border) / cell_w);
                let first = cell * usize::from(grid.per_cell);
                keep(&mut out[first..first + usize::from(grid.per_cell)], corner);
            }
        }
        out
    }

    /// A `w x h` image (at most 104 x 64 pixels) of 4x4 blocks of random grey levels, corners
    /// where they meet, under pixel noise; from `seed`.
    fn blocks(w: u16, h: u16, seed: u32) -> Vec<u8> {
        let mut next = crate::test_rng::uniform(seed);
        let blocks: Vec<u8> = (0..26 * 16).map(|_| (next() * 255.0) as u8).collect();
        (0..usize::from(w) * usize::from(h))
            .map(|k| {
                let (x, y) = (k % usize::from(w), k / usize::from(w));
                let noise = (next() * 24.0) as u8;
                blocks[(y / 4) * 26 + x / 4].saturating_add(noise)
            })
            .collect()
    }

    #[test]
    fn the_pre_tests_drop_no_corner_of_the_segment_test() {
        // A width whose tested run is no whole number of lanes: the last pixels are tested too.
        let (w, h) = (101u16, 64u16);
        let img = blocks(w, h, 17);
        let frame = SliceFrame::new(&img, w, h, usize::from(w)).unwrap();
        let grid = Grid {
            columns: 4,
            rows: 2,
            per_cell: 6,
        };
        for threshold in [5, 20, 60] {
            // Both pre-tests: many pixels at once, and one at a time (a Cortex-M's).
            for vector in [true, false] {
                let mut out = vec![None; grid.capacity()];
                detect_with(&frame, threshold, grid, 8, &mut out, vector);
                let found = out.iter().flatten().count();
                assert!(found > 8, "threshold {threshold}: {found} corners");
                assert_eq!(
                    out,
                    reference(&frame, threshold, grid, 8),
                    "threshold {threshold}, vector {vector}"
                );
            }
        }
    }

    #[test]
    fn the_cells_of_a_rectangle_hold_every_corner_inside_it() {
        let (w, h) = (101u16, 64u16);
        let img = blocks(w, h, 29);
        let frame = SliceFrame::new(&img, w, h, usize::from(w)).unwrap();
        let mut next = crate::test_rng::uniform(31);
        let grid = Grid {
            columns: 7,
            rows: 3,
            per_cell: 5,
        };
        let mut out = vec![None; grid.capacity()];
        detect(&frame, 20, grid, 8, &mut out);
        let corners: Vec<(usize, ImageCorner)> = out
            .iter()
            .enumerate()
            .filter_map(|(k, c)| c.map(|c| (k / usize::from(grid.per_cell), c)))
            .collect();
        assert!(corners.len() > 40, "{} corners", corners.len());
        for _ in 0..500 {
            // Rectangles of any size, partly or wholly off the frame, on fractional bounds.
            let u0 = next() * 140.0 - 20.0;
            let v0 = next() * 100.0 - 20.0;
            let (u1, v1) = (u0 + next() * 40.0, v0 + next() * 30.0);
            let (columns, rows) = grid.cells_within((w, h, 8), (u0, u1), (v0, v1)).unwrap();
            for &(cell, c) in &corners {
                let (u, v) = (f32::from(c.u), f32::from(c.v));
                if (u0..=u1).contains(&u) && (v0..=v1).contains(&v) {
                    let (col, row) = (cell % 7, cell / 7);
                    assert!(
                        columns.contains(&(col as u16)) && rows.contains(&(row as u16)),
                        "{c:?} in cell ({col}, {row}), rectangle {u0} {u1} {v0} {v1}: {columns:?} {rows:?}"
                    );
                }
            }
        }
        // A bound that is not a number: every cell. A frame without an inside: none.
        assert_eq!(
            grid.cells_within((w, h, 8), (f32::NAN, 10.0), (0.0, 10.0)),
            Some((0..=6, 0..=2))
        );
        assert_eq!(
            grid.cells_within((16, 16, 8), (0.0, 10.0), (0.0, 10.0)),
            None
        );
    }

    #[test]
    fn arcs_wrap_round_the_ring() {
        assert!(has_arc(0b1111_1111_1000_0000 | 0b1));
        assert!(!has_arc(0b0000_0000_1111_1111));
        assert!(has_arc(0b0000_0001_1111_1111));
    }
}
