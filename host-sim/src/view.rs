//! What the odometer sees, frame by frame, as pictures: the frame with the ground window, the
//! rows the odometer reads and its tracked ground features coloured by their fate (matched in
//! this frame, started in it, carried along unmatched), each matched one with a line to where
//! the frame's estimated motion says it was in the previous frame; beside it a bird's-eye view
//! of the ground window with the same tracks, and the frame's motion and quality.

use crate::plot::register_font;
use crate::run::{BadFrames, FrameSource, Ran, run_frames_inspected};
use anyhow::{Context, Result};
use image::{GrayImage, RgbImage};
use plotters::prelude::*;
use roadvo::tracks::Track;
use roadvo::{Estimate, GroundPoint, Odometer, Pixel, ValidConfig};
use std::path::{Path, PathBuf};

/// Width of the panel beside the frame: the bird's-eye view and the figures, pixels.
const PANEL_PX: u32 = 320;

/// A track matched in this frame.
const MATCHED: RGBColor = RGBColor(44, 200, 44);
/// A track started in this frame.
const NEW: RGBColor = RGBColor(255, 200, 0);
/// A track carried along by the motion, not seen in this frame.
const CARRIED: RGBColor = RGBColor(230, 40, 40);
/// The ground window and the rows read.
const WINDOW: RGBColor = RGBColor(60, 160, 255);

/// What happened to a track in the last frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fate {
    /// Seen again: matched to a corner of this frame.
    Matched,
    /// Started from a corner of this frame that no track took.
    New,
    /// Not seen: carried along by the estimated motion.
    Carried,
}

impl Fate {
    /// The fate of `t` after the frame.
    pub fn of(t: &Track) -> Self {
        match (t.age, t.misses) {
            (0, _) => Self::New,
            (_, 0) => Self::Matched,
            _ => Self::Carried,
        }
    }

    fn colour(self) -> RGBColor {
        match self {
            Self::Matched => MATCHED,
            Self::New => NEW,
            Self::Carried => CARRIED,
        }
    }
}

/// Runs the odometer over `source` and writes one picture a frame into `out` (`NNNNNN.png`,
/// the frame's number), every `every`-th frame; `progress` hears of each frame run. Returns
/// the pictures written and how the run ended.
pub fn write_views(
    source: &impl FrameSource,
    config: ValidConfig,
    out: &Path,
    every: usize,
    mut progress: impl FnMut(),
) -> Result<(Vec<PathBuf>, Ran)> {
    register_font();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut written = Vec::new();
    let ran = run_frames_inspected(source, config, BadFrames::Stop, |i, est, _, _, odo| {
        if i % every.max(1) == 0 {
            let (frame, _) = source.frame(i)?;
            let path = out.join(format!("{i:06}.png"));
            let picture = view(&frame, &est, odo, i)?;
            crate::output::write_atomic_with(&path, |temp| {
                picture
                    .save(temp)
                    .with_context(|| format!("cannot write {}", path.display()))
            })?;
            written.push(path);
        }
        progress();
        Ok(())
    })?;
    Ok((written, ran))
}

/// One frame's picture: the frame with its overlays, the panel to its right.
pub fn view(frame: &GrayImage, est: &Estimate, odo: &Odometer, index: usize) -> Result<RgbImage> {
    let (w, h) = frame.dimensions();
    let height = h.max(PANEL_PX + 120);
    let mut rgb = vec![0u8; (3 * (w + PANEL_PX) * height) as usize];
    for (x, y, p) in frame.enumerate_pixels() {
        let k = 3 * (y * (w + PANEL_PX) + x) as usize;
        rgb[k..k + 3].copy_from_slice(&[p.0[0]; 3]);
    }
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w + PANEL_PX, height)).into_drawing_area();
        let (image, panel) = root.split_horizontally(w);
        draw_frame(&image, est, odo).map_err(plot_error)?;
        draw_panel(&panel, est, odo, index).map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    RgbImage::from_raw(w + PANEL_PX, height, rgb).context("picture buffer")
}

fn plot_error<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing a view: {e:?}")
}

type Area<DB> = DrawingArea<DB, plotters::coord::Shift>;
type DrawResult<DB> =
    std::result::Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// The ground window's outline on the road (vehicle frame), `n` points a side.
fn window_outline(config: &ValidConfig, n: usize) -> Vec<GroundPoint> {
    let s = config.settings();
    let (near, far, half) = (s.window_near_m, s.window_far_m, s.window_half_width_m);
    let along = |k: usize| near + (far - near) * k as f32 / n as f32;
    let across = |k: usize| -half + 2.0 * half * k as f32 / n as f32;
    let mut outline: Vec<(f32, f32)> = (0..=n).map(|k| (along(k), half)).collect();
    outline.extend((0..=n).map(|k| (far, -across(k))));
    outline.extend((0..=n).rev().map(|k| (along(k), -half)));
    outline.extend((0..=n).map(|k| (near, across(k))));
    outline
        .into_iter()
        .map(|(ahead, left)| config.window_point(ahead, left))
        .collect()
}

