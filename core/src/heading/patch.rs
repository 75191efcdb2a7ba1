//! Appearance: a 7x7 patch of grey levels kept for each corner, found again in the next frame by
//! the zero-mean sum of squared differences (insensitive to a change of exposure), stepping
//! from a candidate to the best of the pixels around until it settles, then to a fraction of a
//! pixel by a quadric through its neighbours (a
//! sum of squares is a parabola near its minimum; a sum of absolute values is not, and pulled
//! the offsets towards whole pixels by a fifth of a pixel).

use crate::frame::Frame;

/// Pixels each side of a patch's centre.
pub const HALF: u16 = 3;
/// Pixels across a patch.
const SIDE: usize = 2 * HALF as usize + 1;
/// Pixels in a patch.
const AREA: usize = SIDE * SIDE;
/// Steps the search may take from its start: each moves to the best of the 3x3 pixels around.
pub const MAX_STEPS: u16 = 4;
/// Pixels across the window a step reads: the patch and a pixel around it.
const WINDOW: usize = SIDE + 2;
/// Pixels of margin a search needs inside the frame: the patch, a pixel, and its steps.
pub const MARGIN: u16 = HALF + 1 + MAX_STEPS;

/// A corner's patch, row by row.
pub type Patch = [u8; AREA];

/// The patch of `frame` centred on pixel (`u`, `v`); black beyond a short row's end. The centre
/// must be at least [`HALF`] inside the frame.
pub fn read<F: Frame + ?Sized>(frame: &F, u: u16, v: u16) -> Patch {
    let mut p = [0u8; AREA];
    for (dy, out) in p.chunks_exact_mut(SIDE).enumerate() {
        let row = frame.row(v - HALF + dy as u16);
        let from = usize::from(u - HALF);
        let src = row.get(from..).unwrap_or_default();
        let n = src.len().min(SIDE);
        out[..n].copy_from_slice(&src[..n]);
    }
    p
}

/// Where a patch was found: its centre, pixels (fractional), and how unlike it was there (the
/// root mean square difference of the zero-mean grey levels, at the fractional place).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    /// Column, pixels.
    pub u_px: f32,
    /// Row, pixels.
    pub v_px: f32,
    /// Root mean square difference after removing each patch's mean, grey levels.
    pub unlikeness: f32,
}

/// Searches `frame` for `patch` from pixel (`u`, `v`): at the 3x3 pixels around, moving to
/// the best until the centre is best (at most [`MAX_STEPS`] moves), then to a fraction of a
/// pixel. `None` where it does not settle, or would leave the frame's [`MARGIN`].
pub fn find<F: Frame + ?Sized>(frame: &F, patch: &Patch, u: u16, v: u16) -> Option<Found> {
    let (w, h) = (frame.width(), frame.height());
    let (mut cu, mut cv) = (u, v);
    // The costs already known around the centre: a step keeps the six (or four) it shares.
    let mut known = [None; 9];
    for _ in 0..=MAX_STEPS {
        let inside = |x: u16, n: u16| x > HALF && x + HALF + 1 < n;
        if !(inside(cu, w) && inside(cv, h)) {
            return None;
        }
        let cost = costs(frame, patch, cu, cv, known);
        let (mut best, mut at) = (cost[4], 4);
        for (k, &c) in cost.iter().enumerate() {
            if c < best {
                (best, at) = (c, k);
            }
        }
        if at == 4 {
            let (du, dv, _) = quadric_minimum(cost.map(|c| c as f32));
            return refine(frame, patch, f32::from(cu) + du, f32::from(cv) + dv);
        }
        let (dx, dy) = (at % 3, at / 3);
        known = core::array::from_fn(|k| {
            let (x, y) = ((k % 3 + dx).checked_sub(1)?, (k / 3 + dy).checked_sub(1)?);
            (x < 3 && y < 3)
                .then(|| cost.get(3 * y + x).copied())
                .flatten()
        });
        cu = (cu + dx as u16).checked_sub(1)?;
        cv = (cv + dy as u16).checked_sub(1)?;
    }
    None
}

/// Pixels across the patch's interior, where its gradients are known.
const INNER: usize = SIDE - 2;

/// Lucas-Kanade steps that refine a place found to the nearest pixel and a quadric.
const LK_STEPS: usize = 3;
/// A step this small, pixels, ends the refinement.
const LK_SETTLED_PX: f32 = 0.01;

