//! Measured-data records (CSV, INTERFACES.md "Measured data"): reading with errors that name
//! the line and the column, and writing in the same convention.
//!
//! Row k: the outputs were sampled at `time_s[k]`, then `motor_voltage_v[k]` was applied
//! until the next row. The first row's outputs are the initial state.
//!
//! # Time bases
//! A record whose intervals are all within [`UNIFORM_TOLERANCE`] of their mean is uniform and
//! read as it is. Logs from servo buses, USB and scopes jitter by several per cent: such a
//! record is resampled onto the uniform grid of its mean period (same first instant, same
//! number of rows), with one warning saying how much the instants departed from that grid and
//! what was done:
//! - the outputs are interpolated linearly between the samples around each grid instant
//!   (they are sampled values of continuous signals; the error is that of a chord over a
//!   fraction of a period, far below sensor noise at the rates records are taken);
//! - the voltage is the drive's zero-order hold (each row's command applies until the next
//!   row), so each grid period gets the mean of that held voltage over the period: the same
//!   volt-seconds as the drive applied, which is what the plant's held step integrates.
//!   Interpolating it linearly would turn a square wave's edges into ramps no drive makes.
//!
//! Time that does not increase is refused, and so is an interval longer than
//! [`MAX_INTERVAL_PERIODS`] typical (median) periods: samples are missing there, and no
//! interpolation can tell what the output did in the gap.

use crate::error::{shown, HostError};
use std::path::Path;

/// Output columns a record may carry (INTERFACES.md "Measured data"), in the order the fit
/// prefers them when a record has several (`calibrate::Data::from_record`): the
/// motor-side speed sensors, then the output shaft's encoder (its angle, then a speed derived
/// from it), then the current.
pub const OUTPUT_COLUMNS: [&str; 5] = [
    "tach_voltage_v",
    "motor_speed_rad_s",
    "load_angle_deg",
    "load_speed_rad_s",
    "current_a",
];

/// Intervals within this fraction of the mean period are uniform sampling (no resampling).
pub const UNIFORM_TOLERANCE: f64 = 0.01;

/// Longest interval between rows, in typical (median) periods; a longer one is a gap
/// (missing samples) and the record is refused.
pub const MAX_INTERVAL_PERIODS: f64 = 1.5;

/// A uniformly sampled record.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// `# key: value` comment lines before the header, in order.
    pub metadata: Vec<(String, String)>,
    /// Sample instants, s (uniform: a jittered record's are those of the grid it was
    /// resampled onto).
    pub time_s: Vec<f64>,
    /// Mean sample period, s.
    pub sample_period_s: f64,
    /// Voltage applied from each row to the next, V.
    pub motor_voltage_v: Vec<f64>,
    /// Output columns present, by name (see [`OUTPUT_COLUMNS`]), each as long as `time_s`.
    pub outputs: Vec<(String, Vec<f64>)>,
    /// Non-fatal remarks (ignored columns), for stderr.
    pub warnings: Vec<String>,
}

impl Record {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether the record has no rows.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// The output column `name`, if present.
    pub fn output(&self, name: &str) -> Option<&[f64]> {
        self.outputs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// Metadata value for `key`, if a `# key: value` line gave one.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// Reads a record from a file. With `require_output`, at least one output column must be
/// present (measured data); without it a voltage record is enough (`simulate`'s input).
pub fn read(path: &Path, require_output: bool) -> Result<Record, HostError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| HostError::input(format!("{name}: cannot read: {e}")))?;
    parse(&text, &name, require_output)
}

