"""Period-average comparison of models on a periodic record (a development probe).

For a record whose command repeats (the foreign suite's validation record: a 9 V square
wave plus a 2 V multisine, period 0.25 s = 500 rows at 2 kHz), each model named on the
command line is run with `geared-servo simulate` on the record's voltage. The measured
output and each model's are folded over the period (the first period, a transient from
rest, left out) and compared phase by phase:

- avg-NRMSE: RMS of (measured period mean - model period mean) over the RMS of the measured
  mean. Noise and what does not repeat average out over the K periods; a model that is
  right where the unit repeats has it near the noise over sqrt(K).
- mean z2: the same difference in units of its standard error, (s_m^2 + s_y^2) / K with
  s_m^2, s_y^2 the variances across periods of the measured and modelled outputs at that
  phase. Both carry the same deterministic period-to-period change where the model is
  right, so the truth sits well below 1; only the ratio between models means anything.
- every-row NRMSE: sample by sample over the whole record (no row weighted out).

Usage, with the records of `target/release/examples/foreign_records DIR --kind K --draw N`
and `geared-servo diagnose ... --out DIR/o`:

    python3 docs/dev/period_average.py DIR COLUMN [PERIOD_ROWS] NAME=PARAMS.toml ...

e.g. `python3 docs/dev/period_average.py DIR current_a 500 truth=DIR/truth.toml
final=DIR/o/calibrated.toml file=DIR/file.toml`. Needs numpy and a release build of the
CLI (`GS` below, or the environment variable `GEARED_SERVO`).
"""

import csv
import os
import subprocess
import sys

import numpy as np

GS = os.environ.get("GEARED_SERVO", "target/release/geared-servo")


def load(path):
    with open(path) as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])


def simulate(params, inp, out):
    subprocess.run(
        [GS, "--params", params, "simulate", "--input", inp, "--output", out],
        check=True,
        capture_output=True,
    )
    return load(out)


def fold(y, period_rows, skip=1):
    k = len(y) // period_rows
    return y[: k * period_rows].reshape(k, period_rows)[skip:]


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    d, col = sys.argv[1], sys.argv[2]
    rest = sys.argv[3:]
    period_rows = 500
    if rest and "=" not in rest[0]:
        period_rows = int(rest.pop(0))
    header, m = load(os.path.join(d, "validation.csv"))
    if col not in header:
        sys.exit(f"validation.csv: no column `{col}` (has {', '.join(header)})")
    ci = header.index(col)
    inp = os.path.join(d, "pa_in.csv")
    with open(inp, "w") as f:
        f.write("time_s,motor_voltage_v\n")
        for r in m:
            f.write(f"{float(r[0])!r},{float(r[1])!r}\n")
    ym = fold(m[:, ci], period_rows)
    k = ym.shape[0]
    mean_m, var_m = ym.mean(0), ym.var(0, ddof=1)
    rms = np.sqrt(np.mean(mean_m**2))
    for name, params in (a.split("=", 1) for a in rest):
        hs, s = simulate(params, inp, os.path.join(d, f"pa_{name}.csv"))
        y = s[:, hs.index(col)]
        ys = fold(y, period_rows)
        mean_y, var_y = ys.mean(0), ys.var(0, ddof=1)
        z2 = (mean_m - mean_y) ** 2 / ((var_m + var_y) / k + 1e-30)
        avg = np.sqrt(np.mean((mean_m - mean_y) ** 2)) / rms
        every = np.sqrt(np.mean((m[:, ci] - y) ** 2)) / np.sqrt(np.mean(m[:, ci] ** 2))
        print(
            f"{name:8s} K={k} mean z2 {z2.mean():8.2f}  median {np.median(z2):6.2f}  "
            f"avg-NRMSE {avg:.4f}  every-row NRMSE {every:.4f}  "
            f"spread across periods: model {np.sqrt(var_y.mean()) / rms:.4f}, "
            f"measured {np.sqrt(var_m.mean()) / rms:.4f}"
        )


if __name__ == "__main__":
    main()