/// The patch's place refined from (`u`, `v`) by Lucas-Kanade (inverse compositional, its
/// 5x5 interior, the frame sampled bilinearly, each side's mean removed), and how unlike it is
/// there. A quadric through whole-pixel costs pulls a place towards the nearest whole pixel by
/// a few hundredths of a pixel; in a steady turn every far point moves alike, and those
/// hundredths turn into a heading. `None` where it strays a pixel from the start.
fn refine<F: Frame + ?Sized>(frame: &F, patch: &Patch, u: f32, v: f32) -> Option<Found> {
    let t = |x: usize, y: usize| f32::from(patch[y * SIDE + x]);
    // The template's interior, its gradients and their normal matrix.
    let mut tmpl = [0.0f32; INNER * INNER];
    let mut grad = [(0.0f32, 0.0f32); INNER * INNER];
    let (mut hxx, mut hxy, mut hyy) = (0.0f32, 0.0f32, 0.0f32);
    for y in 0..INNER {
        for x in 0..INNER {
            let k = y * INNER + x;
            tmpl[k] = t(x + 1, y + 1);
            let g = (
                0.5 * (t(x + 2, y + 1) - t(x, y + 1)),
                0.5 * (t(x + 1, y + 2) - t(x + 1, y)),
            );
            grad[k] = g;
            hxx += g.0 * g.0;
            hxy += g.0 * g.1;
            hyy += g.1 * g.1;
        }
    }
    let det = hxx * hyy - hxy * hxy;
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    let tmpl_mean = tmpl.iter().sum::<f32>() / (INNER * INNER) as f32;
    let (mut pu, mut pv) = (u, v);
    let mut unlikeness = f32::MAX;
    for step in 0..=LK_STEPS {
        let sampled = sample(frame, pu, pv)?;
        let mean = sampled.iter().sum::<f32>() / (INNER * INNER) as f32;
        let (mut bx, mut by, mut sq) = (0.0f32, 0.0f32, 0.0f32);
        for ((&i, &tv), &(gx, gy)) in sampled.iter().zip(&tmpl).zip(&grad) {
            let e = (i - mean) - (tv - tmpl_mean);
            bx += gx * e;
            by += gy * e;
            sq += e * e;
        }
        unlikeness = libm::sqrtf(sq / (INNER * INNER) as f32);
        if step == LK_STEPS {
            break;
        }
        let du = (hyy * bx - hxy * by) / det;
        let dv = (hxx * by - hxy * bx) / det;
        pu -= du;
        pv -= dv;
        if (pu - u).abs() > 1.0 || (pv - v).abs() > 1.0 {
            return None;
        }
        if du.abs() < LK_SETTLED_PX && dv.abs() < LK_SETTLED_PX {
            let sampled = sample(frame, pu, pv)?;
            let mean = sampled.iter().sum::<f32>() / (INNER * INNER) as f32;
            let sq: f32 = sampled
                .iter()
                .zip(&tmpl)
                .map(|(&i, &tv)| {
                    let e = (i - mean) - (tv - tmpl_mean);
                    e * e
                })
                .sum();
            unlikeness = libm::sqrtf(sq / (INNER * INNER) as f32);
            break;
        }
    }
    Some(Found {
        u_px: pu,
        v_px: pv,
        unlikeness,
    })
}

/// The frame sampled bilinearly on the `INNER x INNER` pixels centred on (`u`, `v`), row by
/// row; `None` where they reach past the frame.
fn sample<F: Frame + ?Sized>(frame: &F, u: f32, v: f32) -> Option<[f32; INNER * INNER]> {
    const N: usize = INNER;
    let half = (N / 2) as f32;
    let (x0, y0) = (u - half, v - half);
    if !(x0 >= 0.0 && y0 >= 0.0) {
        return None;
    }
    let (ix, iy) = (libm::floorf(x0), libm::floorf(y0));
    let (fx, fy) = (x0 - ix, y0 - iy);
    let (ix, iy) = (ix as usize, iy as usize);
    if iy + N + 1 > usize::from(frame.height()) || ix + N + 1 > usize::from(frame.width()) {
        return None;
    }
    // The N + 1 pixels of a row the samples read; black where a row is short.
    let span = |y: usize| {
        let row = frame.row(y as u16);
        let mut px = [0.0f32; N + 1];
        for (p, &b) in px.iter_mut().zip(row.get(ix..).unwrap_or_default()) {
            *p = f32::from(b);
        }
        px
    };
    let mut out = [0.0f32; N * N];
    let mut above = span(iy);
    for (y, row_out) in out.chunks_exact_mut(N).enumerate() {
        let below = span(iy + y + 1);
        let (a, b) = (above.windows(2), below.windows(2));
        for ((o, a), b) in row_out.iter_mut().zip(a).zip(b) {
            let (&[a0, a1], &[b0, b1]) = (a, b) else {
                continue;
            };
            let top = a0 + fx * (a1 - a0);
            let bottom = b0 + fx * (b1 - b0);
            *o = top + fy * (bottom - top);
        }
        above = below;
    }
    Some(out)
}