/// Parses a record's text; `name` is used in messages.
pub fn parse(text: &str, name: &str, require_output: bool) -> Result<Record, HostError> {
    // Leading comment lines, then the CSV proper.
    let mut metadata = Vec::new();
    let mut offset = 0usize;
    let mut skipped_lines = 0usize;
    for line in text.split_inclusive('\n') {
        let t = line.trim();
        if let Some(c) = t.strip_prefix('#') {
            if let Some((k, v)) = c.split_once(':') {
                metadata.push((k.trim().to_string(), v.trim().to_string()));
            }
        } else if !t.is_empty() {
            break;
        }
        offset += line.len();
        skipped_lines += 1;
    }
    let body = text.get(offset..).unwrap_or("");
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(body.as_bytes());
    let headers = rdr
        .headers()
        .map_err(|e| {
            HostError::input(format!(
                "{name}: line {}: cannot read the header: {e}",
                skipped_lines + 1
            ))
        })?
        .clone();
    if headers.is_empty() || (headers.len() == 1 && headers.get(0).is_some_and(str::is_empty)) {
        return Err(HostError::input(format!("{name}: no header row")));
    }
    let col = |c: &str| headers.iter().position(|h| h == c);
    let header_line = skipped_lines + 1;
    let mut warnings = Vec::new();
    let mut seen: Vec<&str> = Vec::new();
    for h in headers.iter() {
        if seen.contains(&h) {
            return Err(HostError::input(format!(
                "{name}: line {header_line}: column `{}` appears twice",
                shown(h)
            )));
        }
        seen.push(h);
        if h != "time_s" && h != "motor_voltage_v" && !OUTPUT_COLUMNS.contains(&h) {
            warnings.push(format!(
                "{name}: column `{}` is not used and was ignored",
                shown(h)
            ));
        }
    }
    let t_col = col("time_s").ok_or_else(|| {
        HostError::input(format!(
            "{name}: line {header_line}: missing required column `time_s`"
        ))
    })?;
    let v_col = col("motor_voltage_v").ok_or_else(|| {
        HostError::input(format!(
            "{name}: line {header_line}: missing required column `motor_voltage_v`"
        ))
    })?;
    let out_cols: Vec<(String, usize)> = OUTPUT_COLUMNS
        .iter()
        .filter_map(|c| col(c).map(|i| ((*c).to_string(), i)))
        .collect();
    if require_output && out_cols.is_empty() {
        return Err(HostError::input(format!(
            "{name}: line {header_line}: no output column (need at least one of {})",
            OUTPUT_COLUMNS.join(", ")
        )));
    }

    let mut time_s = Vec::new();
    let mut volts = Vec::new();
    let mut outs: Vec<Vec<f64>> = vec![Vec::new(); out_cols.len()];
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e
                .position()
                .map(|p| p.line() as usize + skipped_lines)
                .unwrap_or(0);
            let why = match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => {
                    format!("has {len} fields, the header has {expected_len}")
                }
                _ => e.to_string(),
            };
            HostError::input(format!("{name}: line {line}: {why}"))
        })?;
        let line = rec
            .position()
            .map(|p| p.line() as usize + skipped_lines)
            .unwrap_or(0);
        let field = |i: usize, cname: &str| -> Result<f64, HostError> {
            let raw = rec.get(i).unwrap_or("");
            if raw.is_empty() {
                return Err(HostError::input(format!(
                    "{name}: line {line}, column `{cname}`: empty field"
                )));
            }
            let v: f64 = raw.parse().map_err(|_| {
                HostError::input(format!(
                    "{name}: line {line}, column `{cname}`: `{}` is not a number",
                    shown(raw)
                ))
            })?;
            if !v.is_finite() {
                return Err(HostError::input(format!(
                    "{name}: line {line}, column `{cname}`: `{}` is not finite",
                    shown(raw)
                )));
            }
            Ok(v)
        };
        let t = field(t_col, "time_s")?;
        if let Some(&prev) = time_s.last() {
            if t <= prev {
                return Err(not_increasing(&format!("{name}: line {line}"), t, prev));
            }
        }
        time_s.push(t);
        volts.push(field(v_col, "motor_voltage_v")?);
        for ((cname, i), o) in out_cols.iter().zip(outs.iter_mut()) {
            o.push(field(*i, cname)?);
        }
    }
    let dt = time_base(
        &mut time_s,
        &mut volts,
        &mut outs,
        &mut warnings,
        name,
        |k| format!("{name}: line {}", header_line + k + 1),
    )?;
    Ok(Record {
        metadata,
        time_s,
        sample_period_s: dt,
        motor_voltage_v: volts,
        outputs: out_cols.into_iter().map(|(n, _)| n).zip(outs).collect(),
        warnings,
    })
}

