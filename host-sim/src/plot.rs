//! Plots: one figure of a drive's estimates against the ground truth. On the left the top view
//! (the ground truth drawn last, dashed black, so it stays visible under the estimates); on the
//! right the KITTI translation and rotation errors per segment length and the APE over the
//! distance travelled; below, given a quality file, the tracks matched, the inlier ratio and
//! the fallbacks over the drive. PNG or SVG by the file's extension; the font is compiled in, so
//! no system fonts are needed.

use crate::eval::{LengthRow, Report};
use crate::kitti::Pose;
use crate::quality::QualitySample;
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
fn top_view_of(p: &Pose) -> (f64, f64) {
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
            let (x, z) = top_view_of(p);
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

/// An estimate to draw and what was measured of it.
pub struct Scored<'a> {
    /// Legend label.
    pub label: &'a str,
    /// Camera poses in the ground truth's world frame (aligned, if an alignment was made).
    pub poses: &'a [Pose],
    /// Its KITTI metric against the ground truth.
    pub report: Option<&'a Report>,
    /// Its APE at each pose, metres, paired with the ground truth's poses.
    pub ape_m: Option<&'a [f64]>,
}

/// Everything one figure shows.
pub struct Figure<'a> {
    /// The figure's title.
    pub title: &'a str,
    /// The ground truth's camera poses, paired pose by pose with each estimate's.
    pub ground_truth: Option<&'a [Pose]>,
    /// The estimates.
    pub estimates: &'a [Scored<'a>],
    /// The odometer's quality over the drive (`roadvo run --quality`).
    pub quality: Option<&'a [QualitySample]>,
}

/// Draws the top view of `tracks` and, with a report, the errors per segment length, into `out`
/// (.png or .svg): with a report, the first track is the ground truth and the report the
/// second's.
pub fn plot_trajectories(
    out: &Path,
    title: &str,
    tracks: &[Track],
    report: Option<&Report>,
) -> Result<()> {
    let (ground_truth, rest) = match (report, tracks) {
        (Some(_), [gt, rest @ ..]) => (Some(gt.poses), rest),
        _ => (None, tracks),
    };
    let estimates: Vec<Scored> = rest
        .iter()
        .enumerate()
        .map(|(i, t)| Scored {
            label: t.label,
            poses: t.poses,
            report: report.filter(|_| i == 0),
            ape_m: None,
        })
        .collect();
    plot_figure(
        out,
        &Figure {
            title,
            ground_truth,
            estimates: &estimates,
            quality: None,
        },
    )
}

/// Draws `figure` into `out` (.png or .svg), whole or not at all.
pub fn plot_figure(out: &Path, figure: &Figure) -> Result<()> {
    register_font();
    let format = format_of(out)?;
    let mut tracks: Vec<Track> = figure
        .estimates
        .iter()
        .map(|e| Track {
            label: e.label,
            poses: e.poses,
        })
        .collect();
    tracks.extend(figure.ground_truth.map(|poses| Track {
        label: "ground truth",
        poses,
    }));
    check_coordinates(&tracks)?;
    let errors = figure.estimates.iter().any(|e| e.report.is_some());
    let size = match (errors, figure.quality.is_some()) {
        (false, false) => (900, 900),
        (false, true) => (900, 1250),
        (true, false) => (1600, 950),
        (true, true) => (1600, 1300),
    };
    let failed = || format!("cannot write {}", out.display());
    crate::output::write_atomic_with(out, |temp| {
        match format {
            Format::Png => {
                let root = BitMapBackend::new(temp, size).into_drawing_area();
                draw(&root, figure)?;
                root.present().with_context(failed)?;
            }
            Format::Svg => {
                let root = SVGBackend::new(temp, size).into_drawing_area();
                draw(&root, figure)?;
                root.present().with_context(failed)?;
            }
        }
        Ok(())
    })
}

/// The estimates' colours, in order; the ground truth is black.
const COLOURS: [RGBColor; 4] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

/// The colour of estimate `i`.
fn colour(i: usize) -> RGBColor {
    COLOURS[i % COLOURS.len()]
}

/// A plotting error as an `anyhow` one.
fn plotting<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e:?}")
}

