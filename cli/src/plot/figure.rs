//! A figure of line-chart panels, rendered to SVG with plotters.
//!
//! Logarithmic axes are drawn by plotting `log10` of the data on a linear axis whose
//! range is widened to whole decades, with ticks at the powers of ten (labelled `10⁻³`)
//! and light grid lines at 2…9 × 10ᵏ when the axis spans few decades. Values that cannot
//! be shown (zero or negative on a log axis, NaN, infinite) break the line there.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::PlotError;

/// Series colours (the "tableau 10" palette without grey), distinct on white.
pub const PALETTE: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// The `i`-th palette colour (cycling).
pub fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesKind {
    /// A solid line.
    Line,
    /// A solid line with a marker at each point.
    LinePoints,
    /// A dashed line (guides such as a reference slope).
    Dashed,
}

/// One data series of a panel.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Machine-readable name written as `data-series` on the series' SVG polylines
    /// (empty: the polylines are not tagged, e.g. for guide lines).
    pub tag: String,
    /// Colour.
    pub color: RGBColor,
    /// Line style.
    pub kind: SeriesKind,
    /// Points (x, y) in data units, in drawing order.
    pub points: Vec<(f64, f64)>,
    /// Text written next to each point (empty: none; else one per point).
    pub labels: Vec<String>,
}

impl Series {
    /// A solid line.
    pub fn line(name: impl Into<String>, color: RGBColor, points: Vec<(f64, f64)>) -> Series {
        let name = name.into();
        Series {
            tag: name.clone(),
            name,
            color,
            kind: SeriesKind::Line,
            points,
            labels: Vec::new(),
        }
    }
}

/// An axis: its label (with the unit) and its scale.
#[derive(Clone, Debug, Default)]
pub struct Axis {
    /// Label, including the unit, e.g. `time t (s)`.
    pub label: String,
    /// Logarithmic scale.
    pub log: bool,
}

impl Axis {
    /// A linear axis.
    pub fn linear(label: impl Into<String>) -> Axis {
        Axis {
            label: label.into(),
            log: false,
        }
    }

    /// A logarithmic axis.
    pub fn log(label: impl Into<String>) -> Axis {
        Axis {
            label: label.into(),
            log: true,
        }
    }
}

/// Where a panel's legend goes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LegendPos {
    /// Upper right corner of the plotting area.
    #[default]
    UpperRight,
    /// Lower right.
    LowerRight,
    /// Lower left.
    LowerLeft,
}

/// Marks drawn along the top edge of a panel (for example, runs that diverged).
#[derive(Clone, Debug, Default)]
pub struct TopMarks {
    /// Legend text for the marks.
    pub label: String,
    /// x positions (data units) and colours.
    pub marks: Vec<(f64, RGBColor)>,
}

/// One chart.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    /// Panel title.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Data series.
    pub series: Vec<Series>,
    /// Marks along the top edge.
    pub top: TopMarks,
    /// A short note written in the lower left corner of the plotting area.
    pub note: Option<String>,
    /// Legend position.
    pub legend: LegendPos,
}

/// A figure: a title and panels on a grid.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Figure title.
    pub title: String,
    /// A second title line (run settings, ...).
    pub subtitle: Option<String>,
    /// Panels, filled row by row.
    pub panels: Vec<Panel>,
    /// Panels per row.
    pub columns: usize,
    /// Size of one panel in pixels.
    pub panel_size: (u32, u32),
}

fn draw_err<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// `10⁻³` for an integer exponent, a compact number otherwise.
pub fn power_of_ten_label(e: f64) -> String {
    if (e - e.round()).abs() > 1e-9 {
        return number_label(10f64.powf(e));
    }
    let e = e.round() as i64;
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::from("10");
    if e < 0 {
        s.push('⁻');
    }
    for d in e.unsigned_abs().to_string().chars() {
        s.push(SUP[d.to_digit(10).unwrap_or(0) as usize]);
    }
    s
}

/// A tick label for a linear axis: plain for moderate magnitudes, scientific otherwise,
/// without trailing zeros.
pub fn number_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { format!("{v}") };
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".into()
        } else {
            s.to_string()
        }
    } else {
        let s = format!("{v:.3e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        format!("{m}e{e}")
    }
}

