//! The sweep's chart: error against loop time, model memory and peak RSS, one panel each, log-log.
use super::*;
use plotters::coord::Shift;
use plotters::prelude::{
    ChartContext, Circle, DrawingArea, DrawingBackend, IntoFont, IntoLogRange, LineSeries,
    SeriesLabelPosition, Text, TextStyle,
};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{Color, BLACK};

/// The chart: error against loop time, model memory and peak RSS.
pub(super) struct SweepChart<'a> {
    pub(super) title: String,
    pub(super) measures: &'a [Measure],
    pub(super) rows: &'a [SweepRow],
    pub(super) notes: Vec<String>,
}

/// Chart size, pixels.
const SWEEP_CHART_SIZE: (u32, u32) = (1800, 620);

/// Every log axis spans at least this ratio (one decade), so that it has labelled ticks.
const MIN_AXIS_RATIO: f64 = 10.0;

/// Labelled ticks asked of each axis (plotters picks round values near this many).
const AXIS_LABELS: usize = 8;

/// Each panel's margin and label areas, pixels.
const FRAME: chart::Frame = chart::Frame {
    margin: 15,
    x_labels: 45,
    y_labels: 70,
};

/// A panel's cost axis: its description and where a run lies on it.
struct CostAxis {
    /// The axis's description.
    desc: &'static str,
    /// The run's cost in the axis's unit.
    of: fn(&SweepRow) -> f64,
}

/// The three panels' cost axes, left to right.
const COSTS: [CostAxis; 3] = [
    CostAxis {
        desc: "time-step loop wall time (s)",
        of: |r| r.loop_s,
    },
    CostAxis {
        desc: "model memory: bytes per element x elements (MB)",
        of: |r| r.model_bytes / 1e6,
    },
    CostAxis {
        desc: "peak resident set, max over ranks (MB)",
        of: |r| r.rss_peak_bytes / 1e6,
    },
];