/// A named line of (x, y) points in a colour.
struct Line {
    label: String,
    colour: RGBColor,
    points: Vec<(f64, f64)>,
}

/// Draws `lines` (with a marker at each point if `markers`) in a chart on `area` with a legend.
fn line_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    (x_desc, y_desc): (&str, &str),
    lines: &[Line],
    markers: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let pts = || lines.iter().flat_map(|l| l.points.iter());
    let x_max = pts().map(|p| p.0).fold(1e-9, f64::max);
    // An all-zero series (no fallbacks) still gets an axis up to 1.
    let y_max = match pts().map(|p| p.1).fold(0.0, f64::max) {
        // Headroom for the legend above the lines.
        y if y > 0.0 => y * 1.4,
        _ => 1.0,
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x_max * 1.05, 0.0..y_max)
        .map_err(plotting)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()
        .map_err(plotting)?;
    for l in lines {
        let c = l.colour;
        chart
            .draw_series(LineSeries::new(l.points.iter().copied(), c.stroke_width(2)))
            .map_err(plotting)?
            .label(l.label.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
        if markers {
            chart
                .draw_series(l.points.iter().map(|&p| Circle::new(p, 4, c.filled())))
                .map_err(plotting)?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(plotting)?;
    Ok(())
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, figure: &Figure) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(plotting)?;
    let root = root
        .titled(figure.title, ("sans-serif", 24))
        .map_err(plotting)?;
    let (main, below) = match figure.quality {
        Some(_) => {
            let (w, h) = root.dim_in_pixel();
            let (a, b) = root.split_vertically(h.saturating_sub(330).max(w / 3));
            (a, Some(b))
        }
        None => (root.clone(), None),
    };
    let scored: Vec<&Scored> = figure
        .estimates
        .iter()
        .filter(|e| e.report.is_some())
        .collect();
    if scored.is_empty() {
        top_view(&main, figure)?;
    } else {
        let (left, right) = main.split_horizontally(main.dim_in_pixel().1.min(800));
        top_view(&left, figure)?;
        error_panels(&right, figure)?;
    }
    if let (Some(area), Some(q)) = (below, figure.quality) {
        quality_panels(&area, q)?;
    }
    Ok(())
}

/// The top view, equal scales on both axes; the ground truth last, dashed.
fn top_view<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, figure: &Figure) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let all = || {
        figure
            .estimates
            .iter()
            .map(|e| e.poses)
            .chain(figure.ground_truth)
            .flat_map(|p| p.iter().map(top_view_of))
    };
    let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
    for (x, z) in all() {
        lo = (lo.0.min(x), lo.1.min(z));
        hi = (hi.0.max(x), hi.1.max(z));
    }
    let span = (hi.0 - lo.0).max(hi.1 - lo.1).max(1.0) * 1.08;
    let centre = (0.5 * (lo.0 + hi.0), 0.5 * (lo.1 + hi.1));
    let mut chart = ChartBuilder::on(area)
        .caption(
            "top view (camera 0's frame at the first frame)",
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(
            (centre.0 - 0.5 * span)..(centre.0 + 0.5 * span),
            (centre.1 - 0.5 * span)..(centre.1 + 0.5 * span),
        )
        .map_err(plotting)?;
    chart
        .configure_mesh()
        .x_desc("x (m, right)")
        .y_desc("z (m, forward)")
        .draw()
        .map_err(plotting)?;
    for (i, e) in figure.estimates.iter().enumerate() {
        let c = colour(i);
        chart
            .draw_series(LineSeries::new(
                e.poses.iter().map(top_view_of),
                c.stroke_width(2),
            ))
            .map_err(plotting)?
            .label(e.label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    if let Some(gt) = figure.ground_truth {
        chart
            .draw_series(DashedLineSeries::new(
                gt.iter().map(top_view_of),
                8,
                5,
                BLACK.stroke_width(2),
            ))
            .map_err(plotting)?
            .label("ground truth")
            .legend(|(x, y)| {
                PathElement::new(
                    [(x, y), (x + 8, y), (x + 13, y), (x + 20, y)],
                    BLACK.stroke_width(2),
                )
            });
    }
    let starts = figure
        .estimates
        .iter()
        .map(|e| e.poses)
        .chain(figure.ground_truth);
    chart
        .draw_series(
            starts
                .filter_map(|p| p.first())
                .map(|p| Circle::new(top_view_of(p), 5, BLACK.filled())),
        )
        .map_err(plotting)?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(plotting)?;
    Ok(())
}

/// Translation and rotation errors per segment length and, where there is one, the APE over
/// the distance travelled, stacked.
fn error_panels<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, figure: &Figure) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let reports: Vec<(usize, &Scored, &Report)> = figure
        .estimates
        .iter()
        .enumerate()
        .filter_map(|(i, e)| e.report.map(|r| (i, e, r)))
        .collect();
    // KITTI lengths where an estimate has two or more of them, the short ones otherwise.
    let kitti = reports.iter().any(|(_, _, r)| r.per_length.len() >= 2);
    let (rows_of, what): (fn(&Report) -> &[LengthRow], &str) = if kitti {
        (|r| &r.per_length, "KITTI segments, 100..800 m")
    } else {
        (
            |r| &r.short_per_length,
            "short segments, 10..50 m (not a KITTI figure)",
        )
    };
    let per_length = |value: fn(&LengthRow) -> f64| -> Vec<Line> {
        reports
            .iter()
            .map(|&(i, e, r)| Line {
                label: e.label.to_string(),
                colour: colour(i),
                points: rows_of(r)
                    .iter()
                    .map(|row| (row.length_m, value(row)))
                    .collect(),
            })
            .collect()
    };
    let ape: Vec<Line> = match figure.ground_truth {
        Some(gt) => {
            let dist = crate::ape::distances_m(gt);
            figure
                .estimates
                .iter()
                .enumerate()
                .filter_map(|(i, e)| {
                    e.ape_m.map(|errors| Line {
                        label: e.label.to_string(),
                        colour: colour(i),
                        points: dist.iter().copied().zip(errors.iter().copied()).collect(),
                    })
                })
                .collect()
        }
        None => Vec::new(),
    };
    let panels = area.split_evenly((if ape.is_empty() { 2 } else { 3 }, 1));
    line_chart(
        &panels[0],
        &format!("translation error per length: {what}"),
        ("segment length (m)", "translation error (%)"),
        &per_length(|row| row.t_err_pct),
        true,
    )?;
    line_chart(
        &panels[1],
        &format!("rotation error per length: {what}"),
        ("segment length (m)", "rotation error (deg/m)"),
        &per_length(|row| row.r_err_deg_per_m),
        true,
    )?;
    if let Some(p) = panels.get(2) {
        line_chart(
            p,
            "APE (translation) over the distance travelled",
            ("distance travelled (m, ground truth)", "APE (m)"),
            &ape,
            false,
        )?;
    }
    Ok(())
}

