//! Line plots of per-frame quality figures (penetration depth, volume change, solver residuals
//! …): several named series of (x, y) points, title, axis labels, "nice" ticks, legend and an
//! optional logarithmic y axis. The same layout is written as a standalone SVG
//! ([`svg_line_plot`]) or drawn into an [`Image`] with the crate's own lines and bitmap font
//! ([`plot_image`]), so that command-line users get a PNG without any font or library.
//!
//! Robustness: a point with a non-finite coordinate (or y ≤ 0 on a log axis) is skipped and
//! breaks its line; a point alone between breaks is drawn as a dot; an axis with no data spans
//! [0, 1] (or [1, 10] on a log axis); a constant axis is widened around its value.

use crate::canvas::{draw_line, draw_polyline, fill_circle, stroke_rect};
use crate::colormap::categorical;
use crate::font::{ADVANCE, GLYPH_HEIGHT, draw_text, draw_text_vertical, text_size};
use crate::image::{Image, MAX_IMAGE_SIDE};
use crate::shading::{Rgb, linear_to_srgb8};

/// One named curve.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Series {
    /// Name shown in the legend.
    pub name: String,
    /// The points, in drawing order.
    pub points: Vec<(f64, f64)>,
    /// Linear colour; by default the series' index in the categorical palette.
    pub color: Option<Rgb>,
}

impl Series {
    /// A series with the palette's colour.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self { name: name.into(), points, color: None }
    }

    /// A series of values at x = 0, 1, 2, … (e.g. one value per frame).
    pub fn from_values(name: impl Into<String>, values: &[f64]) -> Self {
        Self::new(name, values.iter().enumerate().map(|(i, &v)| (i as f64, v)).collect())
    }
}

/// A line plot.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plot {
    /// Title above the plot.
    pub title: String,
    /// Label under the x axis.
    pub x_label: String,
    /// Label left of the y axis (written bottom to top).
    pub y_label: String,
    /// The curves.
    pub series: Vec<Series>,
    /// Logarithmic y axis (base 10).
    pub log_y: bool,
    /// Width in pixels (SVG user units).
    pub width: u32,
    /// Height in pixels (SVG user units).
    pub height: u32,
}

impl Plot {
    /// An empty 800 × 500 plot with a title.
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            x_label: String::new(),
            y_label: String::new(),
            series: Vec::new(),
            log_y: false,
            width: 800,
            height: 500,
        }
    }

    /// Sets both axis labels.
    pub fn with_labels(mut self, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        self.x_label = x_label.into();
        self.y_label = y_label.into();
        self
    }

    /// Adds a series.
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Sets a logarithmic (or linear) y axis.
    pub fn with_log_y(mut self, log_y: bool) -> Self {
        self.log_y = log_y;
        self
    }

    /// Sets the size.
    pub fn with_size(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }
}

/// One axis: its data range after rounding to ticks, and the ticks.
#[derive(Clone, Debug)]
struct Axis {
    /// Range in axis units (log10 of the value on a log axis).
    lo: f64,
    hi: f64,
    log: bool,
    /// Tick positions in axis units and their labels.
    ticks: Vec<(f64, String)>,
}

impl Axis {
    /// Axis units of a data value, `None` if it cannot be shown.
    fn coordinate(&self, v: f64) -> Option<f64> {
        if !v.is_finite() {
            return None;
        }
        if self.log { if v > 0.0 { Some(v.log10()) } else { None } } else { Some(v) }
    }

    /// Fraction of the way from `lo` to `hi`.
    fn fraction(&self, coordinate: f64) -> f64 {
        (coordinate - self.lo) / (self.hi - self.lo)
    }
}

/// A 1-2-5 step near `raw` (positive, finite).
fn nice_step(raw: f64) -> f64 {
    let magnitude = 10f64.powf(raw.log10().floor());
    let fraction = raw / magnitude;
    let nice = if fraction <= 1.0 {
        1.0
    } else if fraction <= 2.0 {
        2.0
    } else if fraction <= 5.0 {
        5.0
    } else {
        10.0
    };
    nice * magnitude
}

