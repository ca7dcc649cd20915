//! A case's chart: a panel per measure, the measure against resolution (or the single run) with the
//! reference, its published range and the allowed band.
use super::*;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::{
    Cartesian2d, ChartContext, Circle, DrawingArea, DrawingBackend, LineSeries, Rectangle,
};
use plotters::style::{Color, RED, WHITE};

/// One case's chart: a panel per measure, the measure against resolution (or the single run)
/// with the reference, its published range and the allowed band.
pub(super) struct CaseChart<'a> {
    pub(super) title: String,
    pub(super) measures: &'a [MeasureDef],
    pub(super) rows: &'a [Row],
}

/// Panel size, pixels.
const PANEL: (u32, u32) = (560, 420);
/// Panels per row of the chart.
const PANELS_PER_ROW: usize = 3;

/// Each panel's margin and label areas, pixels.
const FRAME: chart::Frame = chart::Frame {
    margin: 12,
    x_labels: 35,
    y_labels: 75,
};

/// The reference, its published range and the allowed band (green, [`chart::PALETTE`]'s third).
const BAND_COLOUR: plotters::style::RGBColor = chart::PALETTE[2];
/// Our values (blue, [`chart::PALETTE`]'s first; a failing point is red).
const OURS_COLOUR: plotters::style::RGBColor = chart::PALETTE[0];

/// One measure's rows, what they are judged against and the value axis's range.
struct MeasurePanel<'a> {
    /// The measure's rows, one per rung.
    rows: Vec<&'a Row>,
    /// The reference value.
    reference: f64,
    /// Its published range (both ends the reference when there is none).
    band: [f64; 2],
    /// The allowed error where judged (the first judged rung's tolerance), absolute.
    tol: Option<f64>,
    /// The value axis's range.
    y: (f64, f64),
}

impl<'a> MeasurePanel<'a> {
    /// The panel of `rows` (one measure's); None without rows.
    fn new(rows: Vec<&'a Row>) -> Option<Self> {
        let first = rows.first()?;
        let (reference, band) = (first.reference, first.band);
        let tol = rows.iter().find_map(|r| r.allowed).map(|(rel, abs)| {
            rel.map(|a| a * reference.abs())
                .unwrap_or(0.0)
                .max(abs.unwrap_or(0.0))
        });
        let mut lo = band[0].min(reference - tol.unwrap_or(0.0));
        let mut hi = band[1].max(reference + tol.unwrap_or(0.0));
        for r in rows.iter().filter(|r| r.ours.is_finite()) {
            lo = lo.min(r.ours);
            hi = hi.max(r.ours);
        }
        let pad = ((hi - lo) * 0.15).max(reference.abs() * 1e-3).max(1e-300);
        Some(MeasurePanel {
            rows,
            reference,
            band,
            tol,
            y: (lo - pad, hi + pad),
        })
    }
}

impl CaseChart<'_> {
    /// Measure `m`'s panel on `area`: its value at each rung against the reference, inside
    /// the allowed band and the published range; nothing when it has no rows.
    fn panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        m: &MeasureDef,
        text: bool,
    ) -> Result<(), String> {
        let rows: Vec<&Row> = self.rows.iter().filter(|r| r.measure == m.name).collect();
        let Some(p) = MeasurePanel::new(rows) else {
            return Ok(());
        };
        let ((lo, hi), reference) = (p.y, p.reference);
        let x1 = p.rows.len() as f64 - 0.5;
        let mut builder = chart::panel(area, FRAME, text);
        builder.caption(&m.name, ("sans-serif", 16));
        let mut ch = builder
            .build_cartesian_2d(-0.5..x1, lo..hi)
            .map_err(chart::err)?;
        let labels: Vec<String> = p.rows.iter().map(|r| r.rung.clone()).collect();
        let fmt_x = |x: &f64| {
            let k = x.round();
            if (x - k).abs() < 1e-6 && k >= 0.0 {
                labels.get(k as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart::axes(&mut ch, text, |mesh| {
            mesh.disable_x_mesh()
                .x_labels(p.rows.len() * 2 + 1)
                .x_label_formatter(&fmt_x)
                .light_line_style(WHITE)
                .y_desc(if m.unit.is_empty() {
                    m.axis()
                } else {
                    format!("{} ({})", m.axis(), m.unit)
                })
                .y_label_formatter(&|v: &f64| num(*v));
        })?;
        if let Some(t) = p.tol {
            ch.draw_series(std::iter::once(Rectangle::new(
                [(-0.5, reference - t), (x1, reference + t)],
                BAND_COLOUR.mix(0.15).filled(),
            )))
            .map_err(chart::err)?;
        }
        if p.band[0] != p.band[1] {
            ch.draw_series(std::iter::once(Rectangle::new(
                [(-0.5, p.band[0]), (x1, p.band[1])],
                BAND_COLOUR.mix(0.35).filled(),
            )))
            .map_err(chart::err)?;
        }
        ch.draw_series(LineSeries::new(
            [(-0.5, reference), (x1, reference)],
            BAND_COLOUR.stroke_width(2),
        ))
        .map_err(chart::err)?;
        ours(&mut ch, &p.rows)?;
        if text {
            let note = match p.tol {
                Some(_) => "green: reference, light band: allowed; red point: fails",
                None => "green: reference",
            };
            chart::note(&mut ch, note, (-0.45, hi - 0.04 * (hi - lo)), 12)?;
        }
        Ok(())
    }
}

/// Our value at each rung of `rows` (x = the rung's index): a line through the measured ones,
/// a point each, red where it fails.
fn ours<DB: DrawingBackend>(
    ch: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    rows: &[&Row],
) -> Result<(), String> {
    let pts: Vec<(f64, f64, bool)> = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.ours.is_finite())
        .map(|(k, r)| (k as f64, r.ours, r.failed()))
        .collect();
    ch.draw_series(LineSeries::new(
        pts.iter().map(|p| (p.0, p.1)),
        OURS_COLOUR.stroke_width(2),
    ))
    .map_err(chart::err)?;
    ch.draw_series(pts.iter().map(|p| {
        let c = if p.2 { RED } else { OURS_COLOUR };
        Circle::new((p.0, p.1), 5, c.filled())
    }))
    .map_err(chart::err)?;
    Ok(())
}

impl Figure for CaseChart<'_> {
    fn size(&self) -> (u32, u32) {
        let n = self.measures.len().max(1);
        let cols = n.min(PANELS_PER_ROW) as u32;
        let lines = n.div_ceil(PANELS_PER_ROW) as u32;
        (PANEL.0 * cols, PANEL.1 * lines + 40)
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let (root, text) = chart::canvas(root, &self.title)?;
        let n = self.measures.len().max(1);
        let panels = root.split_evenly((n.div_ceil(PANELS_PER_ROW), n.min(PANELS_PER_ROW)));
        for (area, m) in panels.iter().zip(self.measures) {
            self.panel(area, m, text)?;
        }
        root.present().map_err(chart::err)?;
        Ok(())
    }
}
