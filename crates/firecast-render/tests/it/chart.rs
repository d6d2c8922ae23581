//! Charts, heatmaps, bar charts and the bitmap font.

use std::path::{Path, PathBuf};
use std::time::Instant;

use firecast_render::{
    Align, BarChart, CellPercent, Chart, Heatmap, LegendPosition, Marker, OKABE_ITO, RgbImage, Series,
    TextStyle, draw_text, draw_text_aligned, draw_text_styled, draw_text_vertical, format_ticks, nice_ticks,
    text_height, text_width, viridis,
};

const WHITE: [u8; 3] = [255, 255, 255];
const RED: [u8; 3] = [220, 20, 60];

fn white(w: usize, h: usize) -> RgbImage {
    let mut img = RgbImage::new(w, h);
    img.data.fill(255);
    img
}

/// Bounding box (x0, y0, x1, y1 exclusive) of pixels matching `pred`.
fn bbox(img: &RgbImage, pred: impl Fn([u8; 3]) -> bool) -> Option<(usize, usize, usize, usize)> {
    let mut b: Option<(usize, usize, usize, usize)> = None;
    for y in 0..img.height {
        for x in 0..img.width {
            if pred(img.pixel(x, y).unwrap()) {
                b = Some(match b {
                    None => (x, y, x + 1, y + 1),
                    Some((a, c, d, e)) => (a.min(x), c.min(y), d.max(x + 1), e.max(y + 1)),
                });
            }
        }
    }
    b
}

fn approx(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9)
}

/// Where the example PNGs go: `FIRECAST_CHART_OUT` if set (to look at them), else a temp dir.
fn out_dir() -> (Option<tempfile::TempDir>, PathBuf) {
    match std::env::var("FIRECAST_CHART_OUT") {
        Ok(d) => {
            std::fs::create_dir_all(&d).unwrap();
            (None, PathBuf::from(d))
        }
        Err(_) => {
            let t = tempfile::tempdir().unwrap();
            let p = t.path().to_path_buf();
            (Some(t), p)
        }
    }
}

#[test]
fn nice_ticks_use_1_2_5_steps() {
    assert!(approx(&nice_ticks(0.0, 1.0, 5), &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]));
    assert!(approx(&nice_ticks(0.0, 37.0, 5), &[0.0, 10.0, 20.0, 30.0]));
    assert!(approx(&nice_ticks(-1.0, 1.0, 5), &[-1.0, -0.5, 0.0, 0.5, 1.0]));
    assert!(approx(&nice_ticks(-37.0, -3.0, 5), &[-30.0, -20.0, -10.0]));
    assert!(approx(&nice_ticks(1.0, 0.0, 5), &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]));
    assert!(approx(&nice_ticks(0.0, 1.0, 10), &nice_ticks(0.0, 1.0, 10)));
    assert_eq!(nice_ticks(0.0, 1.0, 10).len(), 11);
    assert!(approx(
        &nice_ticks(-0.05, 1.05, 5),
        &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    ));
    assert!(approx(
        &nice_ticks(1990.0, 2024.0, 4),
        &[1990.0, 2000.0, 2010.0, 2020.0]
    ));
    assert!(approx(
        &nice_ticks(0.001, 0.0042, 4),
        &[0.001, 0.002, 0.003, 0.004]
    ));
    assert!(approx(&nice_ticks(0.0, 5e6, 5), &[0.0, 1e6, 2e6, 3e6, 4e6, 5e6]));
    assert!(approx(&nice_ticks(3.0, 3.0, 5), &[3.0]));
    assert!(nice_ticks(f64::NAN, 1.0, 5).is_empty());
    // Values are exact multiples (no 0.6000000000000001).
    assert_eq!(nice_ticks(0.0, 1.0, 5)[3], 0.6);

    assert_eq!(
        format_ticks(&nice_ticks(0.0, 1.0, 5)),
        ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
    );
    assert_eq!(format_ticks(&nice_ticks(0.0, 37.0, 5)), ["0", "10", "20", "30"]);
    assert_eq!(
        format_ticks(&nice_ticks(-1.0, 1.0, 5)),
        ["-1.0", "-0.5", "0.0", "0.5", "1.0"]
    );
    assert_eq!(format_ticks(&[-0.1, 0.0, 0.1]), ["-0.1", "0.0", "0.1"]);
    assert_eq!(
        format_ticks(&nice_ticks(0.0, 0.05, 5)),
        ["0.00", "0.01", "0.02", "0.03", "0.04", "0.05"]
    );
    assert_eq!(format_ticks(&[0.0, 2e-7, 4e-7]), ["0e0", "2e-7", "4e-7"]);
    assert_eq!(format_ticks(&[1e9, 2e9]), ["1e9", "2e9"]);
}

