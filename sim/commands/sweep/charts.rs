//! The sweep's charts, drawn on the crate's small canvas: summary.png (coverage and PSNR per
//! planner, a point per episode coloured by world, the mean as a bar) and
//! coverage_over_time.png (a panel per planner, a line per episode).

use super::results::{first_seen, Row};
use crate::canvas::Canvas;
use crate::error::Result;
use std::path::Path;

const INK: [u8; 3] = [20, 20, 30];
const GRID: [u8; 3] = [225, 225, 230];
/// World colours, in the order worlds first appear.
const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

/// A plotting area on the canvas and the value ranges it shows.
struct Panel {
    left: f64,
    top: f64,
    width: f64,
    height: f64,
    x: (f64, f64),
    y: (f64, f64),
}

impl Panel {
    fn px(&self, x: f64) -> f64 {
        self.left + (x - self.x.0) / (self.x.1 - self.x.0) * self.width
    }

    fn py(&self, y: f64) -> f64 {
        self.top + self.height - (y - self.y.0) / (self.y.1 - self.y.0) * self.height
    }

    /// The frame, horizontal grid lines at the y ticks with their labels, and the title.
    fn frame(&self, canvas: &mut Canvas, title: &str) {
        for tick in ticks(self.y.0, self.y.1) {
            let y = self.py(tick);
            canvas.line((self.left, y), (self.left + self.width, y), 0.5, GRID);
            let label = label(tick);
            canvas.text(
                (self.left as usize).saturating_sub(8 * label.len() + 6),
                (y as usize).saturating_sub(4),
                &label,
                INK,
            );
        }
        let (l, t, r, b) = (
            self.left,
            self.top,
            self.left + self.width,
            self.top + self.height,
        );
        for (a, z) in [
            ((l, t), (r, t)),
            ((r, t), (r, b)),
            ((r, b), (l, b)),
            ((l, b), (l, t)),
        ] {
            canvas.line(a, z, 0.5, INK);
        }
        canvas.text(l as usize, (t as usize).saturating_sub(16), title, INK);
    }

    /// Labels under the x axis at its ticks.
    fn x_ticks(&self, canvas: &mut Canvas) {
        let bottom = self.top + self.height;
        for tick in ticks(self.x.0, self.x.1) {
            let x = self.px(tick);
            canvas.line((x, bottom), (x, bottom + 4.0), 0.5, INK);
            let label = label(tick);
            canvas.text(
                (x as usize).saturating_sub(4 * label.len()),
                bottom as usize + 8,
                &label,
                INK,
            );
        }
    }
}

/// About five round tick values covering [lo, hi].
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-9);
    let raw = span / 5.0;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * span {
        out.push(t);
        t += step;
    }
    out
}

fn label(v: f64) -> String {
    if v.fract().abs() < 1e-9 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

/// A value range with a margin; a flat range is widened.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.1).max(0.5);
    (lo - pad, hi + pad)
}

/// A row of world swatches with their names, from (x, y); returns the height used.
fn legend(canvas: &mut Canvas, x: usize, y: usize, worlds: &[&str]) -> usize {
    let (mut cx, mut cy) = (x, y);
    for (k, w) in worlds.iter().enumerate() {
        let width = 14 + 8 * w.len() + 14;
        if cx + width > canvas.width {
            cx = x;
            cy += 16;
        }
        canvas.swatch(cx, cy, PALETTE[k % PALETTE.len()]);
        canvas.text(cx + 14, cy + 1, w, INK);
        cx += width;
    }
    cy + 16 - y
}

