//! SVG plots of `paper` (plotters, SVG backend): Fig. 3 Bode, Fig. 4 f vs voltage, Fig. 5
//! f vs backlash, Fig. 6 f_AR map with iso-f_AR contours and the design points.

use crate::error::HostError;
use crate::fr::Located;
use crate::paper::{FeatureRow, PaperData, FIG6_LEVELS};
use plotters::coord::Shift;
use plotters::prelude::*;

const SERIES: [RGBColor; 5] = [
    RGBColor(0, 0, 0),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
];
const AR_COLOR: RGBColor = RGBColor(31, 119, 180);
const R_COLOR: RGBColor = RGBColor(214, 39, 40);
const GREY: RGBColor = RGBColor(120, 120, 120);

fn err<E: std::fmt::Debug>(e: E) -> HostError {
    HostError::other(format!("plot: {e:?}"))
}

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

fn render(
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), HostError>,
) -> Result<String, HostError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// All figures: (file name, SVG text).
pub fn all(d: &PaperData) -> Result<Vec<(&'static str, String)>, HostError> {
    Ok(vec![
        ("fig3_bode.svg", fig3(d)?),
        ("fig4_voltage.svg", fig4(d)?),
        ("fig5_backlash.svg", fig5(d)?),
        ("fig6_map.svg", fig6(d)?),
    ])
}

fn fig3(d: &PaperData) -> Result<String, HostError> {
    render((1300, 850), |root| {
        let (title, body) = root.split_vertically(40);
        title
            .titled(
                "Fig. 3  Stepped-sine Bode diagram of V_t/V_m (simulated, 10-300 Hz, 1 Hz steps)",
                ("sans-serif", 22),
            )
            .map_err(err)?;
        let cols = body.split_evenly((2, 2));
        let vs: Vec<f64> = {
            let mut v: Vec<f64> = d.bode.iter().map(|c| c.vpk).collect();
            v.dedup();
            v
        };
        for (ci, &v) in vs.iter().enumerate() {
            let curves: Vec<_> = d.bode.iter().filter(|c| c.vpk == v).collect();
            let label = ["(a)", "(b)"].get(ci).copied().unwrap_or("");
            for row in 0..2 {
                let Some(area) = cols.get(row * 2 + ci) else {
                    continue;
                };
                let (ylo, yhi, ydesc) = if row == 0 {
                    (-70.0, 10.0, "Gain |V_t/V_m| (dB)")
                } else {
                    (-180.0, 180.0, "Phase (deg)")
                };
                let mut ch = ChartBuilder::on(area)
                    .caption(
                        format!(
                            "{label} V_m = {v} V_pk: {}",
                            if row == 0 { "gain" } else { "phase" }
                        ),
                        ("sans-serif", 17),
                    )
                    .margin(8)
                    .x_label_area_size(40)
                    .y_label_area_size(60)
                    .build_cartesian_2d(10f64..300f64, ylo..yhi)
                    .map_err(err)?;
                ch.configure_mesh()
                    .x_desc("Frequency (Hz)")
                    .y_desc(ydesc)
                    .light_line_style(RGBColor(235, 235, 235))
                    .draw()
                    .map_err(err)?;
                for (k, c) in curves.iter().enumerate() {
                    let col = SERIES.get(k).copied().unwrap_or(BLACK);
                    let pts = c.points.iter().map(|p| {
                        let y = if row == 0 {
                            p.tach.gain_db().max(ylo)
                        } else {
                            p.tach.phase_deg()
                        };
                        (p.freq_hz, y)
                    });
                    let s = if row == 0 {
                        ch.draw_series(LineSeries::new(pts, col.stroke_width(2)))
                    } else {
                        ch.draw_series(
                            pts.map(|xy| Circle::new(xy, 1, col.filled()))
                                .collect::<Vec<_>>(),
                        )
                    }
                    .map_err(err)?;
                    s.label(format!("backlash {:.2} deg", c.backlash_deg))
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                        });
                }
                ch.configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .position(SeriesLabelPosition::LowerLeft)
                    .draw()
                    .map_err(err)?;
            }
        }
        Ok(())
    })
}

