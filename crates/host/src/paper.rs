//! `paper --out DIR`: regenerates the paper's Fig. 3–6 from simulated stepped-sine responses
//! of the parameter set (CSV + SVG), and the design points of section III.C.
//!
//! Every number comes from [`crate::fr`]: f_AR is the refined minimum of |V_t/V_m|,
//! f_R the refined minimum of |I/V_m| above it (the pole of `Ωm/T_m`, eq. 17b in the linear
//! case), each with the band of frequencies whose value is within two block spreads of the
//! extremum. The describing-function prediction ([`geared_servo::describing`]) is drawn beside them.
//! Where a feature has no answer ([`crate::no_answer`]) its CSV fields are empty, the JSON
//! has null with the reason, and the plots leave the point out.

use crate::design;
use crate::error::HostError;
use crate::fr::{self, Bench, Drives, LocateOptions, Located, Point, SweepOptions};
use crate::no_answer::{add_reason, Answer};
use crate::progress::Progress;
use geared_servo::describing::{self, DfPrediction};
use geared_servo::ActuatorParams;
use rayon::prelude::*;
use serde_json::{json, Value};
use std::sync::Arc;

/// Iso-f_AR levels of Fig. 6 (contours in the CSV and on the plot) besides the bandwidth, Hz.
pub const FIG6_LEVELS: [f64; 5] = [80.0, 90.0, 100.0, 110.0, 120.0];
/// Fig. 3: voltage amplitudes, V.
pub const FIG3_VPK: [f64; 2] = [10.0, 17.9];
/// Fig. 3: total backlash values, deg.
pub const FIG3_BACKLASH_DEG: [f64; 4] = [0.0, 0.02, 0.04, 0.08];
/// Fig. 4: backlash, deg (the paper's).
pub const FIG4_BACKLASH_DEG: f64 = 0.08;
/// Fig. 5: voltage amplitudes, V.
pub const FIG5_VPK: [f64; 2] = [10.0, 17.9];
/// Fig. 6: voltage amplitudes of the map's rows, V.
pub const FIG6_VPK: [f64; 15] = [
    5.0, 7.5, 10.0, 12.5, 15.0, 17.9, 20.0, 25.0, 30.0, 35.0, 40.0, 50.0, 60.0, 80.0, 100.0,
];
/// Backlash grid of Fig. 5 and Fig. 6: 0 to 0.16° in 0.01° steps.
pub fn backlash_grid() -> Vec<f64> {
    (0..=16).map(|i| f64::from(i) * 0.01).collect()
}
/// Fig. 4 voltages: 24 log-spaced amplitudes from 3 to 1000 V plus 10, 17.9 and 30 V.
pub fn fig4_vpk() -> Vec<f64> {
    let mut v: Vec<f64> = (0..24)
        .map(|i| 3.0 * (1000.0f64 / 3.0).powf(f64::from(i) / 23.0))
        .chain([10.0, 17.9, 30.0])
        .collect();
    v.sort_by(f64::total_cmp);
    v
}

/// The paper's quoted design points (section III.C): (V_pk, largest backlash in deg) for a
/// 100 Hz bandwidth.
pub const PAPER_DESIGN_POINTS: [(f64, f64); 2] = [(10.0, 0.03), (30.0, 0.08)];

/// One simulated Bode curve.
pub struct BodeCurve {
    /// Voltage amplitude, V.
    pub vpk: f64,
    /// Total backlash, deg.
    pub backlash_deg: f64,
    /// The points (10–300 Hz, 1 Hz).
    pub points: Vec<Point>,
}

/// f_AR, f_R located at one (voltage, backlash), with the DF prediction.
#[derive(Clone, Debug)]
pub struct FeatureRow {
    /// Voltage amplitude, V.
    pub vpk: f64,
    /// Total backlash, deg.
    pub backlash_deg: f64,
    /// Anti-resonance.
    pub ar: Answer<Located>,
    /// Resonance (minimum of |I/V_m| above f_AR), each frequency started on the linearised
    /// steady state; its band is widened to cover `r_cold`. `None` where not searched (Fig. 6).
    pub r: Option<Answer<Located>>,
    /// The same started from rest, when resolved: with backlash the response is multivalued
    /// near the resonance (softening jump) and the start picks the branch.
    pub r_cold: Option<Located>,
    /// Describing-function prediction.
    pub df: DfPrediction,
}