#[test]
fn text_ink_stays_inside_its_box() {
    let text = "AUROC 0.83 [gjpqy] -1.5e3 ±2°";
    for scale in [1, 2, 3] {
        let mut img = white(900, 80);
        let b = draw_text(&mut img, 7, 11, text, scale, [0, 0, 0]);
        assert_eq!((b.x, b.y), (7, 11));
        assert_eq!(b.width, text_width(text, scale));
        assert_eq!(b.height, text_height(scale));
        let ink = bbox(&img, |p| p != WHITE).unwrap();
        // Ink inside the box, touching its left and right edges; descenders reach the bottom.
        assert_eq!(ink.0, 7);
        assert_eq!(ink.2, 7 + b.width);
        assert!(ink.1 >= 11 && ink.3 == 11 + b.height, "{ink:?} {b:?}");
    }

    // Centre and right alignment move the box, not the ink within it.
    let mut img = white(200, 40);
    let b = draw_text_aligned(&mut img, 100, 5, "Hello", 2, [0, 0, 0], Align::Center);
    let w = text_width("Hello", 2);
    assert_eq!(b.x, 100 - (w / 2) as i64);
    let ink = bbox(&img, |p| p != WHITE).unwrap();
    assert_eq!((ink.0 as i64, ink.2 as i64), (b.x, b.x + w as i64));
    let mut img = white(200, 40);
    let b = draw_text_aligned(&mut img, 150, 5, "Hello", 2, [0, 0, 0], Align::Right);
    assert_eq!(b.x + b.width as i64, 150);
    assert_eq!(bbox(&img, |p| p != WHITE).unwrap().2, 150);

    // Vertical text: a tall box, ink within it, reading upwards (the "T" bar on the left at
    // the bottom).
    let mut img = white(60, 200);
    let b = draw_text_vertical(&mut img, 10, 150, "Tp", 2, [0, 0, 0], Align::Left);
    assert_eq!((b.width, b.height), (text_height(2), text_width("Tp", 2)));
    assert_eq!(b.y + b.height as i64, 150);
    let ink = bbox(&img, |p| p != WHITE).unwrap();
    assert!(ink.0 as i64 >= b.x && ink.2 as i64 <= b.x + b.width as i64);
    assert_eq!((ink.1 as i64, ink.3 as i64), (b.y, 150));
    // The T's bar is the glyph's top row: leftmost column of the box, bottom 10 px.
    assert_eq!(img.pixel(10, 149), Some([0, 0, 0]));
    assert_eq!(img.pixel(11, 140), Some([0, 0, 0]));

    // Bold adds one pixel per glyph; text off the image edges is clipped without panicking.
    let mut img = white(50, 20);
    let style = TextStyle::new(2, [0, 0, 0]).bold(true);
    let b = draw_text_styled(&mut img, -20, -5, "Wide title", &style);
    assert!(b.width > text_width("Wide title", 2));
}