/// f_AR (`which` 0) or f_R of a row where it has an answer.
fn resolved(r: &FeatureRow, which: u8) -> Option<Located> {
    let l = if which == 0 {
        Some(&r.ar)
    } else {
        r.r.as_ref()
    };
    l.and_then(|l| l.as_ref().ok()).copied()
}

fn band_bars<'a>(
    rows: &'a [FeatureRow],
    x: impl Fn(&FeatureRow) -> f64 + 'a,
    which: u8,
    col: RGBColor,
) -> impl Iterator<Item = ErrorBar<f64, f64, plotters::element::ErrorBarOrientV<f64, f64>>> + 'a {
    rows.iter().filter_map(move |r| {
        let l = resolved(r, which)?;
        Some(ErrorBar::new_vertical(
            x(r),
            l.band_hz.0,
            l.freq_hz,
            l.band_hz.1,
            col.stroke_width(1),
            6,
        ))
    })
}

/// Draws f_AR, f_R (simulated, with bands) and the DF predictions of `rows` against `x`.
fn feature_chart<'a, 'b: 'a, X: Ranged<ValueType = f64>>(
    ch: &mut ChartContext<
        'a,
        SVGBackend<'b>,
        Cartesian2d<X, plotters::coord::types::RangedCoordf64>,
    >,
    rows: &[FeatureRow],
    x: impl Fn(&FeatureRow) -> f64 + Copy,
    closed: (f64, f64),
    x_range: (f64, f64),
) -> Result<(), HostError> {
    for (which, col, name) in [(0u8, AR_COLOR, "f_AR"), (1, R_COLOR, "f_R")] {
        let sim: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| {
                let l = resolved(r, which)?;
                Some((x(r), l.freq_hz))
            })
            .collect();
        ch.draw_series(band_bars(rows, x, which, col))
            .map_err(err)?;
        ch.draw_series(LineSeries::new(sim.clone(), col.stroke_width(2)))
            .map_err(err)?
            .label(format!("{name} simulated (bar: blur band)"))
            .legend(move |(a, b)| PathElement::new(vec![(a, b), (a + 20, b)], col.stroke_width(2)));
        ch.draw_series(sim.iter().map(|&p| Circle::new(p, 3, col.filled())))
            .map_err(err)?;
        let df: Vec<(f64, f64)> = rows
            .iter()
            .map(|r| {
                let f = if which == 0 {
                    r.df.anti_resonance.freq_hz
                } else {
                    r.df.resonance.freq_hz
                };
                (x(r), f)
            })
            .collect();
        ch.draw_series(DashedLineSeries::new(df, 8, 5, col.stroke_width(2)))
            .map_err(err)?
            .label(format!("{name} describing function (eq. 18-19)"))
            .legend(move |(a, b)| PathElement::new(vec![(a, b), (a + 8, b)], col.stroke_width(2)));
        let lim = if which == 0 { closed.0 } else { closed.1 };
        ch.draw_series(DashedLineSeries::new(
            vec![(x_range.0, lim), (x_range.1, lim)],
            3,
            4,
            GREY.stroke_width(1),
        ))
        .map_err(err)?
        .label(format!("{name} without backlash ({lim:.1} Hz, eq. 17)"))
        .legend(move |(a, b)| PathElement::new(vec![(a, b), (a + 20, b)], GREY.stroke_width(1)));
    }
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(err)
}

fn fig4(d: &PaperData) -> Result<String, HostError> {
    render((1100, 720), |root| {
        let (lo, hi) = d.fig4.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (a.min(r.vpk), b.max(r.vpk))
        });
        let b = d.fig4.first().map(|r| r.backlash_deg).unwrap_or(0.0);
        let mut ch = ChartBuilder::on(root)
            .caption(
                format!("Fig. 4  f_AR and f_R versus voltage amplitude (backlash {b} deg)"),
                ("sans-serif", 22),
            )
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d((lo..hi).log_scale(), 0f64..(d.closed_form.1 * 1.1))
            .map_err(err)?;
        ch.configure_mesh()
            .x_desc("Motor voltage amplitude V_m (V_pk, log scale)")
            .y_desc("Frequency (Hz)")
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(err)?;
        feature_chart(&mut ch, &d.fig4, |r| r.vpk, d.closed_form, (lo, hi))
    })
}