/// summary.png: coverage and PSNR per planner, a point per complete episode.
pub fn write_summary_png(path: &Path, rows: &[Row]) -> Result<()> {
    let complete: Vec<&Row> = rows.iter().filter(|r| r.status == "complete").collect();
    let planners = first_seen(rows.iter().map(|r| r.planner.as_str()));
    let worlds = first_seen(rows.iter().map(|r| r.world.as_str()));
    let panel_width = (90 * planners.len()).max(240) as f64;
    let (panel_height, margin_left, margin_top) = (260.0, 60.0, 40.0);
    let width = (2.0 * (panel_width + margin_left) + 30.0) as usize;
    let legend_rows = 1 + worlds.iter().map(|w| 28 + 8 * w.len()).sum::<usize>() / width;
    let height = (margin_top + panel_height + 40.0) as usize + 16 * legend_rows + 16;
    let mut canvas = Canvas::blank(width, height);
    for (k, (column, title, scale)) in [
        ("evaluation.coverage", "coverage %", 100.0),
        ("evaluation.psnr", "PSNR dB", 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let values: Vec<f64> = complete
            .iter()
            .filter_map(|r| r.number(column))
            .map(|v| scale * v)
            .collect();
        let panel = Panel {
            left: margin_left + k as f64 * (panel_width + margin_left + 10.0),
            top: margin_top,
            width: panel_width,
            height: panel_height,
            x: (0.0, planners.len().max(1) as f64),
            y: range(values.iter().copied()),
        };
        panel.frame(&mut canvas, title);
        for (c, planner) in planners.iter().enumerate() {
            let centre = panel.px(c as f64 + 0.5);
            let name = &planner[..planner.len().min(10)];
            canvas.text(
                (centre as usize).saturating_sub(4 * name.len()),
                (panel.top + panel.height) as usize + 8,
                name,
                INK,
            );
            let group: Vec<(f64, &Row)> = complete
                .iter()
                .filter(|r| r.planner == *planner)
                .filter_map(|r| Some((scale * r.number(column)?, *r)))
                .collect();
            let m = group.len();
            for (j, (v, row)) in group.iter().enumerate() {
                let offset =
                    (j as f64 - (m as f64 - 1.0) / 2.0) * (40.0 / m.max(1) as f64).min(8.0);
                let colour = worlds.iter().position(|w| *w == row.world).unwrap_or(0);
                canvas.disc(
                    centre + offset,
                    panel.py(*v),
                    3.0,
                    PALETTE[colour % PALETTE.len()],
                );
            }
            if m > 0 {
                let mean = group.iter().map(|(v, _)| v).sum::<f64>() / m as f64;
                let y = panel.py(mean);
                canvas.line((centre - 18.0, y), (centre + 18.0, y), 1.0, INK);
            }
        }
    }
    canvas.text(
        6,
        6,
        "per planner: a point per episode (colour: world), bar: mean",
        INK,
    );
    legend(
        &mut canvas,
        (margin_left) as usize,
        (margin_top + panel_height + 36.0) as usize,
        &worlds,
    );
    canvas.write_png(path)
}

/// coverage_over_time.png: a panel per planner, coverage against simulated seconds, a line
/// per complete episode coloured by world.
pub fn write_coverage_png(path: &Path, rows: &[Row]) -> Result<()> {
    let planners = first_seen(rows.iter().map(|r| r.planner.as_str()));
    let worlds = first_seen(rows.iter().map(|r| r.world.as_str()));
    let columns = planners.len().clamp(1, 2);
    let panels_down = planners.len().div_ceil(columns).max(1);
    let (pw, ph, margin_left, margin_top, gap) = (340.0, 200.0, 50.0, 44.0, 50.0);
    let width = (columns as f64 * (pw + margin_left + 20.0) + 20.0) as usize;
    let legend_rows = 1 + worlds.iter().map(|w| 28 + 8 * w.len()).sum::<usize>() / width;
    let height = (margin_top + panels_down as f64 * (ph + gap)) as usize + 16 * legend_rows + 16;
    let mut canvas = Canvas::blank(width, height);
    let t_max = rows
        .iter()
        .flat_map(|r| r.coverage_over_time.iter().map(|p| p[0]))
        .fold(1.0, f64::max);
    for (k, planner) in planners.iter().enumerate() {
        let panel = Panel {
            left: margin_left + (k % columns) as f64 * (pw + margin_left + 20.0),
            top: margin_top + (k / columns) as f64 * (ph + gap),
            width: pw,
            height: ph,
            x: (0.0, t_max),
            y: (0.0, 100.0),
        };
        panel.frame(&mut canvas, &format!("{planner}: coverage % over sim s"));
        panel.x_ticks(&mut canvas);
        for row in rows.iter().filter(|r| r.planner == *planner) {
            let colour = worlds.iter().position(|w| *w == row.world).unwrap_or(0);
            let points: Vec<(f64, f64)> = row
                .coverage_over_time
                .iter()
                .map(|p| (panel.px(p[0]), panel.py(100.0 * p[1])))
                .collect();
            for pair in points.windows(2) {
                canvas.line(pair[0], pair[1], 1.0, PALETTE[colour % PALETTE.len()]);
            }
            if let Some(last) = points.last() {
                canvas.disc(last.0, last.1, 2.5, PALETTE[colour % PALETTE.len()]);
            }
        }
    }
    canvas.text(
        6,
        6,
        "coverage of the hidden test set over each episode (colour: world)",
        INK,
    );
    legend(
        &mut canvas,
        margin_left as usize,
        (margin_top + panels_down as f64 * (ph + gap)) as usize - 10,
        &worlds,
    );
    canvas.write_png(path)
}
