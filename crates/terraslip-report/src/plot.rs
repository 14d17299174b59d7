use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::ReportError;

/// Colour-blind-friendly palette (Okabe-Ito), used in series order.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 0, 0),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 158, 115),
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(204, 121, 167),
    RGBColor(140, 140, 40),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SeriesStyle {
    Line,
    /// Thicker line, for the reference (truth).
    Bold,
    Dashed,
    Points,
}

/// One named series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub style: SeriesStyle,
    /// Palette index; `None` picks the next colour.
    pub color: Option<usize>,
}

impl Series {
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            style: SeriesStyle::Line,
            color: None,
        }
    }
    pub fn points(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            style: SeriesStyle::Points,
            ..Self::line(name, points)
        }
    }
    pub fn style(mut self, style: SeriesStyle) -> Self {
        self.style = style;
        self
    }
    pub fn color(mut self, idx: usize) -> Self {
        self.color = Some(idx);
        self
    }
}

/// A shaded band `lo(x)..hi(x)` (e.g. a 2σ interval).
#[derive(Debug, Clone)]
pub struct Band {
    pub name: String,
    /// `(x, lo, hi)`
    pub points: Vec<(f64, f64, f64)>,
    pub color: Option<usize>,
}

/// A 2-D line/scatter plot with optional bands and labelled vertical markers.
#[derive(Debug, Clone)]
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub bands: Vec<Band>,
    /// Vertical markers `(x, label)` (e.g. terrain changes).
    pub markers: Vec<(f64, String)>,
    /// Same scale on both axes (trajectories).
    pub equal_aspect: bool,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
    pub size: (u32, u32),
    /// Where the legend goes (default upper right).
    pub legend: LegendPosition,
}

/// Legend placement inside the plot area.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    #[default]
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
    MiddleRight,
}

impl LegendPosition {
    /// Whether the legend sits in the upper half (marker labels then go to
    /// the bottom of the plot).
    fn is_upper(self) -> bool {
        matches!(self, Self::UpperRight | Self::UpperLeft)
    }
}