fn fig5(d: &PaperData) -> Result<String, HostError> {
    render((1300, 650), |root| {
        let (title, body) = root.split_vertically(40);
        title
            .titled(
                "Fig. 5  f_AR and f_R versus total backlash",
                ("sans-serif", 22),
            )
            .map_err(err)?;
        let panels = body.split_evenly((1, 2));
        // The paper's order: (a) 17.9 V, (b) 10 V.
        for (i, (v, label)) in [(17.9, "(a)"), (10.0, "(b)")].iter().enumerate() {
            let rows: Vec<FeatureRow> = d.fig5.iter().filter(|r| r.vpk == *v).cloned().collect();
            let bmax = rows.iter().map(|r| r.backlash_deg).fold(0.0, f64::max);
            let Some(area) = panels.get(i) else { continue };
            let mut ch = ChartBuilder::on(area)
                .caption(format!("{label} V_m = {v} V_pk"), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(45)
                .y_label_area_size(65)
                .build_cartesian_2d(0f64..bmax, 0f64..(d.closed_form.1 * 1.1))
                .map_err(err)?;
            ch.configure_mesh()
                .x_desc("Total backlash b_t (deg)")
                .y_desc("Frequency (Hz)")
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(err)?;
            feature_chart(
                &mut ch,
                &rows,
                |r| r.backlash_deg,
                d.closed_form,
                (0.0, bmax),
            )?;
        }
        Ok(())
    })
}

/// Viridis-like colour for t in [0, 1].
fn colour(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = t.clamp(0.0, 1.0) * 4.0;
    let i = (t.floor() as usize).min(3);
    let f = t - i as f64;
    let (a, b) = (
        STOPS.get(i).copied().unwrap_or((0.0, 0.0, 0.0)),
        STOPS.get(i + 1).copied().unwrap_or((255.0, 255.0, 255.0)),
    );
    let m = |x: f64, y: f64| (x + (y - x) * f).round() as u8;
    RGBColor(m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
}

fn fig6(d: &PaperData) -> Result<String, HostError> {
    render((1150, 760), |root| {
        let (main, bar) = root.split_horizontally(1010);
        let m = &d.map;
        let db = m.backlash_deg.get(1).copied().unwrap_or(0.01)
            - m.backlash_deg.first().copied().unwrap_or(0.0);
        let (bmin, bmax) = (
            m.backlash_deg.first().copied().unwrap_or(0.0) - db / 2.0,
            m.backlash_deg.last().copied().unwrap_or(0.16) + db / 2.0,
        );
        let (vlo, vhi) = (
            m.vpk.first().copied().unwrap_or(5.0),
            m.vpk.last().copied().unwrap_or(100.0),
        );
        let (flo, fhi) = (60.0, d.closed_form.0.ceil());
        let mut ch = ChartBuilder::on(&main)
            .caption(
                format!(
                    "Fig. 6  Simulated anti-resonance f_AR over backlash and voltage (contour: {} Hz bandwidth)",
                    d.bandwidth_hz
                ),
                ("sans-serif", 19),
            )
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(bmin..bmax, (vlo * 0.9..vhi * 1.1).log_scale())
            .map_err(err)?;
        ch.configure_mesh()
            .x_desc("Total backlash b_t (deg)")
            .y_desc("Motor voltage amplitude V_m (V_pk, log scale)")
            .disable_mesh()
            .draw()
            .map_err(err)?;
        // Cells: rows span halfway (geometrically) to their neighbours.
        let edges: Vec<f64> = {
            let mut e = vec![vlo * 0.9];
            e.extend(
                m.vpk
                    .iter()
                    .zip(m.vpk.iter().skip(1))
                    .map(|(a, b)| (a * b).sqrt()),
            );
            e.push(vhi * 1.1);
            e
        };
        for ((row, &v0), &v1) in m.f_ar_hz.iter().zip(edges.iter()).zip(edges.iter().skip(1)) {
            // Cells without an answer stay blank.
            let cells = row.iter().zip(m.backlash_deg.iter());
            ch.draw_series(cells.filter_map(|(&f, &b)| Some((f?, b))).map(|(f, b)| {
                Rectangle::new(
                    [(b - db / 2.0, v0), (b + db / 2.0, v1)],
                    colour((f - flo) / (fhi - flo)).filled(),
                )
            }))
            .map_err(err)?;
        }
        for level in FIG6_LEVELS
            .iter()
            .copied()
            .filter(|l| (l - d.bandwidth_hz).abs() > 1e-9)
            .chain([d.bandwidth_hz])
        {
            let main_level = (level - d.bandwidth_hz).abs() < 1e-9;
            let pts: Vec<(f64, f64)> = m
                .contour(level)
                .into_iter()
                .filter_map(|(v, b)| b.map(|b| (b, v)))
                .collect();
            let style = if main_level {
                RGBColor(255, 255, 255).stroke_width(4)
            } else {
                RGBColor(255, 255, 255).mix(0.6).stroke_width(1)
            };
            let s = ch
                .draw_series(LineSeries::new(pts.clone(), style))
                .map_err(err)?;
            if main_level {
                s.label(format!("f_AR = {level} Hz (bandwidth)"))
                    .legend(|(a, b)| {
                        PathElement::new(vec![(a, b), (a + 20, b)], BLACK.stroke_width(3))
                    });
            } else if let Some(&(b, v)) = pts.last() {
                ch.draw_series(std::iter::once(Text::new(
                    format!("{level:.0} Hz"),
                    (b, v),
                    ("sans-serif", 13).into_font().color(&WHITE),
                )))
                .map_err(err)?;
            }
        }
        let found: Vec<(f64, f64)> = d
            .design
            .iter()
            .filter_map(|p| Some((*p.max_backlash_deg.as_ref().ok()?, p.vpk)))
            .collect();
        ch.draw_series(
            found
                .iter()
                .map(|&p| TriangleMarker::new(p, 9, RGBColor(230, 30, 30).filled())),
        )
        .map_err(err)?
        .label("design point (bisection on simulated f_AR)")
        .legend(|(a, b)| TriangleMarker::new((a + 10, b), 7, RGBColor(230, 30, 30).filled()));
        // The paper quotes its design points for 100 Hz only.
        if (d.bandwidth_hz - 100.0).abs() < 1e-9 {
            ch.draw_series(
                d.design
                    .iter()
                    .map(|p| Cross::new((p.paper_deg, p.vpk), 8, BLACK.stroke_width(3))),
            )
            .map_err(err)?
            .label("paper's design point (0.03 deg @ 10 V, 0.08 deg @ 30 V)")
            .legend(|(a, b)| Cross::new((a + 10, b), 6, BLACK.stroke_width(2)));
        }
        for &(b, v) in &found {
            ch.draw_series(std::iter::once(Text::new(
                format!("{b:.3} deg @ {v} V"),
                (b + 0.004, v * 0.93),
                ("sans-serif", 14).into_font().color(&WHITE),
            )))
            .map_err(err)?;
        }
        ch.configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(err)?;
        // Colour bar.
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(60)
            .margin_bottom(65)
            .margin_right(10)
            .y_label_area_size(55)
            .caption("f_AR (Hz)", ("sans-serif", 14))
            .build_cartesian_2d(0f64..1f64, flo..fhi)
            .map_err(err)?;
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(8)
            .draw()
            .map_err(err)?;
        let n = 100;
        cb.draw_series((0..n).map(|i| {
            let f0 = flo + (fhi - flo) * f64::from(i) / f64::from(n);
            let f1 = flo + (fhi - flo) * f64::from(i + 1) / f64::from(n);
            Rectangle::new(
                [(0.0, f0), (1.0, f1)],
                colour((f0 - flo) / (fhi - flo)).filled(),
            )
        }))
        .map_err(err)?;
        Ok(())
    })
}