#[test]
fn diagonal_line_passes_through_the_plot_corners() {
    let chart = Chart::new(420, 360)
        .title("Diagonal")
        .x_label("false positive rate")
        .y_label("true positive rate")
        .x_range(0.0, 1.0)
        .y_range(0.0, 1.0)
        .series(Series::line([(0.0, 0.0), (1.0, 1.0)]).color(RED).width(3.0));
    let (img, area) = chart.render_with_area();
    assert_eq!((img.width, img.height), (420, 360));
    assert!(area.left > 0 && area.right < 420 && area.top > 0 && area.bottom < 360);
    assert_eq!(area.pixel_of(0.0, 0.0), Some((area.left, area.bottom - 1)));
    assert_eq!(area.pixel_of(1.0, 1.0), Some((area.right - 1, area.top)));
    assert_eq!(img.pixel(area.left, area.bottom - 1), Some(RED));
    assert_eq!(img.pixel(area.right - 1, area.top), Some(RED));
    let (mx, my) = area.pixel_of(0.5, 0.5).unwrap();
    assert_eq!(img.pixel(mx, my), Some(RED));
    // Clipped at the frame: nothing red outside the plot area.
    let red = bbox(&img, |p| p == RED).unwrap();
    assert!(red.0 >= area.left && red.2 <= area.right && red.1 >= area.top && red.3 <= area.bottom);
    // The opposite corners stay background (or grid).
    let corner = img.pixel(area.right - 1, area.bottom - 1).unwrap();
    assert!(corner[0] > 200 && corner[1] > 200, "{corner:?}");
}

#[test]
fn data_outside_a_fixed_range_is_clipped() {
    let base = Chart::new(300, 200)
        .x_range(0.0, 1.0)
        .y_range(0.0, 1.0)
        .legend(None);
    let plain = base.clone().render();
    let (img, area) = base
        .series(
            Series::line([
                (-5.0, -5.0),
                (0.5, 9.0),
                (0.5, -3.0),
                (7.0, 0.5),
                (f64::NAN, 1.0),
                (1e300, -1e300),
            ])
            .width(5.0),
        )
        .series(Series::scatter([(1.0, 1.0), (-1.0, 0.5)]).marker(Marker::Square, 30.0))
        .render_with_area();
    for y in 0..img.height {
        for x in 0..img.width {
            let inside = x >= area.left && x < area.right && y >= area.top && y < area.bottom;
            if !inside {
                assert_eq!(img.pixel(x, y), plain.pixel(x, y), "({x}, {y})");
            }
        }
    }
    assert!(img != plain);
}

fn roc_chart() -> Chart {
    // A smooth-ish ROC curve as a step function, with a CI band.
    let n = 40;
    let pts: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let x = i as f64 / n as f64;
            (x, x.powf(0.35))
        })
        .collect();
    let band: Vec<(f64, f64, f64)> = pts
        .iter()
        .map(|&(x, y)| (x, (y - 0.06).max(0.0), (y + 0.06).min(1.0)))
        .collect();
    let pts2: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let x = i as f64 / n as f64;
            (x, x.powf(0.6))
        })
        .collect();
    Chart::new(800, 600)
        .title("ROC, test split 2021-2023")
        .x_label("false positive rate")
        .y_label("true positive rate")
        .x_range(0.0, 1.0)
        .y_range(0.0, 1.0)
        .legend(Some(LegendPosition::BottomRight))
        .series(Series::step(pts).label("CNN (AUROC 0.83 ± 0.02)").with_band(band))
        .series(Series::step(pts2).label("logistic regression (AUROC 0.71)"))
        .series(Series::segment((0.0, 0.0), (1.0, 1.0)).label("chance"))
}