/// Fig. 6: f_AR over backlash (columns) × voltage (rows).
pub struct Map {
    /// Backlash values, deg.
    pub backlash_deg: Vec<f64>,
    /// Voltage amplitudes, V.
    pub vpk: Vec<f64>,
    /// f_AR\[row\]\[column\], Hz; `None` where the response has no resolvable
    /// anti-resonance.
    pub f_ar_hz: Vec<Vec<Option<f64>>>,
}

impl Map {
    /// Per row, the backlash (deg) where f_AR first falls to `level_hz` (linear interpolation
    /// between grid columns, both with an answer); None when the row never reaches it on the
    /// grid.
    pub fn contour(&self, level_hz: f64) -> Vec<(f64, Option<f64>)> {
        self.vpk
            .iter()
            .zip(self.f_ar_hz.iter())
            .map(|(&v, row)| {
                let cross = row
                    .iter()
                    .zip(row.iter().skip(1))
                    .zip(
                        self.backlash_deg
                            .iter()
                            .zip(self.backlash_deg.iter().skip(1)),
                    )
                    .find_map(|((&f0, &f1), (&b0, &b1))| {
                        let (f0, f1) = (f0?, f1?);
                        (f0 >= level_hz && f1 < level_hz)
                            .then(|| b0 + (b1 - b0) * (f0 - level_hz) / (f0 - f1))
                    });
                (v, cross)
            })
            .collect()
    }
}

/// A design point found by bisection on the simulated f_AR.
#[derive(Clone, Debug)]
pub struct DesignPoint {
    /// Voltage amplitude, V.
    pub vpk: f64,
    /// Largest backlash keeping f_AR ≥ the bandwidth, deg, or why there is none.
    pub max_backlash_deg: Answer<f64>,
    /// The paper's value, deg.
    pub paper_deg: f64,
}

/// Everything `paper` computes.
pub struct PaperData {
    /// Bandwidth of Fig. 6's contour and of the design points, Hz.
    pub bandwidth_hz: f64,
    /// Closed-form (f_AR, f_R) without backlash, Hz.
    pub closed_form: (f64, f64),
    /// Fig. 3.
    pub bode: Vec<BodeCurve>,
    /// Fig. 4.
    pub fig4: Vec<FeatureRow>,
    /// Fig. 5.
    pub fig5: Vec<FeatureRow>,
    /// Fig. 6.
    pub map: Map,
    /// Design points.
    pub design: Vec<DesignPoint>,
}

fn feature_row(
    drives: &Arc<Drives>,
    params: &ActuatorParams,
    vpk: f64,
    backlash_deg: f64,
    with_r: bool,
) -> Result<FeatureRow, HostError> {
    let p = params.with_backlash_deg(backlash_deg);
    let bench = Bench::with_drives(
        &p,
        SweepOptions {
            vpk,
            ..SweepOptions::default()
        },
        Arc::clone(drives),
    )?;
    let lo = LocateOptions {
        to_hz: if with_r {
            300.0
        } else {
            design::f_ar_top_hz(&p)?
        },
        resonance: with_r,
        ..LocateOptions::default()
    };
    let (r, _) = fr::locate(&bench, &lo, &())?;
    let mut res = r.resonance;
    let mut r_cold = None;
    if with_r && backlash_deg > 0.0 {
        let cold = Bench::with_drives(
            &p,
            SweepOptions {
                vpk,
                warm_start: false,
                ..SweepOptions::default()
            },
            Arc::clone(drives),
        )?;
        r_cold = fr::locate(&cold, &lo, &())?
            .0
            .resonance
            .and_then(Result::ok);
        if let (Some(Ok(w)), Some(c)) = (res.as_mut(), r_cold) {
            w.band_hz.0 = w.band_hz.0.min(c.band_hz.0);
            w.band_hz.1 = w.band_hz.1.max(c.band_hz.1);
            w.settled &= c.settled;
        }
    }
    let df = describing::predict(&p, vpk).map_err(HostError::from)?;
    Ok(FeatureRow {
        vpk,
        backlash_deg,
        ar: r.anti_resonance,
        r: res,
        r_cold,
        df,
    })
}

