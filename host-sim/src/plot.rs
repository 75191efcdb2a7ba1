//! Plots: the top view of ground truth and estimate, and the error per segment length. PNG or
//! SVG by the file's extension; the font is compiled in, so no system fonts are needed.

use crate::eval::{LengthRow, Report};
use crate::kitti::Pose;
use anyhow::{Context, Result, anyhow, bail};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// Registers the compiled-in font once, for every plot and picture with text.
pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is a valid TTF compiled into the binary; failure would show as missing text.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// A named trajectory to draw.
pub struct Track<'a> {
    /// Legend label.
    pub label: &'a str,
    /// KITTI camera poses.
    pub poses: &'a [Pose],
}

/// Top view of camera poses: (x right, z forward) of camera 0 at the first frame.
fn top_view(p: &Pose) -> (f64, f64) {
    (p[3], p[11])
}

/// The formats a plot is written in, by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Svg,
}

/// The format of a plot at `out`, from its extension: an error for any other than .png and
/// .svg, to be checked before any work.
pub fn check_format(out: &Path) -> Result<()> {
    format_of(out).map(|_| ())
}

fn format_of(out: &Path) -> Result<Format> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png") => Ok(Format::Png),
        Some("svg") => Ok(Format::Svg),
        _ => bail!("{}: plots are written as .png or .svg", out.display()),
    }
}

/// The farthest a plotted position may be from the origin, metres: a road drive's top view
/// spans kilometres, and beyond this the axes would take the plotting library forever.
pub const MAX_COORDINATE_M: f64 = 1e7;

/// Refuses tracks with positions that are not finite or lie beyond [`MAX_COORDINATE_M`].
fn check_coordinates(tracks: &[Track]) -> Result<()> {
    for t in tracks {
        for (i, p) in t.poses.iter().enumerate() {
            let (x, z) = top_view(p);
            if !(x.abs() <= MAX_COORDINATE_M && z.abs() <= MAX_COORDINATE_M) {
                bail!(
                    "cannot plot the {}: pose {} is at ({x:e}, {z:e}) m, beyond +-{MAX_COORDINATE_M:e} m",
                    t.label,
                    i + 1
                );
            }
        }
    }
    Ok(())
}

/// Draws the top view of `tracks` (the first is ground truth) and, with a report, the error
/// per segment length, into `out` (.png or .svg), whole or not at all.
pub fn plot_trajectories(
    out: &Path,
    title: &str,
    tracks: &[Track],
    report: Option<&Report>,
) -> Result<()> {
    register_font();
    let format = format_of(out)?;
    check_coordinates(tracks)?;
    let size = (1400u32, 700u32);
    let failed = || format!("cannot write {}", out.display());
    crate::output::write_atomic_with(out, |temp| {
        match format {
            Format::Png => {
                let root = BitMapBackend::new(temp, size).into_drawing_area();
                draw(&root, title, tracks, report)?;
                root.present().with_context(failed)?;
            }
            Format::Svg => {
                let root = SVGBackend::new(temp, size).into_drawing_area();
                draw(&root, title, tracks, report)?;
                root.present().with_context(failed)?;
            }
        }
        Ok(())
    })
}

const COLOURS: [RGBColor; 4] = [
    BLACK,
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
];

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    tracks: &[Track],
    report: Option<&Report>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plotting failed: {e:?}");
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 24)).map_err(err)?;
    let (left, right) = root.split_horizontally(700);

    // Equal scales on both axes: a square box around all points.
    let pts: Vec<(f64, f64)> = tracks
        .iter()
        .flat_map(|t| t.poses.iter().map(top_view))
        .collect();
    let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
    for &(x, z) in &pts {
        lo = (lo.0.min(x), lo.1.min(z));
        hi = (hi.0.max(x), hi.1.max(z));
    }
    let span = (hi.0 - lo.0).max(hi.1 - lo.1).max(1.0) * 1.08;
    let centre = (0.5 * (lo.0 + hi.0), 0.5 * (lo.1 + hi.1));
    let mut chart = ChartBuilder::on(&left)
        .caption("top view (camera 0 at the first frame)", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(
            (centre.0 - 0.5 * span)..(centre.0 + 0.5 * span),
            (centre.1 - 0.5 * span)..(centre.1 + 0.5 * span),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("x (m, right)")
        .y_desc("z (m, forward)")
        .draw()
        .map_err(err)?;
    for (i, t) in tracks.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(
                t.poses.iter().map(top_view),
                colour.stroke_width(2),
            ))
            .map_err(err)?
            .label(t.label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2)));
        if let Some(first) = t.poses.first() {
            chart
                .draw_series(std::iter::once(Circle::new(
                    top_view(first),
                    4,
                    colour.filled(),
                )))
                .map_err(err)?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;

    if let Some(r) = report {
        let (rows, what): (&[LengthRow], &str) = if r.per_length.is_empty() {
            (
                &r.short_per_length,
                "short segments, 10..50 m (not a KITTI figure)",
            )
        } else {
            (&r.per_length, "KITTI segments, 100..800 m")
        };
        let max_t = rows.iter().map(|row| row.t_err_pct).fold(0.1, f64::max) * 1.15;
        let max_len = rows.iter().map(|row| row.length_m).fold(1.0, f64::max);
        let mut bars = ChartBuilder::on(&right)
            .caption(
                format!("translation error per length: {what}"),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(0.0..max_len * 1.1, 0.0..max_t)
            .map_err(err)?;
        bars.configure_mesh()
            .x_desc("segment length (m)")
            .y_desc("translation error (%)")
            .draw()
            .map_err(err)?;
        bars.draw_series(LineSeries::new(
            rows.iter().map(|row| (row.length_m, row.t_err_pct)),
            COLOURS[1].stroke_width(2),
        ))
        .map_err(err)?;
        bars.draw_series(
            rows.iter()
                .map(|row| Circle::new((row.length_m, row.t_err_pct), 5, COLOURS[1].filled())),
        )
        .map_err(err)?;
    }
    Ok(())
}