#[test]
fn rendering_is_deterministic() {
    let a = roc_chart().render();
    let b = roc_chart().render();
    assert!(a == b);
    let dir = tempfile::tempdir().unwrap();
    roc_chart().save_png(dir.path().join("a.png")).unwrap();
    roc_chart().save_png(dir.path().join("b.png")).unwrap();
    assert_eq!(
        std::fs::read(dir.path().join("a.png")).unwrap(),
        std::fs::read(dir.path().join("b.png")).unwrap()
    );
    let h = || Heatmap::confusion(812, 95, 41, 252).render();
    assert!(h() == h());
    let bars = || forest().render();
    assert!(bars() == bars());
}

#[test]
fn legend_shows_labelled_series() {
    let base = Chart::new(500, 360).x_range(0.0, 10.0).y_range(0.0, 10.0);
    let line = || Series::line([(0.0, 1.0), (3.0, 2.0)]);
    let (unlabelled, area) = base.clone().series(line()).render_with_area();
    let labelled = base.clone().series(line().label("model A")).render();
    let hidden = base.legend(None).series(line().label("model A")).render();
    assert!(unlabelled == hidden);
    // The legend sits in the top-right corner of the plot, away from the data.
    let region = |img: &RgbImage| {
        let mut ink = 0;
        for y in area.top..area.top + 60 {
            for x in area.right - 200..area.right {
                let p = img.pixel(x, y).unwrap();
                if p != unlabelled.pixel(x, y).unwrap() {
                    ink += 1;
                }
            }
        }
        ink
    };
    assert!(region(&labelled) > 50, "{}", region(&labelled));
    // The swatch has the series' colour (the first palette colour); the label is dark text.
    let mut has_swatch = false;
    let mut has_text = false;
    for y in area.top..area.top + 60 {
        for x in area.right - 200..area.right {
            let p = labelled.pixel(x, y).unwrap();
            has_swatch |= p == OKABE_ITO[0];
            has_text |= p.iter().all(|&c| c < 60);
        }
    }
    assert!(has_swatch && has_text);
    // Nothing changed outside the legend corner.
    for y in area.top + 60..area.bottom {
        for x in area.left..area.right {
            assert_eq!(labelled.pixel(x, y), unlabelled.pixel(x, y));
        }
    }
}

/// Ink pattern of `text` drawn at `scale`, cropped to its ink.
fn ink_pattern(img: &RgbImage, color: [u8; 3], within: (usize, usize, usize, usize)) -> Vec<Vec<bool>> {
    let (x0, y0, x1, y1) = within;
    let sub = |x, y| img.pixel(x, y).unwrap() == color;
    let mut b: Option<(usize, usize, usize, usize)> = None;
    for y in y0..y1 {
        for x in x0..x1 {
            if sub(x, y) {
                b = Some(match b {
                    None => (x, y, x + 1, y + 1),
                    Some((a, c, d, e)) => (a.min(x), c.min(y), d.max(x + 1), e.max(y + 1)),
                });
            }
        }
    }
    let Some((a, c, d, e)) = b else {
        return Vec::new();
    };
    (c..e).map(|y| (a..d).map(|x| sub(x, y)).collect()).collect()
}

#[test]
fn heatmap_cells_show_their_values() {
    let hm = Heatmap::new(vec![vec![3.0, 1234.0], vec![57.0, 410.0]])
        .row_labels(["no fire", "fire"])
        .col_labels(["no fire", "fire"]);
    let img = hm.render();
    // The largest value's cell is the top of viridis (yellow) with black text; the smallest
    // is dark purple with white text.
    let top = viridis(1.0);
    let cell = bbox(&img, |p| p == top).unwrap();
    let found = ink_pattern(&img, [0, 0, 0], cell);
    let expected = (1..=6).find(|&s| {
        let mut t = white(400, 100);
        draw_text(&mut t, 2, 2, "1234", s, [0, 0, 0]);
        ink_pattern(&t, [0, 0, 0], (0, 0, 400, 100)) == found
    });
    assert!(expected.is_some(), "cell text is not \"1234\"");
    let low = bbox(&img, |p| p == viridis(0.0)).unwrap();
    let found = ink_pattern(
        &img,
        [255, 255, 255],
        (low.0 + 2, low.1 + 2, low.2 - 2, low.3 - 2),
    );
    let mut t = white(100, 100);
    let s = expected.unwrap();
    draw_text(&mut t, 2, 2, "3", s, [0, 0, 0]);
    assert_eq!(found, ink_pattern(&t, [0, 0, 0], (0, 0, 100, 100)));

    // Percentages add a second line in the cell.
    let with_pct = hm.clone().percent(CellPercent::OfRow).render();
    assert!(with_pct != img);
    // Ragged rows and NaN do not panic.
    Heatmap::new(vec![vec![1.0], vec![f64::NAN, 2.0], vec![]]).render();
    Heatmap::new(vec![]).title("empty").render();
}

