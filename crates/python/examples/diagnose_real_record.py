"""Diagnose the real bench record in a notebook's way: load it with pandas, calibrate the rig's
parameter file against it, print the report, plot measured against model, save the
calibrated file.

    python crates/python/examples/diagnose_real_record.py [OUT_DIR]

Run from anywhere after `pip install` of the geared_servo wheel (README, "Python"), with
pandas and matplotlib. The record is `../shared/data/geartrain-square-wave.csv` beside the
repository (a brushed DC motor, three spur stages, an arm; a ±16 V square wave; the output is
a tachometer voltage); the parameters are `data/kord-geartrain.toml`. The command line does
the same with `geared-servo --params data/kord-geartrain.toml diagnose --data ... --out DIR`
(examples/real-data/ holds its result).
"""

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt
import pandas as pd

import geared_servo as gs

REPO = pathlib.Path(__file__).resolve().parents[3]
RECORD = REPO.parent / "shared" / "data" / "geartrain-square-wave.csv"


def main(out: pathlib.Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    # A DataFrame, as a notebook has it; gs.diagnose(params, str(RECORD)) reads the CSV itself.
    frame = pd.read_csv(RECORD, comment="#")
    params = gs.Params.from_toml(REPO / "data" / "kord-geartrain.toml")
    d = gs.diagnose(params, frame)

    r = d.report
    print(d.summary)
    print(f"fit {r['nominal']['fit_percent']:.1f} % (file) -> {r['final']['fit_percent']:.1f} % (calibrated); "
          f"effects added: {', '.join(r['added_effects']) or 'none'}; unexplained: {r['unexplained']}")

    fig, ax = plt.subplots(figsize=(11, 4.5))
    ax.plot(d.time_s, d.measured, color="black", lw=0.8, label="measured")
    ax.plot(d.time_s, d.model_before, color="tab:red", lw=0.8, label="model, file parameters")
    ax.plot(d.time_s, d.model_after, color="tab:blue", lw=0.8, label="model, calibrated")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{d.output} ({d.output_unit})")
    ax.set_title(f"{RECORD.name}: fit {r['final']['fit_percent']:.1f} % after calibration")
    ax.legend(loc="upper right")
    fig.tight_layout()
    png = out / "measured_vs_model.png"
    fig.savefig(png, dpi=120)
    (out / "calibrated.toml").write_text(d.to_toml())
    print(f"wrote {png} and {out / 'calibrated.toml'}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else pathlib.Path("diagnose-real-record"))