fn rows(
    drives: &Arc<Drives>,
    params: &ActuatorParams,
    cases: &[(f64, f64)],
    with_r: bool,
    pb: &dyn Progress,
) -> Result<Vec<FeatureRow>, HostError> {
    cases
        .par_iter()
        .map(|&(v, b)| {
            let r = feature_row(drives, params, v, b, with_r);
            pb.advance(1);
            r
        })
        .collect()
}

/// Computes every figure's data for `params` (its backlash is overridden per figure).
pub fn compute(
    params: &ActuatorParams,
    bandwidth_hz: f64,
    pb: &dyn Progress,
) -> Result<PaperData, HostError> {
    let d = params.derived().map_err(HostError::from)?;
    let bgrid = backlash_grid();
    let freqs = fr::grid(10.0, 300.0, 1.0)?;
    // One set of sine drives for every figure: they revisit the same frequencies for many
    // backlash values and voltages.
    let drives = Drives::shared();

    pb.stage("fig 3");
    let bode_cases: Vec<(f64, f64)> = FIG3_VPK
        .iter()
        .flat_map(|&v| FIG3_BACKLASH_DEG.iter().map(move |&b| (v, b)))
        .collect();
    let bode = bode_cases
        .par_iter()
        .map(|&(vpk, b)| {
            let bench = Bench::with_drives(
                &params.with_backlash_deg(b),
                SweepOptions {
                    vpk,
                    ..SweepOptions::default()
                },
                Arc::clone(&drives),
            )?;
            let points = bench.sweep(&freqs, &())?;
            pb.advance(1);
            Ok(BodeCurve {
                vpk,
                backlash_deg: b,
                points,
            })
        })
        .collect::<Result<Vec<_>, HostError>>()?;

    pb.stage("fig 4");
    let c4: Vec<(f64, f64)> = fig4_vpk()
        .into_iter()
        .map(|v| (v, FIG4_BACKLASH_DEG))
        .collect();
    let fig4 = rows(&drives, params, &c4, true, pb)?;

    pb.stage("fig 5");
    let c5: Vec<(f64, f64)> = FIG5_VPK
        .iter()
        .flat_map(|&v| bgrid.iter().map(move |&b| (v, b)))
        .collect();
    let fig5 = rows(&drives, params, &c5, true, pb)?;

    pb.stage("fig 6");
    let c6: Vec<(f64, f64)> = FIG6_VPK
        .iter()
        .flat_map(|&v| bgrid.iter().map(move |&b| (v, b)))
        .collect();
    let cells = rows(&drives, params, &c6, false, pb)?;
    let map = Map {
        backlash_deg: bgrid.clone(),
        vpk: FIG6_VPK.to_vec(),
        f_ar_hz: cells
            .chunks(bgrid.len())
            .map(|r| {
                r.iter()
                    .map(|c| c.ar.as_ref().ok().map(|l| l.freq_hz))
                    .collect()
            })
            .collect(),
    };

    pb.stage("design");
    let design = PAPER_DESIGN_POINTS
        .par_iter()
        .map(|&(vpk, paper_deg)| {
            let r = design::max_backlash(
                params,
                bandwidth_hz,
                SweepOptions {
                    vpk,
                    ..SweepOptions::default()
                },
                0.001,
            )?;
            pb.advance(1);
            Ok(DesignPoint {
                vpk,
                max_backlash_deg: r.value,
                paper_deg,
            })
        })
        .collect::<Result<Vec<_>, HostError>>()?;
    Ok(PaperData {
        bandwidth_hz,
        closed_form: (d.f_ar_hz, d.f_r_hz),
        bode,
        fig4,
        fig5,
        map,
        design,
    })
}

/// Jobs [`compute`] ticks the progress bar for.
pub fn job_count() -> u64 {
    (FIG3_VPK.len() * FIG3_BACKLASH_DEG.len()
        + fig4_vpk().len()
        + (FIG5_VPK.len() + FIG6_VPK.len()) * backlash_grid().len()
        + PAPER_DESIGN_POINTS.len()) as u64
}

/// The resolved resonance of a row, if any.
pub(crate) fn resolved_r(r: &FeatureRow) -> Option<Located> {
    r.r.as_ref().and_then(|x| x.as_ref().ok()).copied()
}

