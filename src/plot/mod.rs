//! Log–log line plots with axes, tick labels and a legend in the picture, drawn with the
//! `plotters` crate (bitmap backend) and the bundled DejaVu Sans Mono (`fonts/`, Bitstream Vera
//! licence in `fonts/LICENSE-DejaVu.txt`), so no system font is needed.
//!
//! Used by the cross-check sweeps ([`crate::crosscheck::sweep`]) and the skinsimp error plot
//! ([`crate::skinsimp::picture::draw_error_plot`]).

use std::sync::Once;

use plotters::prelude::*;

use crate::error::{Error, Result};
use crate::texture::{Image, Rgba8};

/// The bundled font (DejaVu Sans Mono 2.37).
const FONT: &[u8] = include_bytes!("fonts/DejaVuSansMono.ttf");
/// The family name the plots ask for; [`register_font`] maps it to [`FONT`].
const FAMILY: &str = "sans-serif";

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// A measured quantity: a solid line with square markers.
    Measured,
    /// A bound: a dashed line, no markers.
    Bound,
}

/// One line of a plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub label: String,
    /// (x, y) points in drawing order; only points with x, y > 0 are drawn (log axes).
    pub points: Vec<(f64, f64)>,
    pub colour: Rgba8,
    pub style: Style,
}

/// A log–log plot.
#[derive(Clone, Debug, PartialEq)]
pub struct LogLogPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Axis ranges; `None`: the points' extent, widened to whole decades.
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    /// Whether x is a category numbered 1, 2, …: a linear x axis with a tick per whole number
    /// (the arithmetic models of a sweep), instead of a logarithmic one.
    pub categorical_x: bool,
}

/// Distinct colours for measured series (tab10's first entries).
pub const PALETTE: [Rgba8; 6] = [
    [31, 119, 180, 255],
    [255, 127, 14, 255],
    [44, 160, 44, 255],
    [214, 39, 40, 255],
    [148, 103, 189, 255],
    [140, 86, 75, 255],
];

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled bytes are a valid TrueType font (a test renders with them).
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// The enclosing whole decades of the positive values (one decade when all are equal).
fn decades(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let positive: Vec<f64> = values.filter(|v| v.is_finite() && *v > 0.0).collect();
    let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = positive.iter().copied().fold(0.0, f64::max);
    if positive.is_empty() {
        return None;
    }
    let (a, b) = (lo.log10().floor(), hi.log10().ceil());
    Some((10f64.powf(a), 10f64.powf(if b > a { b } else { a + 1.0 })))
}

fn colour(c: Rgba8) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

fn draw_error<E: std::fmt::Debug>(e: E) -> Error {
    Error::InvalidArgument(format!("plot: drawing failed: {e:?}"))
}

/// Draw `plot` into a `width × height` picture: axes with tick labels on both log axes, a grid,
/// every series (measured: solid with markers; bounds: dashed), a legend in the upper left.
/// Errors: a size outside 120 × 90 ..= 4096², no positive point, a non-finite point.
pub fn draw(plot: &LogLogPlot, width: usize, height: usize) -> Result<Image<Rgba8>> {
    if !(120..=4096).contains(&width) || !(90..=4096).contains(&height) {
        return Err(Error::InvalidArgument(format!(
            "plot '{}': size {width}×{height} must be within 120×90 ..= 4096×4096",
            plot.title
        )));
    }
    if let Some((s, p)) = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(move |p| (s, p)))
        .find(|(_, p)| !(p.0.is_finite() && p.1.is_finite()))
    {
        return Err(Error::InvalidArgument(format!(
            "plot '{}': series '{}' has the point ({}, {})",
            plot.title, s.label, p.0, p.1
        )));
    }
    let points = || plot.series.iter().flat_map(|s| s.points.iter().copied());
    let no_point =
        || Error::InvalidArgument(format!("plot '{}': no positive point to draw", plot.title));
    let (x0, x1) = match plot.x_range {
        Some(r) => r,
        None => decades(points().map(|p| p.0)).ok_or_else(no_point)?,
    };
    let (y0, y1) = match plot.y_range {
        Some(r) => r,
        None => decades(points().map(|p| p.1)).ok_or_else(no_point)?,
    };
    register_font();
    let mut buffer = vec![255u8; width * height * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width as u32, height as u32))
            .into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let small = (height / 40).clamp(10, 16) as u32;
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(&plot.title, (FAMILY, small + 3))
            .margin(8)
            .x_label_area_size(small * 3)
            .y_label_area_size(small * 5);
        if plot.categorical_x {
            let mut chart = builder
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(draw_error)?;
            let ticks = (x1 - x0).round() as usize + 1;
            draw_chart(&mut chart, plot, small, ticks, &|v| format!("{v:.0}"))?;
        } else {
            let mut chart = builder
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(draw_error)?;
            // plotters' default count of x labels (`MeshStyle`'s 11).
            draw_chart(&mut chart, plot, small, 11, &|v| short(*v))?;
        }
        root.present().map_err(draw_error)?;
    }
    let mut image = Image::new(width, height, [255, 255, 255, 255]);
    for (pixel, rgb) in image.pixels.iter_mut().zip(buffer.chunks_exact(3)) {
        *pixel = [rgb[0], rgb[1], rgb[2], 255];
    }
    Ok(image)
}