/// The costs of `patch` at the 3x3 pixels around (`u`, `v`), row by row: `AREA` times the
/// zero-mean sum of squared differences, `AREA sum (a - b)^2 - (sum (a - b))^2` (under 2^36);
/// those `known` are taken as they are. The centre must be at least `HALF + 1` inside the frame.
fn costs<F: Frame + ?Sized>(
    frame: &F,
    patch: &Patch,
    u: u16,
    v: u16,
    known: [Option<i64>; 9],
) -> [i64; 9] {
    let edge = HALF + 1;
    let mut window = [[0u8; WINDOW]; WINDOW];
    for (dy, out) in window.iter_mut().enumerate() {
        let row = frame.row(v - edge + dy as u16);
        let src = row.get(usize::from(u - edge)..).unwrap_or_default();
        let n = src.len().min(WINDOW);
        out[..n].copy_from_slice(&src[..n]);
    }
    core::array::from_fn(|k| {
        if let Some(Some(c)) = known.get(k) {
            return *c;
        }
        let (ox, oy) = (k % 3, k / 3);
        let (mut sum_d, mut sum_sq) = (0i32, 0i32);
        for (p_row, w_row) in patch.chunks_exact(SIDE).zip(&window[oy..oy + SIDE]) {
            for (&a, &b) in p_row.iter().zip(&w_row[ox..ox + SIDE]) {
                let d = i32::from(a) - i32::from(b);
                sum_d += d;
                sum_sq += d * d;
            }
        }
        AREA as i64 * i64::from(sum_sq) - i64::from(sum_d) * i64::from(sum_d)
    })
}

/// The offset of the minimum of the quadric through the 3x3 costs `c` (row by row, the centre
/// the least), each axis in [-0.5, 0.5], and the cost there. Fitted in both axes at once: a
/// pattern whose gradients lean makes the costs' valley lean too, and a parabola along each axis
/// alone would miss its floor (by a tenth of a pixel and more, measured on the test's pattern).
/// The cost at the floor, not at the nearest whole pixel, says how alike the patches are: half
/// a pixel off, a strong edge differs by half its gradient.
fn quadric_minimum(c: [f32; 9]) -> (f32, f32, f32) {
    let at = |dx: usize, dy: usize| c[3 * dy + dx];
    let centre = at(1, 1);
    let cxx = at(2, 1) + at(0, 1) - 2.0 * centre;
    let cyy = at(1, 2) + at(1, 0) - 2.0 * centre;
    let cxy = 0.25 * (at(2, 2) - at(2, 0) - at(0, 2) + at(0, 0));
    let gx = 0.5 * (at(2, 1) - at(0, 1));
    let gy = 0.5 * (at(1, 2) - at(1, 0));
    // Minimum of gx x + gy y + (cxx x^2 + 2 cxy x y + cyy y^2) / 2.
    let det = cxx * cyy - cxy * cxy;
    if !(cxx > 0.0 && det > 0.0) {
        return (0.0, 0.0, centre);
    }
    let x = ((-gx * cyy + gy * cxy) / det).clamp(-0.5, 0.5);
    let y = ((-gy * cxx + gx * cxy) / det).clamp(-0.5, 0.5);
    let floor = centre + gx * x + gy * y + 0.5 * (cxx * x * x + 2.0 * cxy * x * y + cyy * y * y);
    (x, y, floor)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::frame::SliceFrame;
    use std::vec::Vec;

    /// A smooth blob pattern shifted by (`du`, `dv`) pixels, sampled on a `w x h` grid.
    pub(crate) fn blobs(w: usize, h: usize, du: f32, dv: f32, gain: f32) -> Vec<u8> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - du, (i / w) as f32 - dv);
                let s = libm::sinf(0.45 * x) * libm::cosf(0.37 * y)
                    + 0.5 * libm::sinf(0.23 * x + 0.31 * y);
                (100.0 + gain * 50.0 * s) as u8
            })
            .collect()
    }

    #[test]
    fn a_shifted_patch_is_found_to_a_tenth_of_a_pixel_whatever_the_exposure() {
        let (w, h) = (40usize, 40usize);
        let before = blobs(w, h, 0.0, 0.0, 1.0);
        let f0 = SliceFrame::new(&before, w as u16, h as u16, w).unwrap();
        let patch = read(&f0, 20, 20);
        for (du, dv) in [(0.3f32, -0.4f32), (1.2, 0.7), (-1.4, -1.1), (1.0, -1.0)] {
            let after: Vec<u8> = blobs(w, h, du, dv, 1.0)
                .iter()
                .map(|&p| p.saturating_add(12))
                .collect();
            let f1 = SliceFrame::new(&after, w as u16, h as u16, w).unwrap();
            let found = find(&f1, &patch, 20, 20).unwrap();
            assert!(
                (found.u_px - 20.0 - du).abs() < 0.12,
                "{du} {dv}: {found:?}"
            );
            assert!(
                (found.v_px - 20.0 - dv).abs() < 0.12,
                "{du} {dv}: {found:?}"
            );
            // A whole pixel's shift finds the patch itself, but for the exposure; a fraction of
            // one leaves the difference of two samplings of the pattern.
            let limit = if du.fract() == 0.0 { 1.0 } else { 3.0 };
            assert!(found.unlikeness < limit, "{found:?}");
        }
        // Twelve pixels away, beyond the search's steps: not found, or found only where the
        // pattern is unlike it.
        let far = blobs(w, h, 12.0, 0.0, 1.0);
        let f2 = SliceFrame::new(&far, w as u16, h as u16, w).unwrap();
        let found = find(&f2, &patch, 20, 20);
        assert!(found.is_none_or(|f| f.unlikeness > 5.0), "{found:?}");
    }
}