impl SweepChart<'_> {
    /// The finished runs, in ladder order.
    fn ok(&self) -> Vec<&SweepRow> {
        self.rows.iter().filter(|r| r.status == "ok").collect()
    }

    /// The error axis's range (every panel), with room above the data for the notes.
    fn error_span(&self) -> (f64, f64) {
        let (y0, y1) = chart::log_span(
            self.ok().iter().flat_map(|r| r.errors.iter().copied()),
            3.0,
            (1e-4, 1.0),
        );
        let (y0, y1) = chart::at_least((y0, y1), MIN_AXIS_RATIO);
        (y0, y1 * 30.0)
    }

    /// Panel `p`: the errors against `cost`, `y` the error axis's range.
    fn panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        p: usize,
        y: (f64, f64),
        text: bool,
    ) -> Result<(), String> {
        let cost = &COSTS[p];
        let (x0, x1) = chart::at_least(
            chart::log_span(self.ok().iter().map(|r| (cost.of)(r)), 1.6, (1e-3, 1.0)),
            MIN_AXIS_RATIO,
        );
        let mut ch = chart::panel(area, FRAME, text)
            .build_cartesian_2d((x0..x1).log_scale(), (y.0..y.1).log_scale())
            .map_err(chart::err)?;
        chart::axes(&mut ch, text, |mesh| {
            mesh.x_desc(cost.desc)
                .y_desc("relative error")
                .x_labels(AXIS_LABELS)
                .y_labels(AXIS_LABELS)
                .x_label_formatter(&chart::plain)
                .y_label_formatter(&chart::sci);
        })?;
        self.reference_mark(&mut ch, cost, y, text)?;
        self.curves(&mut ch, cost, text)?;
        if text {
            self.notes(&mut ch, p, (x0, y.1))?;
            // Cheap and accurate is the corner that runs seldom reach.
            chart::legend(&mut ch, SeriesLabelPosition::LowerLeft, 14)?;
        }
        Ok(())
    }

    /// The finest run, when it is the reference, has no error to draw: its cost is a dashed
    /// line, labelled on its left.
    fn reference_mark<DB: DrawingBackend>(
        &self,
        ch: &mut ChartContext<'_, DB, chart::LogLog>,
        cost: &CostAxis,
        y: (f64, f64),
        text: bool,
    ) -> Result<(), String> {
        let Some(r) = self.rows.iter().find(|r| r.status == "ok" && r.reference) else {
            return Ok(());
        };
        let x = (cost.of)(r);
        if !(x > 0.0 && x.is_finite()) {
            return Ok(());
        }
        chart::x_mark(ch, x, y, BLACK.mix(0.5).stroke_width(2))?;
        if text {
            let left_of = TextStyle::from(("sans-serif", 13).into_font())
                .pos(Pos::new(HPos::Right, VPos::Bottom));
            ch.draw_series(std::iter::once(Text::new(
                format!("{} (reference)", r.label),
                (x / 1.05, y.0 * 2.0),
                left_of,
            )))
            .map_err(chart::err)?;
        }
        Ok(())
    }

    /// One labelled curve per measure: its errors against `cost`, in ladder order (the line
    /// follows the refinement, whatever the timings do); a run's label once, at its first
    /// drawn measure.
    fn curves<DB: DrawingBackend>(
        &self,
        ch: &mut ChartContext<'_, DB, chart::LogLog>,
        cost: &CostAxis,
        text: bool,
    ) -> Result<(), String> {
        let ok = self.ok();
        let drawn = |r: &SweepRow, j: usize| {
            let (x, y) = ((cost.of)(r), r.errors[j]);
            x > 0.0 && x.is_finite() && y > 0.0 && y.is_finite()
        };
        for (j, m) in self.measures.iter().enumerate() {
            let c = chart::colour(j);
            let pts: Vec<(f64, f64, &str)> = ok
                .iter()
                .filter(|r| drawn(r, j))
                .map(|r| {
                    let first = (0..j).all(|i| !drawn(r, i));
                    let label = if first { r.label.as_str() } else { "" };
                    ((cost.of)(r), r.errors[j], label)
                })
                .collect();
            let s = ch
                .draw_series(LineSeries::new(
                    pts.iter().map(|p| (p.0, p.1)),
                    c.stroke_width(2),
                ))
                .map_err(chart::err)?;
            if text {
                s.label(m.name()).legend(chart::line_key(c));
            }
            ch.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 4, c.filled())))
                .map_err(chart::err)?;
            if text {
                ch.draw_series(pts.iter().filter(|p| !p.2.is_empty()).map(|p| {
                    Text::new(
                        p.2.to_string(),
                        (p.0 * 1.04, p.1 * 1.15),
                        ("sans-serif", 13),
                    )
                }))
                .map_err(chart::err)?;
            }
        }
        Ok(())
    }

    /// Panel `p`'s notes, one a line down from `top_left`: what the errors are against (the
    /// first panel), the runs not drawn (the second).
    fn notes<DB: DrawingBackend>(
        &self,
        ch: &mut ChartContext<'_, DB, chart::LogLog>,
        p: usize,
        top_left: (f64, f64),
    ) -> Result<(), String> {
        let notes: Vec<String> = match p {
            0 => self.notes.clone(),
            1 => self
                .rows
                .iter()
                .filter(|r| r.status != "ok")
                .map(|r| format!("{}: {} (not drawn)", r.label, r.status))
                .collect(),
            _ => Vec::new(),
        };
        let (x0, y1) = top_left;
        for (i, n) in notes.into_iter().enumerate() {
            chart::note(ch, n, (x0 * 1.05, y1 / 1.4 / 1.7f64.powi(i as i32)), 13)?;
        }
        Ok(())
    }
}

impl Figure for SweepChart<'_> {
    fn size(&self) -> (u32, u32) {
        SWEEP_CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let (root, text) = chart::canvas(root, &self.title)?;
        let panels = root.split_evenly((1, COSTS.len()));
        let y = self.error_span();
        for (p, area) in panels.iter().enumerate() {
            self.panel(area, p, y, text)?;
        }
        root.present().map_err(chart::err)?;
        Ok(())
    }
}
