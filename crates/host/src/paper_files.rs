//! The files `paper` writes: the figures' data as CSV, the contours of Fig. 6, the design
//! points, and the SVG plots.

use crate::error::HostError;
use crate::fr::spread_db;
use crate::paper::{resolved_r, FeatureRow, PaperData, FIG6_LEVELS};
use crate::plots;
use crate::record::write_file;
use std::path::{Path, PathBuf};

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.4}")).unwrap_or_default()
}

fn rows_csv(rows: &[FeatureRow]) -> String {
    let mut s = String::from(
        "vpk,backlash_deg,f_ar_hz,f_ar_band_lo_hz,f_ar_band_hi_hz,f_ar_settled,\
         f_r_hz,f_r_band_lo_hz,f_r_band_hi_hz,f_r_settled,f_r_from_rest_hz,df_f_ar_hz,df_f_r_hz,\
         df_twist_ar_rad,df_twist_r_rad\n",
    );
    for r in rows {
        let (ar, res) = (r.ar.as_ref().ok(), resolved_r(r));
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4},{:.6e},{:.6e}\n",
            r.vpk,
            r.backlash_deg,
            opt(ar.map(|x| x.freq_hz)),
            opt(ar.map(|x| x.band_hz.0)),
            opt(ar.map(|x| x.band_hz.1)),
            ar.map(|x| u8::from(x.settled).to_string())
                .unwrap_or_default(),
            opt(res.map(|x| x.freq_hz)),
            opt(res.map(|x| x.band_hz.0)),
            opt(res.map(|x| x.band_hz.1)),
            res.map(|x| u8::from(x.settled).to_string())
                .unwrap_or_default(),
            opt(r.r_cold.map(|x| x.freq_hz)),
            r.df.anti_resonance.freq_hz,
            r.df.resonance.freq_hz,
            r.df.anti_resonance.twist_amplitude_rad,
            r.df.resonance.twist_amplitude_rad
        ));
    }
    s
}

/// Writes the CSV files and the SVG plots into `out`; returns the files written.
pub fn write_all(data: &PaperData, out: &Path) -> Result<Vec<PathBuf>, HostError> {
    std::fs::create_dir_all(out)
        .map_err(|e| HostError::other(format!("{}: {e}", out.display())))?;
    let mut files = Vec::new();
    let mut put = |name: &str, text: String| -> Result<(), HostError> {
        let p = out.join(name);
        write_file(&p, &text)?;
        files.push(p);
        Ok(())
    };
    let mut s = String::from("vpk,backlash_deg,freq_hz,gain_db,phase_deg,gain_spread_db,settled\n");
    for c in &data.bode {
        for q in &c.points {
            s.push_str(&format!(
                "{},{},{},{:.6},{:.4},{:.6},{}\n",
                c.vpk,
                c.backlash_deg,
                q.freq_hz,
                q.tach.gain_db(),
                q.tach.phase_deg(),
                spread_db(q.tach.spread, q.gain()),
                u8::from(q.settled)
            ));
        }
    }
    put("fig3_bode.csv", s)?;
    put("fig4_voltage.csv", rows_csv(&data.fig4))?;
    put("fig5_backlash.csv", rows_csv(&data.fig5))?;
    let mut s = String::from("backlash_deg,vpk,f_ar_hz\n");
    for (v, row) in data.map.vpk.iter().zip(data.map.f_ar_hz.iter()) {
        for (b, f) in data.map.backlash_deg.iter().zip(row.iter()) {
            s.push_str(&format!("{b},{v},{}\n", opt(*f)));
        }
    }
    put("fig6_map.csv", s)?;
    let mut s = String::from("level_hz,vpk,backlash_deg\n");
    for level in FIG6_LEVELS {
        for (v, b) in data.map.contour(level) {
            if let Some(b) = b {
                s.push_str(&format!("{level},{v},{b:.5}\n"));
            }
        }
    }
    put("fig6_contours.csv", s)?;
    let mut s = String::from("bandwidth_hz,vpk,max_backlash_deg,paper_deg\n");
    for d in &data.design {
        s.push_str(&format!(
            "{},{},{},{}\n",
            data.bandwidth_hz,
            d.vpk,
            opt(d.max_backlash_deg.as_ref().ok().copied()),
            d.paper_deg
        ));
    }
    put("design_points.csv", s)?;
    for (name, svg) in plots::all(data)? {
        put(name, svg)?;
    }
    Ok(files)
}