/// A record from columns already in memory (a pandas DataFrame, numpy arrays), checked as
/// [`parse`] checks a file, with the same messages; rows are counted from 0 (`NAME: row 3,
/// column `time_s`: ...`). Columns other than `time_s`, `motor_voltage_v` and
/// [`OUTPUT_COLUMNS`] are ignored with a warning, as in a file.
pub fn from_columns(
    name: &str,
    columns: &[(&str, &[f64])],
    require_output: bool,
) -> Result<Record, HostError> {
    let mut warnings = Vec::new();
    for (k, (h, _)) in columns.iter().enumerate() {
        if columns.iter().take(k).any(|(g, _)| g == h) {
            return Err(HostError::input(format!(
                "{name}: column `{}` appears twice",
                shown(h)
            )));
        }
        if *h != "time_s" && *h != "motor_voltage_v" && !OUTPUT_COLUMNS.contains(h) {
            warnings.push(format!(
                "{name}: column `{}` is not used and was ignored",
                shown(h)
            ));
        }
    }
    let col = |c: &str| columns.iter().find(|(h, _)| *h == c).map(|(_, v)| *v);
    let required = |c: &str| {
        col(c).ok_or_else(|| HostError::input(format!("{name}: missing required column `{c}`")))
    };
    let (t, v) = (required("time_s")?, required("motor_voltage_v")?);
    let outs: Vec<(&str, &[f64])> = OUTPUT_COLUMNS
        .iter()
        .filter_map(|c| col(c).map(|v| (*c, v)))
        .collect();
    if require_output && outs.is_empty() {
        return Err(HostError::input(format!(
            "{name}: no output column (need at least one of {})",
            OUTPUT_COLUMNS.join(", ")
        )));
    }
    let checked = [("time_s", t), ("motor_voltage_v", v)]
        .into_iter()
        .chain(outs.iter().copied());
    for (c, x) in checked {
        if x.len() != t.len() {
            return Err(HostError::input(format!(
                "{name}: column `{c}` has {} rows, column `time_s` has {}",
                x.len(),
                t.len()
            )));
        }
        if let Some(k) = x.iter().position(|x| !x.is_finite()) {
            return Err(HostError::input(format!(
                "{name}: row {k}, column `{c}`: `{}` is not finite",
                x.get(k).copied().unwrap_or(f64::NAN)
            )));
        }
    }
    for (k, pair) in t.windows(2).enumerate() {
        if let [prev, t] = *pair {
            if t <= prev {
                return Err(not_increasing(&format!("{name}: row {}", k + 1), t, prev));
            }
        }
    }
    let (mut time_s, mut volts) = (t.to_vec(), v.to_vec());
    let mut values: Vec<Vec<f64>> = outs.iter().map(|(_, v)| v.to_vec()).collect();
    let dt = time_base(
        &mut time_s,
        &mut volts,
        &mut values,
        &mut warnings,
        name,
        |k| format!("{name}: row {k}"),
    )?;
    Ok(Record {
        metadata: Vec::new(),
        time_s,
        sample_period_s: dt,
        motor_voltage_v: volts,
        outputs: outs
            .iter()
            .map(|(c, _)| c.to_string())
            .zip(values)
            .collect(),
        warnings,
    })
}

/// `time_s` at `place` does not increase.
fn not_increasing(place: &str, t: f64, prev: f64) -> HostError {
    HostError::input(format!(
        "{place}, column `time_s`: time {t} does not increase (previous row {prev})"
    ))
}