fn forest() -> BarChart {
    BarChart::new(800, 360)
        .title("AUROC with 95% CI per model")
        .x_label("AUROC")
        .x_range(0.5, 1.0)
        .reference(0.5)
        .bar("CNN", 0.83, Some((0.81, 0.85)))
        .bar("XGBoost", 0.79, Some((0.76, 0.82)))
        .bar("logistic regression", 0.71, Some((0.68, 0.74)))
        .bar("persistence", 0.58, None)
}

#[test]
fn bars_keep_their_order_and_show_intervals() {
    let custom = [213, 94, 0];
    let mut chart = forest();
    chart.push(firecast_render::Bar {
        label: "climatology".into(),
        value: 0.62,
        interval: Some((0.6, 0.64)),
        color: Some(custom),
    });
    let (img, area) = chart.render_with_area();
    // Bar i is centred on y = n - 1 - i: the first bar is at the top.
    let n = 5.0;
    let y_first = area.y_to_px(n - 1.0) as usize;
    let y_last = area.y_to_px(0.0) as usize;
    assert!(y_first < y_last);
    // The first bar (0.83) reaches past 0.8; the persistence bar (0.58) does not.
    let x08 = area.x_to_px(0.8) as usize;
    let bar_px = |y: usize| img.pixel(x08, y + 4).unwrap();
    assert_ne!(bar_px(y_first), WHITE);
    let y_pers = area.y_to_px(1.0) as usize;
    assert!(img.pixel(x08, y_pers + 4).unwrap()[0] > 200);
    // The custom colour shows on the last bar, blended at 85 % over white.
    let p = img.pixel(area.left + 3, y_last + 4).unwrap();
    assert!(p[0] > p[2] + 80, "{p:?}");
    // The error bar of the first bar is dark ink at its centre line around 0.85.
    let xh = area.x_to_px(0.85) as usize;
    let ink =
        (y_first.saturating_sub(3)..y_first + 4).any(|y| img.pixel(xh, y).unwrap().iter().all(|&c| c < 60));
    assert!(ink);
    // Values are printed right of the plot.
    let right_ink = bbox(&img, |p| p.iter().all(|&c| c < 60)).unwrap();
    assert!(right_ink.2 > area.right + 20);
}

/// 1000 points each as a line, markers and a band.
fn dense_chart() -> Chart {
    let pts: Vec<(f64, f64)> = (0..1000)
        .map(|i| {
            let x = i as f64 / 10.0;
            (x, (x * 0.7).sin() * 3.0 + ((i * 7919) % 101) as f64 / 50.0)
        })
        .collect();
    Chart::new(1200, 700)
        .title("1000 points")
        .x_label("day of season")
        .y_label("anomaly")
        .series(Series::line(pts.clone()).label("line"))
        .series(
            Series::scatter(pts.iter().map(|&(x, y)| (x, y + 6.0)))
                .marker(Marker::Circle, 4.0)
                .label("scatter"),
        )
        .series(Series::band(pts.iter().map(|&(x, y)| (x, y - 1.0, y + 1.0))).label("band"))
}

