//! SVG plots of a diagnosis: measured against model before and after, residual spectra
//! before and after.

use crate::calibrate::{self, Data};
use crate::error::HostError;
use crate::residual;
use geared_servo::ActuatorParams;
use plotters::prelude::*;
use std::path::Path;

fn err<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> HostError + '_ {
    move |e| HostError::other(format!("{}: plot failed: {e}", path.display()))
}

fn decimate(x: &[f64], h: f64, max_points: usize) -> Vec<(f64, f64)> {
    let step = x.len().div_ceil(max_points.max(1)).max(1);
    x.iter()
        .enumerate()
        .step_by(step)
        .map(|(k, v)| (k as f64 * h, *v))
        .collect()
}

/// Measured output and the model's before (`before`) and after (`after`) calibration.
pub fn time_series(
    path: &Path,
    d: &Data,
    before: &ActuatorParams,
    after: &ActuatorParams,
) -> Result<(), HostError> {
    let h = d.sample_period_s;
    let yb = calibrate::simulate(before, d)
        .map(|t| t.y)
        .unwrap_or_default();
    let ya = calibrate::simulate(after, d)
        .map(|t| t.y)
        .unwrap_or_default();
    let all = d.y.iter().chain(&yb).chain(&ya);
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(*v), b.max(*v))
    });
    let pad = 0.05 * (hi - lo).max(1e-9);
    let t_end = d.y.len() as f64 * h;
    let root = SVGBackend::new(path, (1100, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(err(path))?;
    let mut ch = ChartBuilder::on(&root)
        .caption("measured and model output", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))
        .map_err(err(path))?;
    ch.configure_mesh()
        .x_desc("time (s)")
        .y_desc(format!("{} ({})", d.first_name(), unit_of(&d.output)))
        .draw()
        .map_err(err(path))?;
    let series: [(&[f64], &str, RGBColor); 3] = [
        (&d.y, "measured", BLACK),
        (&yb, "model before (file parameters)", RED),
        (&ya, "model after (calibrated, effects added)", BLUE),
    ];
    for (y, label, c) in series {
        ch.draw_series(LineSeries::new(decimate(y, h, 4000), &c))
            .map_err(err(path))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
    }
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err(path))?;
    root.present().map_err(err(path))
}

fn unit_of(output: &str) -> &'static str {
    crate::simulate::column(output).map_or("", |c| c.unit)
}

/// Welch spectra of the residual before and after, dB (relative to 1 unit²).
pub fn residual_spectra(
    path: &Path,
    d: &Data,
    before: &ActuatorParams,
    after: &ActuatorParams,
) -> Result<(), HostError> {
    let h = d.sample_period_s;
    let spec = |p: &ActuatorParams| {
        let t = calibrate::simulate(p, d).map(|t| t.y).unwrap_or_default();
        let e: Vec<f64> = d.y.iter().zip(&t).map(|(a, b)| a - b).collect();
        let (f, pw) = residual::spectrum(&e, h);
        f.into_iter()
            .zip(pw)
            .skip(1)
            .map(|(f, p)| (f, 10.0 * p.max(1e-30).log10()))
            .collect::<Vec<_>>()
    };
    let b = spec(before);
    let a = spec(after);
    let (lo, hi) = b
        .iter()
        .chain(&a)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), (_, v)| {
            (l.min(*v), u.max(*v))
        });
    let fmax = 0.5 / h;
    let root = SVGBackend::new(path, (1100, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(err(path))?;
    let mut ch = ChartBuilder::on(&root)
        .caption("residual power spectrum (Welch, Hann)", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..fmax, (lo - 5.0)..(hi + 5.0))
        .map_err(err(path))?;
    ch.configure_mesh()
        .x_desc("frequency (Hz)")
        .y_desc(format!("power (dB re 1 {}^2)", unit_of(&d.output)))
        .draw()
        .map_err(err(path))?;
    for (s, label, c) in [(b, "before (file parameters)", RED), (a, "after", BLUE)] {
        ch.draw_series(LineSeries::new(s, &c))
            .map_err(err(path))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
    }
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err(path))?;
    root.present().map_err(err(path))
}