/// The sample period of increasing `time_s` (two rows at least), which is made uniform: a
/// jittered time base is resampled onto the grid of its mean period (see the module's "Time
/// bases"), `volts` and `outs` with it, and one warning is pushed; a gap longer than
/// [`MAX_INTERVAL_PERIODS`] typical periods is refused. `row(k)` names row k (0-based).
fn time_base(
    time_s: &mut Vec<f64>,
    volts: &mut Vec<f64>,
    outs: &mut [Vec<f64>],
    warnings: &mut Vec<String>,
    name: &str,
    row: impl Fn(usize) -> String,
) -> Result<f64, HostError> {
    if time_s.len() < 2 {
        return Err(HostError::input(format!(
            "{name}: needs at least two data rows, found {}",
            time_s.len()
        )));
    }
    let (first, last) = (
        time_s.first().copied().unwrap_or(0.0),
        time_s.last().copied().unwrap_or(0.0),
    );
    let dt = (last - first) / (time_s.len() - 1) as f64;
    // Gaps are judged against the median interval, which they do not bias (the mean they
    // lengthen).
    let typical = {
        let mut d: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(f64::total_cmp);
        d.get(d.len() / 2).copied().unwrap_or(dt)
    };
    let mut uniform = true;
    for (k, pair) in time_s.windows(2).enumerate() {
        let [a, b] = pair else { continue };
        let d = b - a;
        if d > MAX_INTERVAL_PERIODS * typical {
            return Err(HostError::input(format!(
                "{}, column `time_s`: a gap of {d:.6e} s after the previous row, {:.2} times the typical period {typical:.6e} s (samples are missing; at most {MAX_INTERVAL_PERIODS} allowed)",
                row(k + 1),
                d / typical
            )));
        }
        uniform &= (d - dt).abs() <= UNIFORM_TOLERANCE * dt;
    }
    if !uniform {
        let j = jitter(time_s, dt);
        warnings.push(format!(
            "{name}: the time base jitters: sample instants depart from a uniform grid of {dt:.6e} s by {:.1} % of a period RMS, {:.1} % at most (intervals {:.1}-{:.1} % of it); resampled onto that grid: outputs interpolated linearly, the held voltage averaged over each period",
            100.0 * j.rms,
            100.0 * j.max,
            100.0 * j.shortest,
            100.0 * j.longest
        ));
        let grid: Vec<f64> = (0..time_s.len()).map(|k| first + k as f64 * dt).collect();
        *volts = held_means(time_s, volts, &grid, dt);
        for o in outs.iter_mut() {
            *o = interpolate(time_s, o, &grid);
        }
        *time_s = grid;
    }
    Ok(dt)
}

/// How far a time base departs from the uniform grid of period `dt` from its first instant,
/// as fractions of `dt`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jitter {
    /// RMS of the instants' departures from the grid.
    pub rms: f64,
    /// Largest departure.
    pub max: f64,
    /// Shortest interval.
    pub shortest: f64,
    /// Longest interval.
    pub longest: f64,
}

/// [`Jitter`] of `time_s` (at least two instants) against the grid of period `dt` (s).
pub fn jitter(time_s: &[f64], dt: f64) -> Jitter {
    let t0 = time_s.first().copied().unwrap_or(0.0);
    let dev: Vec<f64> = time_s
        .iter()
        .enumerate()
        .map(|(k, t)| (t - (t0 + k as f64 * dt)) / dt)
        .collect();
    let n = dev.len().max(1) as f64;
    let intervals = time_s.windows(2).map(|w| (w[1] - w[0]) / dt);
    Jitter {
        rms: (dev.iter().map(|d| d * d).sum::<f64>() / n).sqrt(),
        max: dev.iter().fold(0.0f64, |m, d| m.max(d.abs())),
        shortest: intervals.clone().fold(f64::INFINITY, f64::min),
        longest: intervals.fold(0.0f64, f64::max),
    }
}

/// `y` (sampled at the increasing instants `t`) linearly interpolated at the increasing
/// instants `at`; held flat beyond the ends.
fn interpolate(t: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    let mut j = 0usize;
    at.iter()
        .map(|&x| {
            while t.get(j + 1).is_some_and(|&tn| tn <= x) {
                j += 1;
            }
            match (t.get(j), t.get(j + 1), y.get(j), y.get(j + 1)) {
                (Some(&ta), Some(&tb), Some(&ya), Some(&yb)) if x > ta => {
                    ya + (yb - ya) * (x - ta) / (tb - ta)
                }
                (_, _, Some(&ya), _) => ya,
                _ => 0.0,
            }
        })
        .collect()
}