/// A step size or other positive value in short scientific form: `2.5e-3`.
pub fn short_sci(v: f64) -> String {
    let s = format!("{v:.2e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let m = m.trim_end_matches('0').trim_end_matches('.');
    format!("{m}e{e}")
}

/// The data range of one axis after transformation, and how to draw it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AxisRange {
    lo: f64,
    hi: f64,
    log: bool,
}

impl AxisRange {
    /// From transformed values (log10 for log axes).
    fn from_values(values: impl Iterator<Item = f64>, log: bool) -> AxisRange {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() || !hi.is_finite() {
            return if log {
                AxisRange {
                    lo: -1.0,
                    hi: 0.0,
                    log,
                }
            } else {
                AxisRange {
                    lo: 0.0,
                    hi: 1.0,
                    log,
                }
            };
        }
        if log {
            let mut a = (lo + 1e-9).floor();
            let mut b = (hi - 1e-9).ceil();
            if b <= a {
                a -= 0.0;
                b = a + 1.0;
            }
            AxisRange { lo: a, hi: b, log }
        } else {
            let span = hi - lo;
            let pad = if span > 0.0 {
                0.05 * span
            } else if lo != 0.0 {
                0.1 * lo.abs()
            } else {
                1.0
            };
            AxisRange {
                lo: lo - pad,
                hi: hi + pad,
                log,
            }
        }
    }

    fn labels(&self) -> usize {
        if self.log {
            ((self.hi - self.lo).round() as usize + 1).clamp(2, 12)
        } else {
            8
        }
    }
}

/// Transform a value for an axis: `log10` on log axes (`None` where it cannot be shown).
fn tr(v: f64, log: bool) -> Option<f64> {
    if !v.is_finite() {
        return None;
    }
    if log {
        (v > 0.0).then(|| v.log10())
    } else {
        Some(v)
    }
}