impl LinePlot {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            bands: Vec::new(),
            markers: Vec::new(),
            equal_aspect: false,
            y_range: None,
            size: (1000, 450),
            legend: LegendPosition::UpperRight,
        }
    }
    pub fn series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
    pub fn band(
        mut self,
        name: impl Into<String>,
        points: Vec<(f64, f64, f64)>,
        color: Option<usize>,
    ) -> Self {
        self.bands.push(Band {
            name: name.into(),
            points,
            color,
        });
        self
    }
    pub fn marker(mut self, x: f64, label: impl Into<String>) -> Self {
        self.markers.push((x, label.into()));
        self
    }
    pub fn equal_aspect(mut self, on: bool) -> Self {
        self.equal_aspect = on;
        self
    }
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }
    pub fn legend(mut self, position: LegendPosition) -> Self {
        self.legend = position;
        self
    }
    pub fn size(mut self, w: u32, h: u32) -> Self {
        self.size = (w, h);
        self
    }

    /// Renders to an SVG string.
    pub fn to_svg(&self) -> Result<String, ReportError> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size).into_drawing_area();
            self.draw_on(&root)?;
            root.present().map_err(|e| draw_err(&self.title, e))?;
        }
        Ok(out)
    }

    /// Writes an SVG file atomically.
    pub fn write_svg(&self, path: &Path) -> Result<(), ReportError> {
        let svg = self.to_svg()?;
        terraslip_io::write_atomic(path, svg.as_bytes())?;
        Ok(())
    }

    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let mut xr = (f64::INFINITY, f64::NEG_INFINITY);
        let mut yr = (f64::INFINITY, f64::NEG_INFINITY);
        let mut add = |x: f64, y: f64| {
            if x.is_finite() && y.is_finite() {
                xr = (xr.0.min(x), xr.1.max(x));
                yr = (yr.0.min(y), yr.1.max(y));
            }
        };
        for s in &self.series {
            for &(x, y) in &s.points {
                add(x, y);
            }
        }
        for b in &self.bands {
            for &(x, lo, hi) in &b.points {
                add(x, lo);
                add(x, hi);
            }
        }
        if !xr.0.is_finite() {
            xr = (0.0, 1.0);
            yr = (0.0, 1.0);
        }
        if let Some(r) = self.y_range {
            yr = r;
        }
        let pad = |r: (f64, f64), frac: f64| {
            let span = (r.1 - r.0).abs().max(1e-9);
            (r.0 - frac * span, r.1 + frac * span)
        };
        let (mut xr, mut yr) = (
            pad(xr, 0.0),
            if self.y_range.is_some() {
                yr
            } else {
                pad(yr, 0.05)
            },
        );
        if self.equal_aspect {
            // Widen the shorter axis so one metre is as long on both.
            let (w, h) = (f64::from(self.size.0 - 90), f64::from(self.size.1 - 90));
            let (sx, sy) = ((xr.1 - xr.0) / w, (yr.1 - yr.0) / h);
            let s = sx.max(sy);
            let (cx, cy) = (0.5 * (xr.0 + xr.1), 0.5 * (yr.0 + yr.1));
            xr = (cx - 0.5 * s * w, cx + 0.5 * s * w);
            yr = (cy - 0.5 * s * h, cy + 0.5 * s * h);
        }
        (xr, yr)
    }

    /// Draws into an existing area (used by [`Figure`] for panels).
    pub fn draw_on<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<(), ReportError> {
        let e = |err| draw_err(&self.title, err);
        area.fill(&WHITE).map_err(e)?;
        let ((x0, x1), (y0, y1)) = self.ranges();
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .light_line_style(RGBColor(235, 235, 235))
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(e)?;

        for (i, b) in self.bands.iter().enumerate() {
            let c = PALETTE[b.color.unwrap_or(i + 1) % PALETTE.len()];
            let mut poly: Vec<(f64, f64)> = b.points.iter().map(|&(x, _, hi)| (x, hi)).collect();
            poly.extend(b.points.iter().rev().map(|&(x, lo, _)| (x, lo)));
            poly.retain(|p| p.0.is_finite() && p.1.is_finite());
            chart
                .draw_series(std::iter::once(Polygon::new(poly, c.mix(0.18).filled())))
                .map_err(e)?
                .label(&b.name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.mix(0.3).filled())
                });
        }

        for (&(x, ref label), k) in self.markers.iter().zip(0..) {
            let grey = RGBColor(120, 120, 120);
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(x, y0), (x, y1)],
                    6,
                    4,
                    grey.stroke_width(1),
                ))
                .map_err(e)?;
            // Stagger labels so neighbouring markers don't overprint, on
            // the side the legend leaves free so it cannot hide them.
            let drop = (y1 - y0) * (0.04 + 0.06 * f64::from(k % 2));
            let yl = if self.legend.is_upper() {
                y0 + drop
            } else {
                y1 - drop
            };
            chart
                .draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (x, yl),
                    ("sans-serif", 13).into_font().color(&grey),
                )))
                .map_err(e)?;
        }

        for (i, s) in self.series.iter().enumerate() {
            let c = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect();
            let anno = match s.style {
                SeriesStyle::Line => chart.draw_series(LineSeries::new(pts, c.stroke_width(2))),
                SeriesStyle::Bold => chart.draw_series(LineSeries::new(pts, c.stroke_width(3))),
                SeriesStyle::Dashed => {
                    chart.draw_series(DashedLineSeries::new(pts, 8, 5, c.stroke_width(2)))
                }
                SeriesStyle::Points => chart.draw_series(
                    pts.into_iter()
                        .map(|p| Circle::new(p, 2, c.mix(0.6).filled())),
                ),
            }
            .map_err(e)?;
            anno.label(&s.name).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3))
            });
        }

        if !self.series.is_empty() || !self.bands.is_empty() {
            chart
                .configure_series_labels()
                .position(match self.legend {
                    LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
                    LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
                    LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
                    LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
                    LegendPosition::MiddleRight => SeriesLabelPosition::MiddleRight,
                })
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(e)?;
        }
        Ok(())
    }
}