/// Tracks matched, inlier ratio and fallbacks (cumulative) over the frames, side by side.
fn quality_panels<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    q: &[QualitySample],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let panels = area.split_evenly((1, 3));
    let line = |label: &str, points: Vec<(f64, f64)>| {
        [Line {
            label: label.to_string(),
            colour: colour(0),
            points,
        }]
    };
    let frame = |s: &QualitySample| s.frame as f64;
    line_chart(
        &panels[0],
        "tracks matched",
        ("frame", "tracks"),
        &line(
            "tracks matched",
            q.iter()
                .map(|s| (frame(s), f64::from(s.tracks_matched)))
                .collect(),
        ),
        false,
    )?;
    line_chart(
        &panels[1],
        "inlier ratio",
        ("frame", "inliers / matched"),
        &line(
            "inlier ratio",
            q.iter()
                .map(|s| (frame(s), f64::from(s.inlier_ratio)))
                .collect(),
        ),
        false,
    )?;
    let mut fallbacks = 0.0;
    let cumulative = q
        .iter()
        .map(|s| {
            fallbacks += f64::from(u8::from(s.fallback));
            (frame(s), fallbacks)
        })
        .collect();
    line_chart(
        &panels[2],
        "fallbacks (to the previous motion), cumulative",
        ("frame", "fallbacks so far"),
        &line("fallbacks", cumulative),
        false,
    )
}