/// The design-point table and the figures' key numbers, as text and as JSON.
pub fn summary(data: &PaperData) -> (String, Value) {
    let mut t = format!(
        "Design points (bandwidth = f_AR >= {} Hz; bisection on simulated f_AR to 0.001 deg)\n\
         | V_pk | max backlash (simulated) | paper |\n|---:|---:|---:|\n",
        data.bandwidth_hz
    );
    // Reasons for the cells that have no answer, listed under their table.
    let mut notes = Vec::new();
    // The paper quotes its design points for 100 Hz only.
    let paper_bw = (data.bandwidth_hz - 100.0).abs() < 1e-9;
    for d in &data.design {
        let paper = if paper_bw {
            format!("{:.2} deg", d.paper_deg)
        } else {
            "– (quoted for 100 Hz)".to_string()
        };
        let sim = match &d.max_backlash_deg {
            Ok(b) => format!("{b:.3} deg"),
            Err(na) => {
                notes.push(format!("- {} V_pk: {}", d.vpk, na.reason));
                "no answer".to_string()
            }
        };
        t.push_str(&format!("| {:.1} | {sim} | {paper} |\n", d.vpk));
    }
    push_notes(&mut t, &mut notes);
    t.push_str(&format!(
        "\nf_AR / f_R located on the simulated response (Hz; closed form without backlash: {:.3} / {:.3})\n\
         | V_pk | backlash (deg) | f_AR | f_AR band | f_R | f_R band | DF f_AR | DF f_R |\n\
         |---:|---:|---:|---|---:|---|---:|---:|\n",
        data.closed_form.0, data.closed_form.1
    ));
    let pick = data.fig5.iter().filter(|r| {
        FIG3_BACKLASH_DEG
            .iter()
            .any(|b| (b - r.backlash_deg).abs() < 1e-9)
    });
    for r in pick {
        let mut cell = |l: Option<&Answer<Located>>, what: &str| match l {
            Some(Ok(l)) => (
                format!("{:.2}", l.freq_hz),
                format!("{:.1}–{:.1}", l.band_hz.0, l.band_hz.1),
            ),
            Some(Err(na)) => {
                notes.push(format!(
                    "- {} V_pk, {} deg, {what}: {}",
                    r.vpk, r.backlash_deg, na.reason
                ));
                ("–".into(), "–".into())
            }
            None => ("–".into(), "–".into()),
        };
        let (far, far_band) = cell(Some(&r.ar), "f_AR");
        let (fr, band) = cell(r.r.as_ref(), "f_R");
        t.push_str(&format!(
            "| {:.1} | {:.2} | {far} | {far_band} | {fr} | {band} | {:.2} | {:.2} |\n",
            r.vpk, r.backlash_deg, r.df.anti_resonance.freq_hz, r.df.resonance.freq_hz
        ));
    }
    push_notes(&mut t, &mut notes);
    let feature_json = |r: &FeatureRow| {
        let mut o = json!({
            "vpk": r.vpk, "backlash_deg": r.backlash_deg,
            "f_ar_hz": r.ar.as_ref().ok().map(|x| x.freq_hz),
            "f_r_hz": resolved_r(r).map(|x| x.freq_hz),
            "df_f_ar_hz": r.df.anti_resonance.freq_hz, "df_f_r_hz": r.df.resonance.freq_hz});
        add_reason(&mut o, "f_ar", &r.ar);
        if let Some(a) = &r.r {
            add_reason(&mut o, "f_r", a);
        }
        o
    };
    let json = json!({
        "bandwidth_hz": data.bandwidth_hz,
        "closed_form": {"f_ar_hz": data.closed_form.0, "f_r_hz": data.closed_form.1},
        "design_points": data.design.iter().map(|d| {
            let mut o = json!({"vpk": d.vpk, "max_backlash_deg": d.max_backlash_deg.as_ref().ok(),
                               "paper_deg": d.paper_deg});
            add_reason(&mut o, "max_backlash", &d.max_backlash_deg);
            o
        }).collect::<Vec<_>>(),
        "fig4": data.fig4.iter().map(feature_json).collect::<Vec<_>>(),
        "fig5": data.fig5.iter().map(feature_json).collect::<Vec<_>>(),
    });
    (t, json)
}

/// Appends the collected reasons (if any) under a table, and empties the list.
fn push_notes(t: &mut String, notes: &mut Vec<String>) {
    if !notes.is_empty() {
        t.push_str("\nNo answer:\n");
        for n in notes.drain(..) {
            t.push_str(&n);
            t.push('\n');
        }
    }
}
