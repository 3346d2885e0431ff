"""Shared by the tests of the geared_servo package: where the repository, its data and the
`geared-servo` command line are, and how to run it.

The tests compare the package with the command line on the same inputs, so the command line
must be built (`cargo build --release -p geared-servo-cli`; `.ci/run` does). Set
GEARED_SERVO_BIN to use another binary. A missing binary fails the tests, it does not skip
them.
"""

import os
import pathlib
import subprocess

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]


def cli_binary() -> pathlib.Path:
    if os.environ.get("GEARED_SERVO_BIN"):
        return pathlib.Path(os.environ["GEARED_SERVO_BIN"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    if not target.is_absolute():
        target = REPO / target
    return target / "release" / "geared-servo"


@pytest.fixture(scope="session")
def cli():
    """Runs `geared-servo ARGS`; returns the completed process (text, not checked)."""
    exe = cli_binary()
    if not exe.is_file():
        pytest.fail(f"{exe}: no geared-servo binary (cargo build --release -p geared-servo-cli, or set GEARED_SERVO_BIN)")

    def run(*args):
        return subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, timeout=600)

    return run


def read_csv(path):
    """A CSV the command line wrote: `# ` comments, a header, numbers. Returns {column: array}."""
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    names = lines[0].strip().split(",")
    data = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    return {n: data[:, i] for i, n in enumerate(names)}


def write_record(path, columns):
    """Writes {column: array} as a record CSV with the values' shortest round-trip text."""
    names = list(columns)
    n = len(columns[names[0]])
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for k in range(n):
            f.write(",".join(repr(float(columns[c][k])) for c in names) + "\n")


@pytest.fixture
def voltage_record(tmp_path):
    """A voltage record at 2 kHz: a ±10 V square wave with a 37 Hz sine on top, 0.6 s."""
    dt = 0.0005
    k = np.arange(1200)
    t = k * dt
    v = np.where((k // 150) % 2 == 0, 10.0, -10.0) + 3.0 * np.sin(2 * np.pi * 37.0 * t)
    path = tmp_path / "volts.csv"
    write_record(path, {"time_s": t, "motor_voltage_v": v})
    return path, t, v