/// Label of a linear tick at `value` on a grid of `step`, with as many decimals as the step
/// needs; very large or very small magnitudes use scientific notation.
fn format_tick(value: f64, step: f64) -> String {
    if value.abs() < 1e-9 * step {
        return "0".to_string();
    }
    let step_exp = step.log10().floor() as i32;
    let value_exp = value.abs().log10().floor() as i32;
    if value_exp >= 6 || value_exp <= -5 || step_exp <= -5 {
        let digits = (value_exp - step_exp).clamp(0, 6) as usize;
        return format!("{value:.digits$e}");
    }
    let decimals = (-step_exp).clamp(0, 10) as usize;
    format!("{value:.decimals$}")
}

/// Label of the log tick 10^e · m.
fn format_log_tick(exponent: i32, mantissa: f64) -> String {
    if (-3..=4).contains(&exponent) {
        let value = mantissa * 10f64.powi(exponent);
        let decimals = (-exponent).max(0) as usize;
        format!("{value:.decimals$}")
    } else if mantissa == 1.0 {
        format!("1e{exponent}")
    } else {
        format!("{mantissa}e{exponent}")
    }
}

/// Builds a linear axis over `values` with about `target` ticks.
fn linear_axis(values: impl Iterator<Item = f64>, target: usize) -> Axis {
    let (mut lo, mut hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        (lo, hi) = (0.0, 1.0);
    }
    if hi - lo <= 1e-12 * lo.abs().max(hi.abs()) {
        // A constant: widen around it so that the line sits in the middle.
        let pad = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo, hi) = (lo - pad, hi + pad);
    }
    let step = nice_step((hi - lo) / target.max(1) as f64);
    if !(step.is_finite() && step > 0.0) {
        return Axis { lo, hi, log: false, ticks: Vec::new() };
    }
    let first = (lo / step).floor();
    let last = (hi / step).ceil();
    let (lo, hi) = (first * step, last * step);
    let count = ((last - first) as i64).clamp(0, 100);
    let ticks = (0..=count)
        .map(|k| {
            // Integer multiples of the step, not an accumulated sum: no 0.30000000000000004.
            let v = (first + k as f64) * step;
            (v, format_tick(v, step))
        })
        .collect();
    Axis { lo, hi, log: false, ticks }
}

/// Builds a log axis over the positive `values`: whole decades, with 2 and 5 ticks when there
/// are few decades and every n-th decade when there are many.
fn log_axis(values: impl Iterator<Item = f64>) -> Axis {
    let (lo, hi) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let (mut e0, mut e1) = if lo.is_finite() { (lo.log10().floor(), hi.log10().ceil()) } else { (0.0, 1.0) };
    if e1 <= e0 {
        e1 = e0 + 1.0;
    }
    e0 = e0.max(-300.0);
    e1 = e1.min(300.0).max(e0 + 1.0);
    let decades = (e1 - e0) as i32;
    let every = (decades / 8 + 1).max(1);
    let mut ticks = Vec::new();
    for e in (e0 as i32)..=(e1 as i32) {
        if (e - e0 as i32) % every == 0 {
            ticks.push((f64::from(e), format_log_tick(e, 1.0)));
        }
        if decades <= 2 && e < e1 as i32 {
            for m in [2.0, 5.0] {
                ticks.push((f64::from(e) + f64::log10(m), format_log_tick(e, m)));
            }
        }
    }
    Axis { lo: e0, hi: e1, log: true, ticks }
}

/// Consecutive drawable points of a series, in pixels.
type Run = Vec<(f64, f64)>;

/// Where everything goes, in pixels, for one text size.
struct Layout {
    width: f64,
    height: f64,
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
    x: Axis,
    y: Axis,
    /// The series' colours and visible runs (consecutive drawable points) in pixels.
    runs: Vec<(Rgb, Vec<Run>)>,
    /// Legend box: top-left corner, size, row height.
    legend: Option<(f64, f64, f64, f64, f64)>,
}