/// Several plots stacked vertically in one SVG (shared time axis panels).
#[derive(Debug, Clone, Default)]
pub struct Figure {
    pub panels: Vec<LinePlot>,
    pub width: u32,
    pub panel_height: u32,
}

impl Figure {
    pub fn new(panels: Vec<LinePlot>) -> Self {
        Self {
            panels,
            width: 1100,
            panel_height: 330,
        }
    }

    pub fn to_svg(&self) -> Result<String, ReportError> {
        let n = self.panels.len().max(1);
        let mut out = String::new();
        {
            let size = (self.width, self.panel_height * n as u32);
            let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
            let areas = root.split_evenly((n, 1));
            for (p, a) in self.panels.iter().zip(areas.iter()) {
                p.draw_on(a)?;
            }
            root.present().map_err(|e| draw_err("figure", e))?;
        }
        Ok(out)
    }

    pub fn write_svg(&self, path: &Path) -> Result<(), ReportError> {
        let svg = self.to_svg()?;
        terraslip_io::write_atomic(path, svg.as_bytes())?;
        Ok(())
    }
}

pub(crate) fn draw_err<E: std::fmt::Debug>(what: &str, e: E) -> ReportError {
    ReportError::Draw {
        what: what.to_string(),
        reason: format!("{e:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_title_labels_legend_and_marker() {
        let svg = LinePlot::new("Spread", "time [s]", "d [m]")
            .series(Series::line("truth", vec![(0.0, 0.5), (1.0, 0.6)]).style(SeriesStyle::Bold))
            .series(Series::points("gnss", vec![(0.5, 0.55)]))
            .band("2σ", vec![(0.0, 0.4, 0.6), (1.0, 0.5, 0.7)], None)
            .marker(0.5, "grass")
            .to_svg()
            .unwrap();
        for needle in [
            "Spread", "time [s]", "d [m]", "truth", "gnss", "grass", "<polygon",
        ] {
            assert!(svg.contains(needle), "missing {needle}");
        }
    }

    /// The y pixel of the SVG text element holding `label`.
    fn text_y(svg: &str, label: &str) -> f64 {
        let end = svg.find(label).expect(label);
        let start = svg[..end].rfind("<text").unwrap();
        let tag = &svg[start..end];
        let y = tag.find(" y=\"").unwrap() + 4;
        tag[y..y + tag[y..].find('"').unwrap()].parse().unwrap()
    }

    #[test]
    fn marker_labels_sit_on_the_side_the_legend_leaves_free() {
        let plot = |legend| {
            LinePlot::new("t", "x", "y")
                .series(Series::line("truth", vec![(0.0, 0.0), (1.0, 1.0)]))
                .marker(0.9, "GNSS back")
                .legend(legend)
                .size(800, 400)
                .to_svg()
                .unwrap()
        };
        let upper = text_y(&plot(LegendPosition::UpperRight), "GNSS back");
        let lower = text_y(&plot(LegendPosition::LowerRight), "GNSS back");
        assert!(
            upper > 200.0,
            "label at y = {upper} px under an upper legend"
        );
        assert!(
            lower < 200.0,
            "label at y = {lower} px above a lower legend"
        );
    }

    #[test]
    fn empty_and_non_finite_data_still_render() {
        let svg = LinePlot::new("empty", "x", "y")
            .series(Series::line(
                "nan",
                vec![(f64::NAN, 1.0), (0.0, f64::INFINITY)],
            ))
            .to_svg()
            .unwrap();
        assert!(svg.contains("empty"));
    }

    #[test]
    fn figure_stacks_panels() {
        let p = |t: &str| {
            LinePlot::new(t, "t [s]", "m").series(Series::line("a", vec![(0.0, 0.0), (1.0, 1.0)]))
        };
        let svg = Figure::new(vec![p("first"), p("second")]).to_svg().unwrap();
        assert!(svg.contains("first") && svg.contains("second"));
    }
}
