//! The comparison's chart: error against cost (left), error against dt with the stable limit
//! (right).
use super::*;
use plotters::coord::Shift;
use plotters::prelude::{
    ChartContext, Circle, Cross, DrawingArea, DrawingBackend, IntoLogRange, LineSeries,
    SeriesLabelPosition, Text,
};
use plotters::style::{Color, BLACK};

/// The chart: error against cost (left), error against dt with the stable limit (right).
pub(super) struct Chart<'a> {
    pub(super) title: String,
    pub(super) y_desc: String,
    pub(super) reference: String,
    pub(super) limit: f64,
    pub(super) rows: &'a [CompareRow],
}

/// A step factor as a short label: "0.25x", "2x", "92x".
fn factor_label(f: f64) -> String {
    if f >= 10.0 {
        format!("{f:.0}x")
    } else {
        let s = format!("{f:.2}");
        format!("{}x", s.trim_end_matches('0').trim_end_matches('.'))
    }
}

/// Chart size, pixels.
const CHART_SIZE: (u32, u32) = (1400, 600);

/// Each panel's margin and label areas, pixels.
const FRAME: chart::Frame = chart::Frame {
    margin: 15,
    x_labels: 45,
    y_labels: 70,
};

/// The x axis of a panel.
#[derive(Clone, Copy, PartialEq, Eq)]
enum XAxis {
    /// Cost: the time-step loop's wall time (left panel).
    Cost,
    /// The time step (right panel).
    Step,
}

impl XAxis {
    /// The axis's description.
    fn desc(self) -> &'static str {
        match self {
            XAxis::Cost => "cost: time-step loop wall time (s)",
            XAxis::Step => "time step dt (s)",
        }
    }

    /// Where a run lies on this axis.
    fn of(self, r: &CompareRow) -> f64 {
        match self {
            XAxis::Cost => r.loop_s,
            XAxis::Step => r.dt,
        }
    }
}

/// A mode's colour.
fn mode_colour(m: Mode) -> plotters::style::RGBColor {
    match m {
        Mode::Explicit => plotters::style::BLUE,
        Mode::Implicit => plotters::style::RED,
    }
}

impl Chart<'_> {
    /// The finished runs with an error to draw.
    fn finished(&self) -> Vec<&CompareRow> {
        self.rows
            .iter()
            .filter(|r| r.outcome == Outcome::Finished && r.error > 0.0 && r.error.is_finite())
            .collect()
    }

    /// The error axis's range (both panels): the drawn errors, with room above them for the
    /// stopped runs' marks.
    fn error_span(&self) -> (f64, f64) {
        let finished = self.finished();
        let (mut y0, mut y1) = finished.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (a.min(r.error), b.max(r.error))
        });
        if finished.is_empty() {
            (y0, y1) = (1e-6, 1.0);
        }
        (y0 / 3.0, y1 * 10.0)
    }

    /// The range of `axis`: the runs' costs, or their steps and the stable limit.
    fn x_span(&self, axis: XAxis) -> (f64, f64) {
        let values = self.rows.iter().map(|r| axis.of(r));
        let limit = (axis == XAxis::Step).then_some(self.limit);
        chart::log_span(values.chain(limit), 2.0, (1e-3, 1.0))
    }

    /// One panel: error against `axis`, `y` the error axis's range.
    fn panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        axis: XAxis,
        y: (f64, f64),
        text: bool,
    ) -> Result<(), String> {
        let (x0, x1) = self.x_span(axis);
        let mut ch = chart::panel(area, FRAME, text)
            .build_cartesian_2d((x0..x1).log_scale(), (y.0..y.1).log_scale())
            .map_err(chart::err)?;
        chart::axes(&mut ch, text, |mesh| {
            mesh.x_desc(axis.desc())
                .y_desc(self.y_desc.as_str())
                .x_label_formatter(&chart::sci)
                .y_label_formatter(&chart::sci);
        })?;
        if axis == XAxis::Step {
            chart::x_mark(&mut ch, self.limit, y, BLACK.stroke_width(2))?;
            if text {
                chart::note(
                    &mut ch,
                    "explicit stable limit",
                    (self.limit * 1.1, y.0 * 1.5),
                    15,
                )?;
            }
        }
        for mode in [Mode::Explicit, Mode::Implicit] {
            self.mode_series(&mut ch, mode, axis, y, text)?;
        }
        if text {
            let stopped = |o: Outcome| self.rows.iter().filter(|r| r.outcome == o).count();
            let note = match axis {
                XAxis::Cost => self.reference.clone(),
                XAxis::Step => format!(
                    "x: stopped ({} unstable, {} failed); labels: dt / explicit stable limit",
                    stopped(Outcome::Unstable),
                    stopped(Outcome::Failed)
                ),
            };
            chart::note(&mut ch, note, (x0 * 1.05, y.1 / 1.3), 13)?;
            chart::legend(&mut ch, SeriesLabelPosition::LowerRight, 15)?;
        }
        Ok(())
    }

    /// `mode`'s runs on a panel: the finished ones as a labelled curve of points, each with its
    /// step factor; a stopped run has no error: a cross near the top at its step (or at the
    /// cost it took before stopping, when it ran at all).
    fn mode_series<DB: DrawingBackend>(
        &self,
        ch: &mut ChartContext<'_, DB, chart::LogLog>,
        mode: Mode,
        axis: XAxis,
        y: (f64, f64),
        text: bool,
    ) -> Result<(), String> {
        let c = mode_colour(mode);
        let y_stop = y.1 / 2.0;
        let pts: Vec<(f64, f64, f64)> = self
            .finished()
            .iter()
            .filter(|r| r.mode == mode)
            .map(|r| (axis.of(r), r.error, r.dt_factor))
            .collect();
        let mut line: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1)).collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        if !line.is_empty() {
            let s = ch
                .draw_series(LineSeries::new(line, c.stroke_width(2)))
                .map_err(chart::err)?;
            if text {
                s.label(mode_name(mode)).legend(chart::line_key(c));
            }
        }
        ch.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 4, c.filled())))
            .map_err(chart::err)?;
        let marks: Vec<(f64, &CompareRow)> = self
            .rows
            .iter()
            .filter(|r| r.mode == mode && r.outcome != Outcome::Finished)
            .map(|r| (axis.of(r), r))
            .filter(|(x, _)| *x > 0.0 && x.is_finite())
            .collect();
        ch.draw_series(
            marks
                .iter()
                .map(|(x, _)| Cross::new((*x, y_stop), 7, c.stroke_width(3))),
        )
        .map_err(chart::err)?;
        if text {
            ch.draw_series(
                pts.iter()
                    .map(|p| Text::new(factor_label(p.2), (p.0, p.1 * 1.25), ("sans-serif", 13))),
            )
            .map_err(chart::err)?;
            ch.draw_series(marks.iter().map(|(x, r)| {
                Text::new(
                    factor_label(r.dt_factor),
                    (*x, y_stop * 1.4),
                    ("sans-serif", 13),
                )
            }))
            .map_err(chart::err)?;
        }
        Ok(())
    }
}

impl chart::Figure for Chart<'_> {
    fn size(&self) -> (u32, u32) {
        CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let (root, text) = chart::canvas(root, &self.title)?;
        let (left, right) = root.split_horizontally(CHART_SIZE.0 / 2);
        let y = self.error_span();
        self.panel(&left, XAxis::Cost, y, text)?;
        self.panel(&right, XAxis::Step, y, text)?;
        root.present().map_err(chart::err)?;
        Ok(())
    }
}