/// Text metrics of a back end: average character width and line height of tick text, and the
/// line height of the title.
#[derive(Clone, Copy)]
struct Metrics {
    char_w: f64,
    line_h: f64,
    title_h: f64,
}

fn series_color(plot: &Plot, index: usize) -> Rgb {
    plot.series
        .get(index)
        .and_then(|s| s.color)
        .filter(|c| c.iter().all(|v| v.is_finite()))
        .unwrap_or(categorical(index))
}

fn layout(plot: &Plot, m: Metrics) -> Layout {
    let width = f64::from(plot.width.clamp(64, MAX_IMAGE_SIDE));
    let height = f64::from(plot.height.clamp(64, MAX_IMAGE_SIDE));
    let xs = plot.series.iter().flat_map(|s| s.points.iter()).filter(|p| p.0.is_finite() && p.1.is_finite());
    let y = if plot.log_y {
        log_axis(xs.clone().map(|p| p.1))
    } else {
        linear_axis(xs.clone().map(|p| p.1), (height / (4.0 * m.line_h)).clamp(2.0, 8.0) as usize)
    };
    let x_points = xs.filter(|p| !plot.log_y || p.1 > 0.0).map(|p| p.0);
    let widest_y_tick = y.ticks.iter().map(|t| t.1.chars().count()).max().unwrap_or(1) as f64;
    let pad = m.line_h * 0.6;
    let left = pad + if plot.y_label.is_empty() { 0.0 } else { m.line_h * 1.4 } + widest_y_tick * m.char_w + pad;
    let top = pad + if plot.title.is_empty() { 0.0 } else { m.title_h * 1.4 };
    let bottom = height - (pad + m.line_h * 1.4 + if plot.x_label.is_empty() { 0.0 } else { m.line_h * 1.4 });
    let right = width - pad * 2.0;
    // Room for about one tick label per 8 characters across.
    let x_target = ((right - left) / (10.0 * m.char_w)).clamp(2.0, 10.0) as usize;
    let x = linear_axis(x_points, x_target);
    let (left, right, top, bottom) = if right - left < 16.0 || bottom - top < 16.0 {
        // Too small for margins: use the whole canvas.
        (0.0, width, 0.0, height)
    } else {
        (left, right, top, bottom)
    };

    let to_px = |px: f64, py: f64| -> Option<(f64, f64)> {
        let cx = x.coordinate(px)?;
        let cy = y.coordinate(py)?;
        Some((left + x.fraction(cx) * (right - left), bottom - y.fraction(cy) * (bottom - top)))
    };
    let runs = plot
        .series
        .iter()
        .enumerate()
        .map(|(index, series)| {
            let mut runs: Vec<Run> = Vec::new();
            let mut current = Vec::new();
            for &(px, py) in &series.points {
                match to_px(px, py) {
                    Some(p) if p.0.is_finite() && p.1.is_finite() => current.push(p),
                    _ => {
                        if !current.is_empty() {
                            runs.push(std::mem::take(&mut current));
                        }
                    }
                }
            }
            if !current.is_empty() {
                runs.push(current);
            }
            (series_color(plot, index), runs)
        })
        .collect();

    let legend = if plot.series.is_empty() {
        None
    } else {
        let longest = plot.series.iter().map(|s| s.name.chars().count()).max().unwrap_or(0) as f64;
        let row = m.line_h * 1.3;
        let w = pad * 3.0 + m.char_w * 3.0 + longest * m.char_w;
        let h = pad + row * plot.series.len() as f64;
        Some((right - w - pad, top + pad, w, h, row))
    };
    Layout { width, height, left, right, top, bottom, x, y, runs, legend }
}

fn svg_color(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", linear_to_srgb8(c[0]), linear_to_srgb8(c[1]), linear_to_srgb8(c[2]))
}