/// Split a series into drawable runs of transformed points.
fn segments(points: &[(f64, f64)], xlog: bool, ylog: bool) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur = Vec::new();
    for &(x, y) in points {
        match (tr(x, xlog), tr(y, ylog)) {
            (Some(a), Some(b)) => cur.push((a, b)),
            _ => {
                if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

impl Figure {
    /// Render to an SVG document.
    ///
    /// # Errors
    /// [`PlotError::Draw`] if plotters fails (it does not on a string target in practice).
    pub fn render(&self) -> Result<String, PlotError> {
        let cols = self.columns.max(1);
        let rows = self.panels.len().div_ceil(cols).max(1);
        let head = if self.subtitle.is_some() { 56 } else { 36 };
        let size = (
            self.panel_size.0 * cols as u32,
            self.panel_size.1 * rows as u32 + head,
        );
        let mut buf = String::new();
        let mut tags: Vec<(String, String)> = Vec::new();
        {
            let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
            root.fill(&WHITE).map_err(draw_err)?;
            let (top, body) = root.split_vertically(head);
            let cx = (size.0 / 2) as i32;
            top.draw(&Text::new(
                self.title.clone(),
                (cx, 8),
                ("sans-serif", 22)
                    .into_font()
                    .style(FontStyle::Bold)
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Top)),
            ))
            .map_err(draw_err)?;
            if let Some(sub) = &self.subtitle {
                top.draw(&Text::new(
                    sub.clone(),
                    (cx, 34),
                    ("sans-serif", 15)
                        .into_font()
                        .color(&BLACK.mix(0.75))
                        .pos(Pos::new(HPos::Center, VPos::Top)),
                ))
                .map_err(draw_err)?;
            }
            let areas = body.split_evenly((rows, cols));
            for (panel, area) in self.panels.iter().zip(areas.iter()) {
                draw_panel(panel, area, &mut tags)?;
            }
            root.present().map_err(draw_err)?;
        }
        Ok(tag_series(&buf, &tags))
    }

    /// Render and write to `path`.
    ///
    /// # Errors
    /// [`PlotError::Write`] naming the file, or a drawing error.
    pub fn save(&self, path: &Path) -> Result<(), PlotError> {
        let svg = self.render()?;
        mbdc_runtime::output::replace_file(path, svg.as_bytes()).map_err(PlotError::Write)
    }
}

fn svg_color(c: &RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

fn legend_pos(p: LegendPos) -> SeriesLabelPosition {
    match p {
        LegendPos::UpperRight => SeriesLabelPosition::UpperRight,
        LegendPos::LowerRight => SeriesLabelPosition::LowerRight,
        LegendPos::LowerLeft => SeriesLabelPosition::LowerLeft,
    }
}

fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, Shift>,
    tags: &mut Vec<(String, String)>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (xlog, ylog) = (panel.x.log, panel.y.log);
    let segs: Vec<Vec<Vec<(f64, f64)>>> = panel
        .series
        .iter()
        .map(|s| segments(&s.points, xlog, ylog))
        .collect();
    let all = || segs.iter().flatten().flatten();
    let xr = AxisRange::from_values(
        all()
            .map(|p| p.0)
            .chain(panel.top.marks.iter().filter_map(|m| tr(m.0, xlog))),
        xlog,
    );
    let mut yr = AxisRange::from_values(all().map(|p| p.1), ylog);
    if !panel.top.marks.is_empty() {
        // room for the marks above the data
        let pad = 0.08 * (yr.hi - yr.lo);
        yr.hi += if ylog { pad.ceil() } else { pad };
    }

    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 17).into_font())
        .margin(12)
        .margin_right(24)
        .x_label_area_size(if panel.note.is_some() { 66 } else { 48 })
        .y_label_area_size(78)
        .build_cartesian_2d(xr.lo..xr.hi, yr.lo..yr.hi)
        .map_err(draw_err)?;

    let xfmt = move |v: &f64| {
        if xlog {
            power_of_ten_label(*v)
        } else {
            number_label(*v)
        }
    };
    let yfmt = move |v: &f64| {
        if ylog {
            power_of_ten_label(*v)
        } else {
            number_label(*v)
        }
    };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(panel.x.label.as_str())
        .y_desc(panel.y.label.as_str())
        .x_labels(xr.labels())
        .y_labels(yr.labels())
        .x_label_formatter(&xfmt)
        .y_label_formatter(&yfmt)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .bold_line_style(BLACK.mix(0.18))
        .light_line_style(BLACK.mix(0.06));
    if xlog {
        mesh.x_max_light_lines(0);
    }
    if ylog {
        mesh.y_max_light_lines(0);
    }
    mesh.draw().map_err(draw_err)?;

    // light decade subdivisions on log axes spanning few decades
    let light = BLACK.mix(0.07);
    for (log, r, vertical) in [(xlog, xr, true), (ylog, yr, false)] {
        if !log || r.hi - r.lo > 6.0 {
            continue;
        }
        let (olo, ohi) = if vertical {
            (yr.lo, yr.hi)
        } else {
            (xr.lo, xr.hi)
        };
        let mut d = r.lo.floor();
        while d < r.hi {
            for k in 2..10 {
                let v = d + (k as f64).log10();
                if v <= r.lo || v >= r.hi {
                    continue;
                }
                let line = if vertical {
                    [(v, olo), (v, ohi)]
                } else {
                    [(olo, v), (ohi, v)]
                };
                chart
                    .draw_series(std::iter::once(PathElement::new(line.to_vec(), light)))
                    .map_err(draw_err)?;
            }
            d += 1.0;
        }
    }

    let mut labelled = false;
    for (s, seg) in panel.series.iter().zip(&segs) {
        if seg.is_empty() {
            // nothing to draw, but the legend still names it (its marks may be drawn)
            if !s.name.is_empty() {
                let c = s.color;
                chart
                    .draw_series(std::iter::once(EmptyElement::at((xr.lo, yr.lo))))
                    .map_err(draw_err)?
                    .label(s.name.clone())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 3), (x + 16, y + 3)], c.mix(0.35).filled())
                    });
                labelled = true;
            }
            continue;
        }
        let style = s.color.stroke_width(2);
        let mut first = true;
        for part in seg {
            let anno = match s.kind {
                SeriesKind::Dashed => chart
                    .draw_series(DashedLineSeries::new(part.iter().copied(), 6, 4, style))
                    .map_err(draw_err)?,
                _ => chart
                    .draw_series(LineSeries::new(part.iter().copied(), style))
                    .map_err(draw_err)?,
            };
            if first && !s.name.is_empty() {
                let c = s.color;
                anno.label(s.name.clone()).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 3), (x + 16, y + 3)], c.filled())
                });
                labelled = true;
            }
            first = false;
        }
        if s.kind == SeriesKind::LinePoints {
            chart
                .draw_series(
                    seg.iter()
                        .flatten()
                        .map(|p| Circle::new(*p, 3, s.color.filled())),
                )
                .map_err(draw_err)?;
        }
        if !s.tag.is_empty() && s.kind != SeriesKind::Dashed {
            tags.push((svg_color(&s.color), s.tag.clone()));
        }
        if !s.labels.is_empty() {
            let font = ("sans-serif", 11).into_font().color(&s.color.mix(0.9));
            let pts = s
                .points
                .iter()
                .zip(&s.labels)
                .filter(|(_, l)| !l.is_empty())
                .filter_map(|(&(x, y), l)| Some(((tr(x, xlog)?, tr(y, ylog)?), l.clone())));
            chart
                .draw_series(
                    pts.map(|(p, l)| EmptyElement::at(p) + Text::new(l, (5, -14), font.clone())),
                )
                .map_err(draw_err)?;
        }
    }

    if !panel.top.marks.is_empty() {
        let y = yr.hi - 0.04 * (yr.hi - yr.lo);
        let marks: Vec<_> = panel
            .top
            .marks
            .iter()
            .filter_map(|&(x, c)| Some(((tr(x, xlog)?, y), c)))
            .collect();
        if !marks.is_empty() {
            chart
                .draw_series(
                    marks
                        .into_iter()
                        .map(|(p, c)| Cross::new(p, 6, c.stroke_width(3))),
                )
                .map_err(draw_err)?
                .label(panel.top.label.clone())
                .legend(|(x, y)| Cross::new((x + 8, y), 5, BLACK.stroke_width(2)));
            labelled = true;
        }
    }

    if let Some(note) = &panel.note {
        // below the axis label, outside the data
        let (_, py) = area.dim_in_pixel();
        area.draw(&Text::new(
            format!("Note: {note}"),
            (14, py as i32 - 8),
            ("sans-serif", 12)
                .into_font()
                .color(&BLACK.mix(0.7))
                .pos(Pos::new(HPos::Left, VPos::Bottom)),
        ))
        .map_err(draw_err)?;
    }

    if labelled {
        chart
            .configure_series_labels()
            .position(legend_pos(panel.legend))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Mark the data polylines: `class="series" data-series="<tag>"` on every `<polyline>`
/// whose stroke is a tagged series' colour (legend samples are rectangles, guides are
/// dashed and untagged, grid lines are `<line>` elements or light grey).
fn tag_series(svg: &str, tags: &[(String, String)]) -> String {
    if tags.is_empty() {
        return svg.to_string();
    }
    let mut out = String::with_capacity(svg.len() + 64 * tags.len());
    let mut rest = svg;
    while let Some(i) = rest.find("<polyline ") {
        let (before, tail) = rest.split_at(i);
        out.push_str(before);
        let end = tail.find('>').map_or(tail.len(), |e| e + 1);
        let tag_text = &tail[..end];
        let stroke = tag_text
            .split_once("stroke=\"")
            .and_then(|(_, s)| s.split_once('"'))
            .map(|(c, _)| c);
        let opaque = tag_text.contains("opacity=\"1\"");
        match (stroke, opaque) {
            (Some(c), true) => match tags.iter().find(|(col, _)| col == c) {
                Some((_, name)) => {
                    out.push_str("<polyline class=\"series\" data-series=\"");
                    escape_attr(&mut out, name);
                    out.push_str("\" ");
                    out.push_str(&tag_text["<polyline ".len()..]);
                }
                None => out.push_str(tag_text),
            },
            _ => out.push_str(tag_text),
        }
        rest = &tail[end..];
    }
    out.push_str(rest);
    out
}

fn escape_attr(out: &mut String, s: &str) {
    for c in s.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
}

/// Thin a long series for drawing: at most about `max` points, keeping each bucket's
/// first, smallest and largest value so that peaks survive.
pub fn decimate(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 8 {
        return points.to_vec();
    }
    let buckets = max / 3;
    let per = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(3 * buckets + 1);
    for chunk in points.chunks(per) {
        let (mut lo, mut hi) = (0usize, 0usize);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 || chunk[lo].1.is_nan() {
                lo = i;
            }
            if p.1 > chunk[hi].1 || chunk[hi].1.is_nan() {
                hi = i;
            }
        }
        let mut idx = vec![0, lo, hi];
        idx.sort_unstable();
        idx.dedup();
        for i in idx {
            out.push(chunk[i]);
        }
    }
    if let Some(last) = points.last() {
        if out.last() != Some(last) {
            out.push(*last);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fig(ylog: bool, pts: Vec<(f64, f64)>) -> Figure {
        Figure {
            title: "T <&>".into(),
            subtitle: Some("sub".into()),
            panels: vec![Panel {
                title: "P".into(),
                x: Axis::linear("time t (s)"),
                y: if ylog {
                    Axis::log("err (m)")
                } else {
                    Axis::linear("err (m)")
                },
                series: vec![
                    Series::line("a\"b", color(0), pts.clone()),
                    Series::line(
                        "c",
                        color(1),
                        pts.iter().map(|p| (p.0, 2.0 * p.1)).collect(),
                    ),
                ],
                top: TopMarks {
                    label: "failed".into(),
                    marks: vec![(0.5, color(0))],
                },
                note: Some("a note".into()),
                legend: LegendPos::LowerRight,
            }],
            columns: 1,
            panel_size: (600, 300),
        }
    }

    #[test]
    fn labels() {
        assert_eq!(power_of_ten_label(-3.0), "10⁻³");
        assert_eq!(power_of_ten_label(12.0), "10¹²");
        assert_eq!(power_of_ten_label(0.0), "10⁰");
        assert_eq!(number_label(0.25), "0.25");
        assert_eq!(number_label(2.0), "2");
        assert_eq!(number_label(1.5e-5), "1.5e-5");
        assert_eq!(number_label(-0.0), "0");
        assert_eq!(short_sci(0.0025), "2.5e-3");
        assert_eq!(short_sci(0.001), "1e-3");
    }

    #[test]
    fn log_ranges_cover_whole_decades() {
        let r = AxisRange::from_values([-2.7, -1.2].into_iter(), true);
        assert_eq!((r.lo, r.hi), (-3.0, -1.0));
        let r = AxisRange::from_values([-2.0].into_iter(), true);
        assert_eq!((r.lo, r.hi), (-2.0, -1.0));
        let r = AxisRange::from_values(std::iter::empty(), true);
        assert!(r.hi > r.lo);
        let r = AxisRange::from_values([3.0, 3.0].into_iter(), false);
        assert!(r.lo < 3.0 && r.hi > 3.0);
    }

    #[test]
    fn segments_break_at_unshowable_values() {
        let s = segments(
            &[
                (1.0, 1.0),
                (2.0, 0.0),
                (3.0, 2.0),
                (4.0, f64::NAN),
                (5.0, 3.0),
            ],
            false,
            true,
        );
        assert_eq!(s.len(), 3);
        assert_eq!(s[1], vec![(3.0, 2f64.log10())]);
    }

    #[test]
    fn renders_tagged_well_formed_svg() {
        for ylog in [false, true] {
            let pts: Vec<_> = (1..50)
                .map(|i| (i as f64 * 0.02, (i as f64).powi(2) * 1e-6))
                .collect();
            let svg = fig(ylog, pts).render().expect("renders");
            assert!(svg.starts_with("<svg"), "{}", &svg[..80]);
            assert!(svg.trim_end().ends_with("</svg>"));
            assert_eq!(svg.matches("data-series=\"a&quot;b\"").count(), 1, "{svg}");
            assert_eq!(svg.matches("data-series=\"c\"").count(), 1);
            assert!(svg.contains("time t (s)") && svg.contains("err (m)"));
            assert!(svg.contains("T &lt;&amp;&gt;"));
            assert!(svg.contains(">\na note") || svg.contains("a note"));
            if ylog {
                assert!(svg.contains("10⁻"), "log ticks");
            }
        }
    }

    #[test]
    fn decimation_keeps_extremes_and_ends() {
        let pts: Vec<_> = (0..10_000)
            .map(|i| (i as f64, if i == 4321 { 100.0 } else { (i as f64).sin() }))
            .collect();
        let d = decimate(&pts, 600);
        assert!(d.len() <= 700, "{}", d.len());
        assert!(d.contains(&(4321.0, 100.0)));
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
    }
}
