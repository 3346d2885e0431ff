//! Measured-data records (CSV, INTERFACES.md "Measured data"): reading with errors that name
//! the line and the column, and writing in the same convention.
//!
//! Row k: the outputs were sampled at `time_s[k]`, then `motor_voltage_v[k]` was applied
//! until the next row. The first row's outputs are the initial state.

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

/// A uniformly sampled record.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// `# key: value` comment lines before the header, in order.
    pub metadata: Vec<(String, String)>,
    /// Sample instants, s.
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
    let dt = sample_period(&time_s, name, |k| {
        format!("{name}: line {}", header_line + k + 1)
    })?;
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
    let dt = sample_period(t, name, |k| format!("{name}: row {k}"))?;
    Ok(Record {
        metadata: Vec::new(),
        time_s: t.to_vec(),
        sample_period_s: dt,
        motor_voltage_v: v.to_vec(),
        outputs: outs
            .iter()
            .map(|(c, v)| (c.to_string(), v.to_vec()))
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

/// The mean sample period of increasing `time_s`, which must have two rows at least and be
/// uniform within 1 %; `row(k)` names row k (0-based) in messages.
fn sample_period(
    time_s: &[f64],
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
    for (k, pair) in time_s.windows(2).enumerate() {
        let [a, b] = pair else { continue };
        let d = b - a;
        if (d - dt).abs() > 0.01 * dt {
            return Err(HostError::input(format!(
                "{}, column `time_s`: sampling is not uniform (step {d:.6e} s against a mean of {dt:.6e} s; 1 % allowed)",
                row(k + 1)
            )));
        }
    }
    Ok(dt)
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
                .starts_with("df: row 1, column `time_s`: sampling is not uniform"),
            "{e}"
        );
    }
}