/// Mean over each period `[g, g + dt)` of the grid `grid` of the voltage held from `t[k]`
/// at `v[k]` until `t[k + 1]` (the last held on; before `t[0]`, `v[0]`).
fn held_means(t: &[f64], v: &[f64], grid: &[f64], dt: f64) -> Vec<f64> {
    let held = |k: usize| v.get(k).or(v.last()).copied().unwrap_or(0.0);
    // Start of the held segment k (k ≥ 1), end of segment k.
    let start = |k: usize| t.get(k).copied().unwrap_or(f64::INFINITY);
    let mut k = 0usize;
    grid.iter()
        .map(|&a| {
            let b = a + dt;
            // The segment holding at `a`.
            while start(k + 1) <= a {
                k += 1;
            }
            let (mut acc, mut from, mut j) = (0.0, a, k);
            while from < b {
                let to = start(j + 1).min(b);
                acc += held(j) * (to - from);
                from = to;
                j += 1;
            }
            acc / dt
        })
        .collect()
}

/// Writes columns as CSV: `comments` as leading `# ` lines, then the header and the rows.
pub fn write(
    path: &Path,
    comments: &[String],
    columns: &[(&str, &[f64])],
) -> Result<(), HostError> {
    use std::io::Write;
    let name = path.display().to_string();
    let file = std::fs::File::create(path)
        .map_err(|e| HostError::other(format!("{name}: cannot create: {e}")))?;
    let mut w = std::io::BufWriter::new(file);
    let io = |e: std::io::Error| HostError::other(format!("{name}: write failed: {e}"));
    for c in comments {
        writeln!(w, "# {c}").map_err(io)?;
    }
    let header: Vec<&str> = columns.iter().map(|(n, _)| *n).collect();
    writeln!(w, "{}", header.join(",")).map_err(io)?;
    let rows = columns.iter().map(|(_, v)| v.len()).min().unwrap_or(0);
    let mut line = String::new();
    for k in 0..rows {
        line.clear();
        for (j, (_, v)) in columns.iter().enumerate() {
            if j > 0 {
                line.push(',');
            }
            let x = v.get(k).copied().unwrap_or(f64::NAN);
            // Values that came from f32 print as the shortest f32 text, others as f64.
            if f64::from(x as f32) == x {
                line.push_str(&format!("{}", x as f32));
            } else {
                line.push_str(&format!("{x}"));
            }
        }
        writeln!(w, "{line}").map_err(io)?;
    }
    w.flush().map_err(io)
}

