//! What the charts of `tdyn run` (energies), `tdyn compare`, `tdyn sweep`, `tdyn validate` and
//! `tdyn chart-scaling` share: the font, one drawing written both as PNG and as SVG, the colours,
//! a panel's frame and axes, notes and marker lines, the legend box, log-axis ranges, SI prefixes
//! and the tick labels.
use plotters::chart::{ChartBuilder, MeshStyle};
use plotters::coord::cartesian::Cartesian2d;
use plotters::coord::combinators::LogCoord;
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::{CoordTranslate, Shift};
use plotters::element::{DashedPathElement, Text};
use plotters::prelude::{
    BitMapBackend, ChartContext, DashedLineSeries, DrawingArea, DrawingAreaErrorKind,
    DrawingBackend, IntoDrawingArea, PathElement, SVGBackend, SeriesLabelPosition,
};
use plotters::style::{Color, RGBColor, ShapeStyle, BLACK, WHITE};
use std::path::Path;

/// TrueType fonts tried for the charts' text (the first found is used).
const FONT_PATHS: [&str; 4] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
];

/// Registers a system font as "sans-serif" once; false when none is found (the charts are then
/// drawn without text rather than not at all).
pub fn font_ready() -> bool {
    static READY: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *READY.get_or_init(|| {
        FONT_PATHS.iter().any(|p| {
            std::fs::read(p).ok().is_some_and(|bytes| {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                plotters::style::register_font(
                    "sans-serif",
                    plotters::style::FontStyle::Normal,
                    bytes,
                )
                .is_ok()
            })
        })
    })
}

/// A chart that can draw itself on any plotters backend.
pub trait Figure {
    /// Width and height, pixels.
    fn size(&self) -> (u32, u32);
    /// Draws the whole chart on `root` (filled, titled, presented).
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// A chart's canvas: `root` filled white, with `title` above when a font is available.
/// Returns the area left for the panels and whether text can be drawn.
pub fn canvas<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
) -> Result<(DrawingArea<DB, Shift>, bool), String> {
    let text = font_ready();
    root.fill(&plotters::style::WHITE)
        .map_err(|x| x.to_string())?;
    let root = if text {
        root.titled(title, ("sans-serif", 22))
            .map_err(|x| x.to_string())?
    } else {
        root
    };
    Ok((root, text))
}

/// Writes `fig` to `stem`.png and `stem`.svg.
pub fn save(fig: &impl Figure, stem: &Path) -> Result<(), String> {
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    fig.draw(BitMapBackend::new(&png, fig.size()).into_drawing_area())
        .map_err(|e| format!("{}: {e}", png.display()))?;
    fig.draw(SVGBackend::new(&svg, fig.size()).into_drawing_area())
        .map_err(|e| format!("{}: {e}", svg.display()))
}

/// The curves' colours, in order (matplotlib's "tab10" less its pink and olive).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// Colour `k` of [`PALETTE`], round again past its end.
pub fn colour(k: usize) -> RGBColor {
    PALETTE[k % PALETTE.len()]
}

/// A plotters drawing error as the message the charts return.
pub fn err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> String {
    e.to_string()
}

/// The coordinates of a log-log panel.
pub type LogLog = Cartesian2d<LogCoord<f64>, LogCoord<f64>>;

/// The room a panel keeps around its plot, pixels.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Blank margin on every side.
    pub margin: u32,
    /// Below the plot, for the x labels and description (only when there is text).
    pub x_labels: u32,
    /// Left of the plot, for the y labels and description (only when there is text).
    pub y_labels: u32,
}

/// A chart builder on `area` with `frame`'s margin and, when there is `text`, its label areas.
/// A caption may still be added.
pub fn panel<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    frame: Frame,
    text: bool,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(frame.margin);
    if text {
        b.x_label_area_size(frame.x_labels)
            .y_label_area_size(frame.y_labels);
    }
    b
}

/// Draws the axes and grid of `ch`: as `labelled` sets them up when there is `text`, else with
/// no labels at all (there is no font to write them with).
pub fn axes<'a, 'b, DB, X, Y, XT, YT>(
    ch: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    text: bool,
    labelled: impl FnOnce(&mut MeshStyle<'a, 'b, X, Y, DB>),
) -> Result<(), String>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = XT> + ValueFormatter<XT>,
    Y: Ranged<ValueType = YT> + ValueFormatter<YT>,
    XT: 'b,
    YT: 'b,
{
    let mut mesh = ch.configure_mesh();
    if text {
        labelled(&mut mesh);
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(err)
}

/// Writes `s` on `ch` with its top left corner at `at` (the chart's coordinates), `font_px`
/// pixels high.
pub fn note<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    ch: &mut ChartContext<'_, DB, CT>,
    s: impl Into<String>,
    at: (f64, f64),
    font_px: u32,
) -> Result<(), String> {
    ch.draw_series(std::iter::once(Text::new(
        s.into(),
        at,
        ("sans-serif", font_px),
    )))
    .map_err(err)?;
    Ok(())
}