#[test]
fn thousand_point_series_renders_quickly() {
    let t = Instant::now();
    let img = dense_chart().render();
    let secs = t.elapsed().as_secs_f64();
    println!(
        "1000-point line + scatter + band, 1200 x 700: {:.1} ms",
        secs * 1e3
    );
    assert_eq!((img.width, img.height), (1200, 700));
    assert!(secs < 2.0, "{secs} s");
}

#[test]
fn tiny_and_empty_charts_do_not_panic() {
    for (w, h) in [(0, 0), (1, 1), (12, 9), (60, 40)] {
        let img = Chart::new(w, h)
            .title("t")
            .x_label("x")
            .y_label("y")
            .series(Series::line([(0.0, 1.0)]).label("one point"))
            .series(Series::band([(0.0, 0.0, 1.0)]))
            .render();
        assert_eq!((img.width, img.height), (w, h));
        let img = Heatmap::confusion(1, 2, 3, 4).size(w, h).colorbar(true).render();
        assert_eq!((img.width, img.height), (w, h));
        let img = BarChart::new(w, h)
            .title("t")
            .bar("a", f64::NAN, Some((f64::NAN, 1.0)))
            .bar("b", 2.0, Some((3.0, 1.0)))
            .render();
        assert_eq!((img.width, img.height), (w, h));
    }
    let empty = Chart::new(200, 150).render();
    assert_eq!((empty.width, empty.height), (200, 150));
}

#[test]
fn save_png_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let err = Chart::new(100, 100)
        .save_png(dir.path().join("nope").join("c.png"))
        .unwrap_err();
    assert!(err.to_string().contains("nope"), "{err}");
}