/// Writes `text` to `path`, naming the file on failure.
pub fn write_file(path: &Path, text: &str) -> Result<(), HostError> {
    use std::io::Write;
    let mut f = std::fs::File::create(path)
        .map_err(|e| HostError::other(format!("{}: {e}", path.display())))?;
    f.write_all(text.as_bytes())
        .map_err(|e| HostError::other(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_in_memory_read_as_the_same_csv_does() {
        let text = "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,2,0.1\n0.001,3,0.2\n";
        let csv = parse(text, "m", true).unwrap();
        let (t, v, y) = ([0.0, 0.0005, 0.001], [1.0, 2.0, 3.0], [0.0, 0.1, 0.2]);
        let mem = from_columns(
            "m",
            &[
                ("time_s", &t),
                ("motor_voltage_v", &v),
                ("tach_voltage_v", &y),
            ],
            true,
        )
        .unwrap();
        assert_eq!(mem, csv);
    }

    #[test]
    fn columns_in_memory_are_refused_with_the_files_messages_by_row() {
        let (t, v) = ([0.0, 0.0005, 0.001], [1.0, 2.0, 3.0]);
        let e = from_columns("df", &[("time_s", &t), ("motor_voltage_v", &v)], true).unwrap_err();
        assert!(
            e.message
                .starts_with("df: no output column (need at least one of"),
            "{e}"
        );
        let e = from_columns("df", &[("time_s", &t), ("tach_voltage_v", &v)], true).unwrap_err();
        assert_eq!(e.message, "df: missing required column `motor_voltage_v`");
        let back = [0.0, 0.001, 0.0005];
        let e =
            from_columns("df", &[("time_s", &back), ("motor_voltage_v", &v)], false).unwrap_err();
        assert_eq!(
            e.message,
            "df: row 2, column `time_s`: time 0.0005 does not increase (previous row 0.001)"
        );
        let nan = [1.0, f64::NAN, 3.0];
        let e =
            from_columns("df", &[("time_s", &t), ("motor_voltage_v", &nan)], false).unwrap_err();
        assert_eq!(
            e.message,
            "df: row 1, column `motor_voltage_v`: `NaN` is not finite"
        );
        let uneven = [0.0, 0.0005, 0.0015, 0.002];
        let e = from_columns(
            "df",
            &[("time_s", &uneven), ("motor_voltage_v", &[0.0; 4])],
            false,
        )
        .unwrap_err();
        assert!(
            e.message
                .starts_with("df: row 2, column `time_s`: a gap of"),
            "{e}"
        );
    }

    /// `n` rows at instants `t(k)` of a ramp output and a square voltage (period 8 rows).
    fn csv(n: usize, t: impl Fn(usize) -> f64) -> String {
        let mut s = String::from("time_s,motor_voltage_v,load_angle_deg\n");
        for k in 0..n {
            let tk = t(k);
            let v = if (k / 4) % 2 == 0 { 5.0 } else { -5.0 };
            s.push_str(&format!("{tk},{v},{}\n", 3.0 + 2000.0 * tk));
        }
        s
    }

    #[test]
    fn a_jittered_time_base_is_resampled_with_one_warning() {
        let h = 5e-4;
        // ±3 % of a period, deterministic and irregular.
        let j = |k: usize| 0.03 * h * ((k as f64 * 1.7).sin());
        let rec = parse(&csv(400, |k| k as f64 * h + j(k)), "j.csv", true).unwrap();
        assert_eq!(rec.warnings.len(), 1, "{:?}", rec.warnings);
        let w = &rec.warnings[0];
        assert!(
            w.contains("jitters") && w.contains("resampled") && !w.contains('\n'),
            "{w}"
        );
        assert_eq!(rec.len(), 400);
        // Uniform grid from the first instant at the mean period.
        let dt = rec.sample_period_s;
        for (k, t) in rec.time_s.iter().enumerate() {
            assert!((t - (rec.time_s[0] + k as f64 * dt)).abs() < 1e-12);
        }
        // A ramp is interpolated exactly (up to rounding) wherever samples bracket it.
        let y = rec.output("load_angle_deg").unwrap();
        for (t, yk) in rec.time_s.iter().zip(y).skip(1).take(398) {
            assert!((yk - (3.0 + 2000.0 * t)).abs() < 1e-9, "{t}: {yk}");
        }
        // The held voltage keeps its volt-seconds over whole grid periods.
        let t_in: Vec<f64> = (0..400).map(|k| k as f64 * h + j(k)).collect();
        let end = rec.time_s[399];
        let held: f64 = (0..399)
            .map(|k| {
                let v = if (k / 4) % 2 == 0 { 5.0 } else { -5.0 };
                v * (t_in[k + 1].min(end) - t_in[k].min(end))
            })
            .sum();
        let grid: f64 = rec.motor_voltage_v.iter().take(399).map(|v| v * dt).sum();
        assert!((held - grid).abs() < 1e-9, "{held} vs {grid}");
        // A voltage switch falling inside a grid period is split by time.
        assert!(rec.motor_voltage_v.iter().any(|v| v.abs() < 4.9));
    }

    #[test]
    fn a_uniform_time_base_is_read_as_it_is() {
        let h = 5e-4;
        let text = csv(50, |k| {
            k as f64 * h * (1.0 + 0.004 * (k % 2) as f64 / k.max(1) as f64)
        });
        let rec = parse(&text, "u.csv", true).unwrap();
        assert!(rec.warnings.is_empty(), "{:?}", rec.warnings);
        assert!(rec.motor_voltage_v.iter().all(|v| v.abs() == 5.0));
    }

    #[test]
    fn a_gap_of_missing_samples_is_refused_naming_its_line() {
        let h = 5e-4;
        // Rows 10 and 11 missing: an interval of three periods before data row 10 (line 12:
        // the header is line 1).
        let t = |k: usize| {
            if k < 10 {
                k as f64 * h
            } else {
                (k + 2) as f64 * h
            }
        };
        let e = parse(&csv(40, t), "g.csv", true).unwrap_err();
        assert!(
            e.message
                .starts_with("g.csv: line 12, column `time_s`: a gap of")
                && e.message.contains("samples are missing"),
            "{}",
            e.message
        );
    }
}
