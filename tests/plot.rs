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
    }
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