/// The mesh of `chart` (`x_labels` x ticks written by `x_format`, log y ticks, the axis
/// descriptions), every series of `plot` (measured: solid with markers; bounds: dashed; points
/// with x, y > 0 only) and the legend in the upper left, whatever the x axis.
fn draw_chart<'a, X>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, Cartesian2d<X, LogCoord<f64>>>,
    plot: &LogLogPlot,
    small: u32,
    x_labels: usize,
    x_format: &dyn Fn(&f64) -> String,
) -> Result<()>
where
    X: Ranged<ValueType = f64> + plotters::coord::ranged1d::ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_labels(x_labels)
        .x_label_formatter(x_format)
        .y_label_formatter(&|v| short(*v))
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .label_style((FAMILY, small))
        .draw()
        .map_err(draw_error)?;
    for s in &plot.series {
        let c = colour(s.colour);
        let style = ShapeStyle::from(c).stroke_width(2);
        let visible: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .collect();
        let legend = match s.style {
            Style::Measured => {
                chart
                    .draw_series(LineSeries::new(visible.clone(), style))
                    .map_err(draw_error)?;
                chart
                    .draw_series(visible.iter().map(|&p| Circle::new(p, 3, c.filled())))
                    .map_err(draw_error)?
            }
            Style::Bound => chart
                .draw_series(DashedLineSeries::new(visible.clone(), 8, 5, style))
                .map_err(draw_error)?,
        };
        legend
            .label(s.label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FAMILY, small))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(draw_error)?;
    Ok(())
}

/// A tick label: 1e-5, 0.01, 1, 100, 1e4.
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10();
    if (-2.0..4.0).contains(&e) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// A legend panel, `width × height` on white: `title` (and the `notes` lines below it,
/// smaller) at the top, then one filled colour box with its label per entry, one line each. Used beside
/// pictures that colour a mesh by a quantity ([`crate::bpm::render::s_picture`]). Errors: a
/// size outside 120 × 90 ..= 4096².
pub fn legend_panel(
    title: &str,
    notes: &[String],
    entries: &[(Rgba8, String)],
    width: usize,
    height: usize,
) -> Result<Image<Rgba8>> {
    if !(120..=4096).contains(&width) || !(90..=4096).contains(&height) {
        return Err(Error::InvalidArgument(format!(
            "legend '{title}': size {width}×{height} must be within 120×90 ..= 4096×4096"
        )));
    }
    register_font();
    let mut buffer = vec![255u8; width * height * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width as u32, height as u32))
            .into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let size = (height / 40).clamp(11, 18) as i32;
        let line = size * 2;
        let text = |s: &str, x: i32, y: i32, px: i32| {
            Text::new(
                s.to_string(),
                (x, y),
                (FAMILY, px).into_font().color(&BLACK),
            )
        };
        root.draw(&text(title, 10, 10, size + 2))
            .map_err(draw_error)?;
        let note_line = size + 2;
        for (k, note) in notes.iter().enumerate() {
            root.draw(&text(note, 10, 10 + line + note_line * k as i32, size - 2))
                .map_err(draw_error)?;
        }
        let top = 10 + line + note_line * notes.len() as i32 + line / 2;
        for (k, (c, label)) in entries.iter().enumerate() {
            let y = top + line * k as i32;
            root.draw(&Rectangle::new(
                [(10, y), (10 + size + 6, y + size + 2)],
                colour(*c).filled(),
            ))
            .map_err(draw_error)?;
            root.draw(&Rectangle::new(
                [(10, y), (10 + size + 6, y + size + 2)],
                BLACK,
            ))
            .map_err(draw_error)?;
            root.draw(&text(label, 20 + size + 6, y, size))
                .map_err(draw_error)?;
        }
        root.present().map_err(draw_error)?;
    }
    let mut image = Image::new(width, height, [255, 255, 255, 255]);
    for (pixel, rgb) in image.pixels.iter_mut().zip(buffer.chunks_exact(3)) {
        *pixel = [rgb[0], rgb[1], rgb[2], 255];
    }
    Ok(image)
}