fn px(p: Pixel) -> (i32, i32) {
    (p.u_px.round() as i32, p.v_px.round() as i32)
}

fn draw_frame<DB: DrawingBackend>(
    area: &Area<DB>,
    est: &Estimate,
    odo: &Odometer,
) -> DrawResult<DB> {
    let config = odo.config();
    let nominal = &config.projection().nominal;
    let (w, _) = area.dim_in_pixel();
    let rows = config.rows_read();
    for row in [rows.start, rows.end.saturating_sub(1)] {
        let y = i32::from(row);
        area.draw(&PathElement::new([(0, y), (w as i32, y)], WINDOW.mix(0.5)))?;
    }
    let outline: Vec<(i32, i32)> = window_outline(config, 16)
        .into_iter()
        .filter_map(|g| nominal.project(g).map(px))
        .collect();
    area.draw(&PathElement::new(outline, WINDOW.stroke_width(2)))?;
    let back = est.motion.end_pose();
    for t in odo.tracks() {
        let fate = Fate::of(t);
        let Some(at) = t.pixel.or_else(|| nominal.project(t.ground)) else {
            continue;
        };
        let (u, v) = px(at);
        if fate == Fate::Matched
            && let Some(before) = nominal.project(back.transform_point(t.ground))
        {
            area.draw(&PathElement::new([(u, v), px(before)], MATCHED.mix(0.8)))?;
        }
        let style = match fate {
            Fate::Carried => fate.colour().stroke_width(1),
            _ => fate.colour().filled(),
        };
        area.draw(&Circle::new((u, v), 3, style))?;
    }
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(
    area: &Area<DB>,
    est: &Estimate,
    odo: &Odometer,
    index: usize,
) -> DrawResult<DB> {
    area.fill(&RGBColor(24, 24, 24))?;
    let config = odo.config();
    let s = config.settings();
    let (top, figures) = area.split_vertically(PANEL_PX);
    // Bird's-eye: ahead up, left to the left, the window filling the square.
    let span = (s.window_far_m - s.window_near_m).max(2.0 * s.window_half_width_m);
    let scale = (PANEL_PX - 20) as f32 / span;
    let centre = 0.5 * (s.window_near_m + s.window_far_m);
    let to_panel = |g: GroundPoint| {
        let (ahead, left) = config.window_coords(g);
        (
            (PANEL_PX as f32 / 2.0 - left * scale).round() as i32,
            (PANEL_PX as f32 / 2.0 - (ahead - centre) * scale).round() as i32,
        )
    };
    let outline: Vec<(i32, i32)> = window_outline(config, 1)
        .into_iter()
        .map(to_panel)
        .collect();
    top.draw(&PathElement::new(outline, WINDOW.stroke_width(2)))?;
    for t in odo.tracks() {
        let fate = Fate::of(t);
        top.draw(&Circle::new(to_panel(t.ground), 3, fate.colour().filled()))?;
    }
    let q = &est.quality;
    let lines = [
        format!("frame {index:06}"),
        format!(
            "distance {:.3} m, turn {:+.3} deg",
            est.motion.distance_m,
            est.motion.heading_change_rad.to_degrees()
        ),
        format!("tracks {} (matched {})", q.tracks, q.tracks_matched),
        format!(
            "inliers {:.0} %, comoving {}",
            100.0 * q.inlier_ratio,
            q.features_comoving
        ),
        format!(
            "image heading {} ({} inliers){}",
            if q.image_heading { "used" } else { "not used" },
            q.image_inliers,
            if q.fallback { ", FALLBACK" } else { "" }
        ),
        "green matched, yellow new, red carried".to_string(),
    ];
    let font = ("sans-serif", 15).into_font().color(&WHITE);
    for (k, line) in lines.iter().enumerate() {
        figures.draw(&Text::new(
            line.as_str(),
            (8, 8 + 18 * k as i32),
            font.clone(),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(age: u16, misses: u8) -> Track {
        Track {
            age,
            misses,
            ..Track::default()
        }
    }

    #[test]
    fn fates_follow_age_and_misses() {
        assert_eq!(Fate::of(&track(0, 0)), Fate::New);
        assert_eq!(Fate::of(&track(5, 0)), Fate::Matched);
        assert_eq!(Fate::of(&track(5, 2)), Fate::Carried);
    }
}
