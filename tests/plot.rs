//! The log–log plots (`reparam::plot`, plotters with the bundled font): every series drawn in
//! its colour, text drawn (dark pixels beyond the lines), and typed errors for bad input.

use reparam::plot::{draw, LogLogPlot, Series, Style, PALETTE};

fn plot(points: Vec<(f64, f64)>) -> LogLogPlot {
    LogLogPlot {
        title: "error against size".into(),
        x_label: "size".into(),
        y_label: "error".into(),
        series: vec![
            Series {
                label: "measured".into(),
                points: points.clone(),
                colour: PALETTE[0],
                style: Style::Measured,
            },
            Series {
                label: "bound".into(),
                points: points.iter().map(|p| (p.0, 10.0 * p.1)).collect(),
                colour: PALETTE[3],
                style: Style::Bound,
            },
        ],
        x_range: None,
        y_range: None,
        categorical_x: false,
    }
}

/// The centre columns of the runs of columns holding `colour` in the lower half of the picture
/// (the legend is in the upper left), left to right.
fn blob_columns(image: &reparam::texture::Image<[u8; 4]>, colour: [u8; 4]) -> Vec<f64> {
    let rows = image.height / 2..image.height;
    let has = |x: usize| {
        rows.clone()
            .any(|y| image.pixels[y * image.width + x] == colour)
    };
    let mut centres = Vec::new();
    let mut start = None;
    for x in 0..=image.width {
        match (x < image.width && has(x), start) {
            (true, None) => start = Some(x),
            (false, Some(s)) => {
                centres.push((s + x - 1) as f64 / 2.0);
                start = None;
            }
            _ => {}
        }
    }
    centres
}

#[test]
fn categories_are_evenly_spaced_and_a_log_axis_is_not() {
    // Seven categories (the arithmetic models of a sweep), one marker each.
    let series = (1..=7)
        .map(|k| Series {
            label: String::new(),
            points: vec![(k as f64, 2e-2)],
            colour: PALETTE[0],
            style: Style::Measured,
        })
        .collect();
    let mut p = LogLogPlot {
        series,
        x_range: Some((1.0, 7.0)),
        y_range: Some((1e-2, 1.0)),
        categorical_x: true,
        ..plot(vec![(1.0, 1.0)])
    };
    let gaps = |p: &LogLogPlot| -> Vec<f64> {
        let image = draw(p, 640, 400).unwrap();
        let centres = blob_columns(&image, PALETTE[0]);
        assert_eq!(centres.len(), 7, "{centres:?}");
        centres.windows(2).map(|w| w[1] - w[0]).collect()
    };
    // A linear axis: equal gaps, to the pixel grid (markers 7 px wide, centres at half pixels).
    let even = gaps(&p);
    let (lo, hi) = even
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), &g| (l.min(g), h.max(g)));
    assert!(hi - lo <= 1.5, "{even:?}");
    // The same categories on a log axis: the first gap is 3.5× the last (ln 2 / ln(7/6)).
    p.categorical_x = false;
    let log = gaps(&p);
    assert!(log[0] > 3.0 * log[5], "{log:?}");
}

#[test]
fn a_plot_draws_its_series_axes_and_legend() {
    let points = vec![(1.0, 1e-6), (10.0, 1e-5), (100.0, 3e-4), (1000.0, 1e-2)];
    let image = draw(&plot(points), 480, 320).unwrap();
    assert_eq!((image.width, image.height), (480, 320));
    let count = |c: [u8; 4]| image.pixels.iter().filter(|&&p| p == c).count();
    assert!(count(PALETTE[0]) > 100, "measured line and markers");
    assert!(count(PALETTE[3]) > 50, "dashed bound");
    // Tick labels, axis descriptions, title and legend text: near-black pixels.
    let dark = image
        .pixels
        .iter()
        .filter(|p| p[0] < 80 && p[1] < 80 && p[2] < 80)
        .count();
    assert!(dark > 1000, "{dark} dark pixels");
}

#[test]
fn bad_plots_are_typed_errors() {
    assert!(draw(&plot(vec![(1.0, 1.0)]), 50, 50).is_err());
    assert!(draw(&plot(vec![(1.0, f64::NAN)]), 480, 320).is_err());
    assert!(draw(&plot(vec![(0.0, 0.0)]), 480, 320).is_err());
}