/// Dash and gap of a marker line, pixels.
pub const MARK_DASH: (u32, u32) = (8, 6);

/// Marks `x` on `ch` with a dashed vertical line of `style` from `y.0` to `y.1`.
pub fn x_mark<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    ch: &mut ChartContext<'_, DB, CT>,
    x: f64,
    y: (f64, f64),
    style: ShapeStyle,
) -> Result<(), String> {
    ch.draw_series(DashedLineSeries::new(
        vec![(x, y.0), (x, y.1)],
        MARK_DASH.0,
        MARK_DASH.1,
        style,
    ))
    .map_err(err)?;
    Ok(())
}

/// The legend's key for a line series of colour `c`: a short stroke of the same width.
pub fn line_key(c: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
}

/// The legend's key for a dashed line series of colour `c` (`dash` and `gap` pixels).
pub fn dashed_key(
    c: RGBColor,
    dash: u32,
    gap: u32,
) -> impl Fn((i32, i32)) -> DashedPathElement<std::vec::IntoIter<(i32, i32)>, u32> {
    move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 20, y)], dash, gap, c.stroke_width(2))
}

/// Draws the legend of `ch`'s labelled series at `position`: a framed, nearly opaque box with
/// text of `font_px` pixels.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    ch: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
    font_px: u32,
) -> Result<(), String> {
    ch.configure_series_labels()
        .position(position)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .label_font(("sans-serif", font_px))
        .draw()
        .map_err(err)
}

/// An SI prefix for values up to `largest` in magnitude: (factor to divide by, prefix), from
/// nano to giga, so that axis labels read "250" rather than "2.5e-4".
pub fn si_prefix(largest: f64) -> (f64, &'static str) {
    const PREFIXES: [(f64, &str); 7] = [
        (1e9, "G"),
        (1e6, "M"),
        (1e3, "k"),
        (1.0, ""),
        (1e-3, "m"),
        (1e-6, "\u{b5}"),
        (1e-9, "n"),
    ];
    let a = largest.abs();
    if !(a > 0.0 && a.is_finite()) {
        return (1.0, "");
    }
    PREFIXES
        .iter()
        .find(|(f, _)| a >= *f)
        .copied()
        .unwrap_or(PREFIXES[PREFIXES.len() - 1])
}

/// A log axis range around the positive finite values: a factor `pad` beyond the smallest and
/// the largest; `empty` when there is none.
pub fn log_span(values: impl Iterator<Item = f64>, pad: f64, empty: (f64, f64)) -> (f64, f64) {
    let (a, b) = values
        .filter(|x| *x > 0.0 && x.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    if b > 0.0 {
        (a / pad, b * pad)
    } else {
        empty
    }
}

/// `span` widened about its geometric middle to at least `ratio` (hi / lo), so that a log axis
/// over nearly equal values still has labelled ticks.
pub fn at_least(span: (f64, f64), ratio: f64) -> (f64, f64) {
    let (lo, hi) = span;
    if hi / lo >= ratio {
        return span;
    }
    let mid = (lo * hi).sqrt();
    (mid / ratio.sqrt(), mid * ratio.sqrt())
}

/// A tick label on a log axis: "1e-3".
pub fn sci(v: &f64) -> String {
    format!("{v:.0e}")
}

/// A tick label for sizes and times: plain from 0.01 to 10^5 to three significant digits
/// ("0.05", "0.0125", "2.5", "300") and at 0, else "1e-3".
pub fn plain(v: &f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".to_string()
    } else if (1e-2..1e5).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        sci(v)
    }
}

#[cfg(test)]
mod tests {
    /// Tick labels to three significant digits: 0.0125 and 0.01 must not both read "0.01".
    #[test]
    fn plain_labels_keep_three_significant_digits() {
        for (v, want) in [
            (0.0125, "0.0125"),
            (0.01, "0.01"),
            (0.015, "0.015"),
            (0.05, "0.05"),
            (2.5, "2.5"),
            (300.0, "300"),
            (12345.0, "12345"),
            (0.0, "0"),
            (-0.25, "-0.25"),
        ] {
            assert_eq!(super::plain(&v), want, "{v}");
        }
    }
}