/// Escapes text for SVG character data and attribute values.
fn xml_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters are not allowed in XML 1.0.
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// The plot as a standalone SVG document.
pub fn svg_line_plot(plot: &Plot) -> String {
    use std::fmt::Write;
    let font = 12.0;
    let m = Metrics { char_w: 0.6 * font, line_h: font, title_h: 1.4 * font };
    let l = layout(plot, m);
    let mut s = String::new();
    let (w, h) = (l.width, l.height);
    // `write!` into a String cannot fail; the results are ignored on purpose.
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="{font}">"#
    );
    let _ = writeln!(s, r#"<rect x="0" y="0" width="{w}" height="{h}" fill="white"/>"#);
    if !plot.title.is_empty() {
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" text-anchor="middle" font-size="{:.1}" font-weight="bold">{}</text>"#,
            0.5 * (l.left + l.right),
            l.top - 0.6 * m.title_h,
            m.title_h,
            xml_escape(&plot.title)
        );
    }
    let (pw, ph) = (l.right - l.left, l.bottom - l.top);
    let _ = writeln!(s, r##"<g stroke="#e4e4e4" stroke-width="1">"##);
    for (v, _) in &l.x.ticks {
        let x = l.left + l.x.fraction(*v) * pw;
        let _ = writeln!(s, r#"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}"/>"#, l.top, l.bottom);
    }
    for (v, _) in &l.y.ticks {
        let y = l.bottom - l.y.fraction(*v) * ph;
        let _ = writeln!(s, r#"<line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}"/>"#, l.left, l.right);
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(
        s,
        r##"<rect x="{:.2}" y="{:.2}" width="{pw:.2}" height="{ph:.2}" fill="none" stroke="#404040"/>"##,
        l.left, l.top
    );
    let _ = writeln!(s, r##"<g fill="#303030">"##);
    for (v, label) in &l.x.ticks {
        let x = l.left + l.x.fraction(*v) * pw;
        let _ = writeln!(
            s,
            r#"<text x="{x:.2}" y="{:.2}" text-anchor="middle">{}</text>"#,
            l.bottom + 1.2 * m.line_h,
            xml_escape(label)
        );
    }
    for (v, label) in &l.y.ticks {
        let y = l.bottom - l.y.fraction(*v) * ph;
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" text-anchor="end">{}</text>"#,
            l.left - 0.4 * m.line_h,
            y + 0.35 * m.line_h,
            xml_escape(label)
        );
    }
    if !plot.x_label.is_empty() {
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" text-anchor="middle">{}</text>"#,
            0.5 * (l.left + l.right),
            l.bottom + 2.6 * m.line_h,
            xml_escape(&plot.x_label)
        );
    }
    if !plot.y_label.is_empty() {
        let (x, y) = (1.2 * m.line_h, 0.5 * (l.top + l.bottom));
        let _ = writeln!(
            s,
            r#"<text x="{x:.2}" y="{y:.2}" text-anchor="middle" transform="rotate(-90 {x:.2} {y:.2})">{}</text>"#,
            xml_escape(&plot.y_label)
        );
    }
    let _ = writeln!(s, "</g>");
    for (index, (color, runs)) in l.runs.iter().enumerate() {
        let color = svg_color(*color);
        let name = plot.series.get(index).map_or(String::new(), |s| xml_escape(&s.name));
        let _ = writeln!(s, r#"<g stroke="{color}" fill="{color}"><title>{name}</title>"#);
        for run in runs {
            if let [(x, y)] = run[..] {
                let _ = writeln!(s, r#"<circle cx="{x:.2}" cy="{y:.2}" r="3" stroke="none"/>"#);
            } else {
                let points: Vec<String> = run.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
                let _ = writeln!(
                    s,
                    r#"<polyline fill="none" stroke-width="2" stroke-linejoin="round" points="{}"/>"#,
                    points.join(" ")
                );
            }
        }
        let _ = writeln!(s, "</g>");
    }
    if let Some((x, y, w, h, row)) = l.legend {
        let _ = writeln!(
            s,
            r##"<rect x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" fill="white" fill-opacity="0.85" stroke="#b0b0b0"/>"##
        );
        for (index, series) in plot.series.iter().enumerate() {
            let color = svg_color(series_color(plot, index));
            let cy = y + 0.5 * m.line_h + row * (index as f64 + 0.5);
            let x0 = x + 0.6 * m.line_h;
            let _ = writeln!(
                s,
                r#"<line x1="{x0:.2}" y1="{cy:.2}" x2="{:.2}" y2="{cy:.2}" stroke="{color}" stroke-width="2"/>"#,
                x0 + 2.4 * m.char_w
            );
            let _ = writeln!(
                s,
                r##"<text x="{:.2}" y="{:.2}" fill="#303030">{}</text>"##,
                x0 + 3.0 * m.char_w,
                cy + 0.35 * m.line_h,
                xml_escape(&series.name)
            );
        }
    }
    s.push_str("</svg>\n");
    s
}

/// The plot drawn into an opaque white picture of `plot.width` × `plot.height` pixels (each
/// clamped to 64 ..= [`MAX_IMAGE_SIDE`]), with the built-in bitmap font.
pub fn plot_image(plot: &Plot) -> Image {
    let (w, h) = (plot.width.clamp(64, MAX_IMAGE_SIDE), plot.height.clamp(64, MAX_IMAGE_SIDE));
    // Font pixels grow with the picture so that text keeps about the same share of it.
    let scale = (w / 400).min(h / 250).clamp(1, 4);
    let title_scale = (3 * scale).div_ceil(2).max(scale + 1);
    let m = Metrics {
        char_w: f64::from(ADVANCE * scale),
        line_h: f64::from(GLYPH_HEIGHT * scale),
        title_h: f64::from(GLYPH_HEIGHT * title_scale),
    };
    let l = layout(plot, m);
    let mut image = Image::new(w, h, [255, 255, 255, 255]);
    let ink = [0.03, 0.03, 0.03];
    let grid_color = [0.78, 0.78, 0.78];
    let (pw, ph) = (l.right - l.left, l.bottom - l.top);
    let round = |v: f64| v.round() as i64;

    for (v, _) in &l.x.ticks {
        let x = round(l.left + l.x.fraction(*v) * pw);
        image.blend_rect(x, round(l.top), 1, ph.max(0.0) as u32, grid_color, 1.0);
    }
    for (v, _) in &l.y.ticks {
        let y = round(l.bottom - l.y.fraction(*v) * ph);
        image.blend_rect(round(l.left), y, pw.max(0.0) as u32, 1, grid_color, 1.0);
    }
    for (color, runs) in &l.runs {
        for run in runs {
            if run.len() == 1 {
                fill_circle(&mut image, run[0], 1.5 * f64::from(scale) + 1.0, *color, 1.0);
            } else {
                draw_polyline(&mut image, run, 1.0 + f64::from(scale), *color, 1.0);
            }
        }
    }
    stroke_rect(&mut image, round(l.left), round(l.top), (pw.max(0.0) as u32) + 1, (ph.max(0.0) as u32) + 1, ink, 0.8);

    let text = |image: &mut Image, x: f64, y: f64, s: &str, scale: u32| {
        draw_text(image, round(x), round(y), s, ink, 1.0, scale);
    };
    let tick = 3.0 * f64::from(scale);
    for (v, label) in &l.x.ticks {
        let x = l.left + l.x.fraction(*v) * pw;
        draw_line(&mut image, (x + 0.5, l.bottom), (x + 0.5, l.bottom + tick), 1.0, ink, 0.8);
        let (tw, _) = text_size(label, scale);
        text(&mut image, x - 0.5 * f64::from(tw), l.bottom + tick + 0.4 * m.line_h, label, scale);
    }
    for (v, label) in &l.y.ticks {
        let y = l.bottom - l.y.fraction(*v) * ph;
        draw_line(&mut image, (l.left - tick, y + 0.5), (l.left, y + 0.5), 1.0, ink, 0.8);
        let (tw, th) = text_size(label, scale);
        text(&mut image, l.left - tick - 0.4 * m.char_w - f64::from(tw), y - 0.5 * f64::from(th) + 0.5, label, scale);
    }
    if !plot.title.is_empty() {
        let (tw, _) = text_size(&plot.title, title_scale);
        text(&mut image, 0.5 * (l.left + l.right - f64::from(tw)), l.top - 1.3 * m.title_h, &plot.title, title_scale);
    }
    if !plot.x_label.is_empty() {
        let (tw, _) = text_size(&plot.x_label, scale);
        text(&mut image, 0.5 * (l.left + l.right - f64::from(tw)), l.bottom + 2.0 * m.line_h, &plot.x_label, scale);
    }
    if !plot.y_label.is_empty() {
        let (tw, _) = text_size(&plot.y_label, scale);
        let y = 0.5 * (l.top + l.bottom + f64::from(tw));
        draw_text_vertical(&mut image, round(0.6 * m.line_h), round(y), &plot.y_label, ink, 1.0, scale);
    }
    if let Some((x, y, w, h, row)) = l.legend {
        image.blend_rect(round(x), round(y), w as u32, h as u32, [1.0; 3], 0.85);
        stroke_rect(&mut image, round(x), round(y), w as u32, h as u32, [0.45; 3], 1.0);
        for (index, series) in plot.series.iter().enumerate() {
            let color = series_color(plot, index);
            let cy = y + 0.5 * m.line_h + row * (index as f64 + 0.5);
            let x0 = x + 0.6 * m.line_h;
            draw_line(&mut image, (x0, cy), (x0 + 2.4 * m.char_w, cy), 1.0 + f64::from(scale), color, 1.0);
            text(&mut image, x0 + 3.0 * m.char_w, cy - 0.5 * m.line_h + 0.5, &series.name, scale);
        }
    }
    image
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn nice_steps_are_1_2_5_multiples() {
        assert_eq!(nice_step(0.13), 0.2);
        assert_eq!(nice_step(3.0), 5.0);
        assert_eq!(nice_step(7.0), 10.0);
        assert_eq!(nice_step(100.0), 100.0);
        let axis = linear_axis([0.05, 0.93].into_iter(), 5);
        let labels: Vec<&str> = axis.ticks.iter().map(|t| t.1.as_str()).collect();
        assert_eq!(labels, ["0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        assert_eq!((axis.lo, axis.hi), (0.0, 1.0));
        let axis = linear_axis([-3.0, 117.0].into_iter(), 6);
        assert_eq!(axis.ticks.first().map(|t| t.1.as_str()), Some("-20"));
        assert_eq!(axis.ticks.last().map(|t| t.1.as_str()), Some("120"));
    }

    #[test]
    fn constant_and_empty_axes_are_widened() {
        let axis = linear_axis([5.0, 5.0].into_iter(), 5);
        assert!(axis.lo < 5.0 && axis.hi > 5.0);
        let axis = linear_axis(std::iter::empty(), 5);
        assert_eq!((axis.lo, axis.hi), (0.0, 1.0));
        let axis = linear_axis([0.0].into_iter(), 5);
        assert!(axis.lo < 0.0 && axis.hi > 0.0);
        let axis = log_axis([0.0, -1.0].into_iter());
        assert_eq!((axis.lo, axis.hi), (0.0, 1.0));
    }

    #[test]
    fn log_axis_spans_whole_decades() {
        let axis = log_axis([3e-4, 0.5].into_iter());
        assert_eq!((axis.lo, axis.hi), (-4.0, 0.0));
        let labels: Vec<&str> = axis.ticks.iter().map(|t| t.1.as_str()).collect();
        assert_eq!(labels, ["1e-4", "0.001", "0.01", "0.1", "1"]);
        let many = log_axis([1e-30, 1e30].into_iter());
        assert!(many.ticks.len() <= 10, "{}", many.ticks.len());
    }

    #[test]
    fn tick_labels_use_enough_digits() {
        assert_eq!(format_tick(0.30000000000000004, 0.1), "0.3");
        assert_eq!(format_tick(1e-17, 0.1), "0");
        assert_eq!(format_tick(2.5e7, 5e6), "2.5e7");
        assert_eq!(format_tick(1.2e-6, 1e-7), "1.2e-6");
        assert_eq!(format_tick(1500.0, 500.0), "1500");
    }
}
