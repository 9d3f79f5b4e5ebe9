//! Plots: well-formed SVG with the series names and finite coordinates, pictures of the same
//! plots, and no panic on empty, single-point, constant or NaN data.

// Tests may unwrap: a panic is the failure report.
#![allow(clippy::unwrap_used)]

use squish_render::*;

/// Checks that `svg` is a single well-formed element tree: tags balance and nest, attributes
/// are quoted, and no text contains a raw '<' or '&' that is not an entity. Returns the tag names
/// in document order.
fn check_well_formed(svg: &str) -> Vec<String> {
    assert!(svg.starts_with("<svg"), "starts with <svg");
    let mut stack: Vec<String> = Vec::new();
    let mut names = Vec::new();
    let mut rest = svg;
    let mut closed_root = false;
    while let Some(open) = rest.find('<') {
        let text = &rest[..open];
        assert!(!text.contains('>'), "stray '>' in text {text:?}");
        for (i, _) in text.match_indices('&') {
            let entity = &text[i..];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"].iter().any(|e| entity.starts_with(e)),
                "bad entity in {text:?}"
            );
        }
        assert!(!closed_root || text.trim().is_empty(), "content after the root element");
        let close = rest[open..].find('>').expect("tag closes") + open;
        let tag = &rest[open + 1..close];
        assert!(tag.matches('"').count().is_multiple_of(2), "quotes balance in <{tag}>");
        if let Some(name) = tag.strip_prefix('/') {
            let top = stack.pop().expect("closing tag has an opening tag");
            assert_eq!(top, name.trim());
            if stack.is_empty() {
                closed_root = true;
            }
        } else {
            let name: String = tag.chars().take_while(|c| c.is_ascii_alphanumeric()).collect();
            assert!(!name.is_empty(), "tag name in <{tag}>");
            assert!(!closed_root, "a second root element");
            names.push(name.clone());
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
        rest = &rest[close + 1..];
    }
    assert!(stack.is_empty(), "unclosed tags {stack:?}");
    assert!(closed_root);
    names
}

/// Every number in the coordinate attributes is finite.
fn check_coordinates(svg: &str) {
    for word in ["NaN", "nan", "inf"] {
        assert!(!svg.contains(word), "{word} in the SVG");
    }
    // With the leading space, so that `y="` does not match inside `font-family="`.
    for attr in [" x=\"", " y=\"", " x1=\"", " y2=\"", " cx=\"", " cy=\"", " points=\"", " width=\"", " height=\""] {
        for (i, _) in svg.match_indices(attr) {
            let value = &svg[i + attr.len()..];
            let value = &value[..value.find('"').unwrap()];
            for number in value.split([' ', ',']).filter(|s| !s.is_empty()) {
                let v: f64 = number.parse().unwrap_or_else(|_| panic!("{attr}{value}"));
                assert!(v.is_finite());
            }
        }
    }
}

fn quality_plot() -> Plot {
    let frames = 60;
    let depth: Vec<(f64, f64)> =
        (0..frames).map(|f| (f as f64, 0.02 * (1.0 + (f as f64 * 0.2).sin()) * (-0.03 * f as f64).exp())).collect();
    let mut volume: Vec<(f64, f64)> = (0..frames).map(|f| (f as f64, 0.004 + 0.001 * (f as f64 * 0.5).cos())).collect();
    volume[20].1 = f64::NAN;
    volume[40].1 = f64::NAN;
    volume[42].1 = f64::NAN;
    Plot::new("Contact quality per frame")
        .with_labels("frame", "error")
        .with_series(Series::new("penetration depth", depth))
        .with_series(Series::new("volume change <rel> & co", volume))
        .with_series(Series::from_values("constant", &[0.01; 60]))
}

#[test]
fn svg_is_well_formed_and_names_its_series() {
    for plot in [quality_plot(), quality_plot().with_log_y(true)] {
        let svg = svg_line_plot(&plot);
        let tags = check_well_formed(&svg);
        check_coordinates(&svg);
        assert!(svg.contains("penetration depth"));
        assert!(svg.contains("volume change &lt;rel&gt; &amp; co"));
        assert!(svg.contains("constant"));
        assert!(svg.contains("Contact quality per frame"));
        // The NaN at frame 41 between two NaNs leaves one isolated point, drawn as a dot.
        assert!(tags.iter().any(|t| t == "circle"));
        assert!(tags.iter().filter(|t| *t == "polyline").count() >= 4);
    }
}

#[test]
fn degenerate_plots_do_not_panic() {
    let cases = [
        Plot::new(""),
        Plot::new("empty series").with_series(Series::new("nothing", vec![])),
        Plot::new("one point").with_series(Series::new("p", vec![(3.0, 4.0)])),
        Plot::new("constant").with_series(Series::new("c", vec![(0.0, 2.0), (1.0, 2.0), (2.0, 2.0)])),
        Plot::new("all missing")
            .with_series(Series::new("n", vec![(f64::NAN, 1.0), (1.0, f64::NAN), (f64::INFINITY, 0.0)])),
        Plot::new("log of non-positive").with_log_y(true).with_series(Series::new("z", vec![(0.0, 0.0), (1.0, -1.0)])),
        Plot::new("huge").with_series(Series::new("h", vec![(-1e300, 1e300), (1e300, -1e300)])),
        Plot::new("extreme")
            .with_series(Series::new("m", vec![(f64::MAX, f64::MIN), (f64::MIN, f64::MAX), (0.0, 0.0)])),
        Plot::new("tiny").with_series(Series::new("t", vec![(0.0, 1e-300), (1e-300, 2e-300)])).with_log_y(true),
        Plot::new("small canvas").with_size(0, 0).with_series(Series::new("s", vec![(0.0, 1.0), (1.0, 0.0)])),
    ];
    for plot in &cases {
        let svg = svg_line_plot(plot);
        check_well_formed(&svg);
        check_coordinates(&svg);
        let image = plot_image(plot);
        assert!(image.width >= 64 && image.height >= 64, "{}", plot.title);
        assert!(encode_png(&image).is_ok());
    }
}

#[test]
fn plot_picture_shows_the_series_colours() {
    let plot = quality_plot();
    let image = plot_image(&plot);
    assert_eq!((image.width, image.height), (800, 500));
    let first = rgba8(categorical(0));
    let count = image.rgba.chunks(4).filter(|p| p[..3] == first[..3]).count();
    assert!(count > 200, "{count} pixels of the first series' colour");
    // White background in the corner, dark text somewhere near the top (the title).
    assert_eq!(image.pixel(0, 0), Some([255, 255, 255, 255]));
    let dark_in_title =
        (0..40).flat_map(|y| (0..800).map(move |x| (x, y))).any(|(x, y)| image.pixel(x, y).unwrap()[0] < 60);
    assert!(dark_in_title);
}

#[test]
fn example_plots() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("squish-render-examples");
    std::fs::create_dir_all(&dir).unwrap();
    let plot = quality_plot();
    std::fs::write(dir.join("quality.svg"), svg_line_plot(&plot)).unwrap();
    std::fs::write(dir.join("quality.png"), encode_png(&plot_image(&plot)).unwrap()).unwrap();
    let log = quality_plot().with_log_y(true).with_size(640, 400);
    std::fs::write(dir.join("quality_log.png"), encode_png(&plot_image(&log)).unwrap()).unwrap();
}