#[test]
fn example_pngs() {
    let (_keep, dir) = out_dir();
    let dir: &Path = &dir;

    roc_chart().save_png(dir.join("roc.png")).unwrap();

    // Calibration-style line chart with markers, a prevalence line, scatter and a band.
    let bins: Vec<f64> = (0..10).map(|i| 0.05 + i as f64 * 0.1).collect();
    let observed: Vec<(f64, f64)> = bins.iter().map(|&p| (p, (p * 0.85 + 0.03).min(1.0))).collect();
    let observed2: Vec<(f64, f64)> = bins.iter().map(|&p| (p, (p * p * 1.1).min(1.0))).collect();
    Chart::new(800, 560)
        .title("Reliability diagram")
        .x_label("predicted probability")
        .y_label("observed frequency")
        .x_range(0.0, 1.0)
        .y_range(0.0, 1.0)
        .legend(Some(LegendPosition::TopLeft))
        .series(Series::segment((0.0, 0.0), (1.0, 1.0)).label("perfectly calibrated"))
        .series(
            Series::hline(0.12)
                .color([150, 150, 150])
                .label("prevalence 0.12"),
        )
        .series(
            Series::line(observed.clone())
                .marker(Marker::Circle, 8.0)
                .label("CNN")
                .with_band(observed.iter().map(|&(x, y)| (x, y - 0.05, y + 0.05))),
        )
        .series(
            Series::line(observed2)
                .marker(Marker::Square, 8.0)
                .dashed(true)
                .label("XGBoost"),
        )
        .save_png(dir.join("calibration.png"))
        .unwrap();

    // Auto ranges with negative values and every marker shape.
    let mut chart = Chart::new(900, 520)
        .title("Fire spread rate vs wind (synthetic)")
        .x_label("wind speed at 20 ft (mph)")
        .y_label("Delta ROS (ch/h)")
        .legend(Some(LegendPosition::TopLeft));
    let shapes = [
        Marker::Circle,
        Marker::Square,
        Marker::Diamond,
        Marker::Triangle,
        Marker::Cross,
    ];
    for (k, m) in shapes.into_iter().enumerate() {
        let pts = (0..25).map(|i| {
            let x = i as f64 * 1.5;
            (
                x,
                (x * 0.9 - 12.0) * (1.0 + k as f64 * 0.3) + ((i * 37 + k * 11) % 13) as f64 - 6.0,
            )
        });
        chart.push(
            Series::scatter(pts)
                .marker(m, 9.0)
                .label(format!("fuel model {}", k + 1)),
        );
    }
    chart.push(Series::vline(20.0).label("red flag threshold"));
    chart.save_png(dir.join("scatter.png")).unwrap();

    Heatmap::confusion(812, 95, 41, 252)
        .colorbar(true)
        .save_png(dir.join("confusion.png"))
        .unwrap();
    Heatmap::new(vec![
        vec![0.91, 0.05, 0.04],
        vec![0.12, 0.80, 0.08],
        vec![0.02, 0.18, 0.80],
    ])
    .title("Fire-size class, row-normalised")
    .row_labels(["A-B", "C-D", "E+"])
    .col_labels(["A-B", "C-D", "E+"])
    .y_label("actual")
    .x_label("predicted")
    .range(0.0, 1.0)
    .colorbar(true)
    .size(560, 500)
    .save_png(dir.join("heatmap3.png"))
    .unwrap();

    forest().save_png(dir.join("forest.png")).unwrap();
    dense_chart().save_png(dir.join("dense.png")).unwrap();

    // Font specimen at 1x, 2x, 3x.
    let mut img = white(980, 250);
    let all: String = (0x20u8..0x7F).map(char::from).collect();
    let (a, b) = all.split_at(48);
    let mut y = 6;
    for s in [1, 2] {
        for line in [a, b] {
            draw_text(&mut img, 6, y, line, s, [0, 0, 0]);
            y += (text_height(s) + 3 * s) as i64;
        }
    }
    draw_text(
        &mut img,
        6,
        y,
        "AUROC 0.832 [0.791, 0.870] ±2° Δt=5 µs ≤ ≥ ×",
        2,
        [0, 0, 0],
    );
    y += 24;
    draw_text(
        &mut img,
        6,
        y,
        "The quick brown fox jumps over the lazy dog.",
        3,
        [0, 114, 178],
    );
    draw_text_vertical(&mut img, 950, 240, "vertical", 2, [213, 94, 0], Align::Left);
    firecast_render::write_png(&img, dir.join("font.png")).unwrap();

    for name in [
        "roc",
        "calibration",
        "scatter",
        "confusion",
        "heatmap3",
        "forest",
        "font",
    ] {
        assert!(dir.join(format!("{name}.png")).exists());
    }
}

/// Cells: translucent squares of a data-unit side, in the band layer, one blend where they
/// touch, and a swatch in the legend.
#[test]
fn cells_fill_their_squares_once() {
    let centres = [(0.5, 0.5), (1.5, 0.5), (0.5, 1.5)];
    let (img, area) = Chart::new(400, 300)
        .grid(false)
        .x_range(0.0, 4.0)
        .y_range(0.0, 3.0)
        .series(Series::cells(centres, 1.0).color(RED).alpha(0.5).label("burnt"))
        .render_with_area();
    let expected = [238, 138, 158];
    let inside = |x: f64, y: f64| {
        let (px, py) = area.pixel_of(x, y).unwrap();
        img.pixel(px, py).unwrap()
    };
    // Square centres, and the shared edge between the first two: the same half blend.
    assert_eq!(inside(0.5, 0.5), expected);
    assert_eq!(inside(1.5, 0.5), expected);
    assert_eq!(inside(1.0, 0.5), expected);
    // The empty cell and beyond stay white.
    assert_eq!(inside(1.5, 1.5), WHITE);
    assert_eq!(inside(3.0, 0.5), WHITE);
    // A swatch of the same colour in the legend (top right).
    let swatch = bbox(&img, |c| c == expected).unwrap();
    assert!(swatch.2 > area.right - 150, "{swatch:?}");
}
