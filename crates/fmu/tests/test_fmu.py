"""The FMU of `geared-servo fmu` under an independent FMI 2.0 importer, FMPy.

Needs the release build of the command line and of the FMU library side by side
(`cargo build --release -p geared-servo-cli -p geared-servo-fmu`; `.ci/run` does), or
GEARED_SERVO_BIN pointing at a `geared-servo` with `libgeared_servo_fmu.so` beside it. A
missing binary fails the tests, it does not skip them.
"""

import os
import pathlib
import subprocess

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy import extract
from fmpy.validation import validate_fmu

REPO = pathlib.Path(__file__).resolve().parents[3]
DT = 0.0005


def cli_binary() -> pathlib.Path:
    if os.environ.get("GEARED_SERVO_BIN"):
        return pathlib.Path(os.environ["GEARED_SERVO_BIN"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    if not target.is_absolute():
        target = REPO / target
    return target / "release" / "geared-servo"


def cli(*args):
    exe = cli_binary()
    if not exe.is_file():
        pytest.fail(f"{exe}: no geared-servo binary (cargo build --release -p geared-servo-cli -p geared-servo-fmu)")
    run = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return run


def read_csv(path):
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    names = lines[0].strip().split(",")
    data = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    return {n: data[:, i] for i, n in enumerate(names)}


def write_volts(path, t, v):
    with open(path, "w") as f:
        f.write("time_s,motor_voltage_v\n")
        for a, b in zip(t, v):
            f.write(f"{float(a)!r},{float(b)!r}\n")


def reference_with(**changes):
    """The reference file's text with `key = value` lines changed (a key once per file)."""
    text = (REPO / "data" / "reference-actuator.toml").read_text().splitlines()
    out = []
    for line in text:
        key = line.split("=", 1)[0].strip()
        if key in changes:
            line = f"{key} = {changes[key]}"
        out.append(line)
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    """The FMU of the reference actuator, built by `geared-servo fmu`."""
    tmp = tmp_path_factory.mktemp("fmu")
    path = tmp / "actuator.fmu"
    cli("--params", REPO / "data" / "reference-actuator.toml", "fmu", "--out", path)
    return path


@pytest.fixture(scope="module")
def volts():
    k = np.arange(1600)
    t = k * DT
    v = np.where((k // 150) % 2 == 0, 12.0, -12.0) + 4.0 * np.sin(2 * np.pi * 53.0 * t)
    return t, v


def test_model_description_is_valid_and_lists_every_key_with_units(fmu):
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["motor_voltage_v"].causality == "input"
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert outputs == ["tach_voltage_v", "motor_speed_rad_s", "load_angle_deg", "current_a",
                       "load_speed_rad_s", "transmitted_torque_nm", "in_contact", "mean_current_a"]
    assert by_name["load.inertia_kg_m2"].unit == "kg*m^2"
    assert float(by_name["motor.resistance_ohm"].start) == 32.5
    assert by_name["backlash.total_deg"].unit == "deg"
    assert by_name["effects.mesh_damping"].unit == "N*m*s/rad"
    assert by_name["gear_stage_2.revolving"].type == "Boolean"
    assert md.coSimulation.modelIdentifier == "geared_servo_fmu"
    assert md.defaultExperiment.stepSize == str(DT) or float(md.defaultExperiment.stepSize) == DT


def run_slave(fmu, values, reals=None, bools=None, every=1):
    """Steps the FMU with FMPy's low-level API over `values` held for `every` periods each;
    returns the outputs at each communication point before its step, as simulate writes them."""
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    unzipped = extract(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="test")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    for k, x in (reals or {}).items():
        slave.setReal([vr[k]], [x])
    for k, x in (bools or {}).items():
        slave.setBoolean([vr[k]], [x])
    slave.exitInitializationMode()
    rows = []
    for n, v in enumerate(values):
        rows.append(slave.getReal([vr[o] for o in outputs]))
        slave.setReal([vr["motor_voltage_v"]], [float(v)])
        slave.doStep(currentCommunicationPoint=n * every * DT, communicationStepSize=every * DT)
    slave.terminate()
    slave.freeInstance()
    return {o: np.array([r[i] for r in rows]) for i, o in enumerate(outputs)}


def test_fmpy_steps_equal_simulate_with_parameters_set_through_fmi(fmu, volts, tmp_path):
    """Parameters set through FMI (a real, an effect, the Boolean) give what `simulate` gives
    with a file holding those values: identical after f32 rounding (the CLI's CSV holds f32)."""
    t, v = volts
    params = tmp_path / "p.toml"
    params.write_text(reference_with(total_deg=0.08, mesh_damping=0.05, revolving="false"))
    write_volts(tmp_path / "v.csv", t, v)
    cli("--params", params, "simulate", "--input", tmp_path / "v.csv", "--output", tmp_path / "sim.csv")
    want = read_csv(tmp_path / "sim.csv")
    got = run_slave(fmu, v, reals={"backlash.total_deg": 0.08, "effects.mesh_damping": 0.05},
                    bools={"gear_stage_2.revolving": False})
    worst = 0.0
    for name, column in got.items():
        a, b = column.astype(np.float32), want[name].astype(np.float32)
        worst = max(worst, float(np.max(np.abs(a.astype(np.float64) - b))))
        assert np.array_equal(a, b), name
    print(f"max |FMPy - simulate| over {len(v)} steps and {len(got)} outputs: {worst}")
    assert np.ptp(got["tach_voltage_v"]) > 0.1 and np.ptp(got["in_contact"]) == 1.0


def test_a_communication_step_of_four_sample_periods_is_four_plant_steps(fmu, volts, tmp_path):
    t, v = volts
    held = np.repeat(v[:400], 4)  # each value held for four periods
    write_volts(tmp_path / "v.csv", np.arange(len(held)) * DT, held)
    cli("--params", REPO / "data" / "reference-actuator.toml", "simulate", "--input", tmp_path / "v.csv",
        "--output", tmp_path / "sim.csv")
    want = read_csv(tmp_path / "sim.csv")
    got = run_slave(fmu, v[:400], every=4)
    for name, column in got.items():
        assert np.array_equal(column.astype(np.float32), want[name][::4].astype(np.float32)), name


def test_simulate_fmu_with_an_input_signal_equals_simulate(fmu, volts, tmp_path):
    """FMPy's own driver (simulate_fmu) with the voltage record as its input signal."""
    t, v = volts
    write_volts(tmp_path / "v.csv", t, v)
    cli("--params", REPO / "data" / "reference-actuator.toml", "simulate", "--input", tmp_path / "v.csv",
        "--output", tmp_path / "sim.csv")
    want = read_csv(tmp_path / "sim.csv")
    signal = np.array(list(zip(t, v)), dtype=[("time", np.float64), ("motor_voltage_v", np.float64)])
    result = simulate_fmu(str(fmu), start_time=0.0, stop_time=t[-1], output_interval=DT, input=signal,
                          output=["tach_voltage_v", "load_angle_deg"])
    assert len(result) == len(t)
    for name in ["tach_voltage_v", "load_angle_deg"]:
        assert np.array_equal(result[name].astype(np.float32), want[name].astype(np.float32)), name


@pytest.mark.parametrize("key,value,message", [
    ("load.inertia_kg_m2", -1.0, "FMU parameters: key `load.inertia_kg_m2` must be greater than zero"),
    ("motor.resistance_ohm", float("nan"), "FMU parameters: key `motor.resistance_ohm` must be a finite number"),
    ("backlash.total_deg", 45.0, "FMU parameters: key `backlash.total_deg` must be below 10 degrees"),
])
def test_bad_parameters_are_an_fmi_error_with_the_key_not_a_crash(fmu, key, value, message):
    logged = []

    def logger(env, instance, status, category, text):
        logged.append((status, text.decode()))

    with pytest.raises(Exception, match=r"fmi2ExitInitializationMode failed with status 3 \(error\)"):
        simulate_fmu(str(fmu), stop_time=0.01, step_size=DT, start_values={key: value}, logger=logger)
    assert any(status == 3 and message in text for status, text in logged), logged
    # The process lives on and the FMU still works with good parameters.
    ok = simulate_fmu(str(fmu), stop_time=0.01, step_size=DT, output=["tach_voltage_v"])
    assert len(ok) == 21


def test_a_step_that_is_not_whole_sample_periods_is_an_fmi_error(fmu):
    logged = []

    def logger(env, instance, status, category, text):
        logged.append((status, text.decode()))

    with pytest.raises(Exception, match=r"fmi2DoStep failed with status 3 \(error\)"):
        simulate_fmu(str(fmu), stop_time=0.01, output_interval=0.0007, logger=logger)
    assert any("is not a whole number of sample periods" in text for _, text in logged), logged


def test_fmu_without_its_library_says_how_to_build_it(tmp_path):
    """A `geared-servo` with no library beside it: one line, exit status 2, no archive."""
    import shutil

    exe = tmp_path / "geared-servo"
    shutil.copy(cli_binary(), exe)
    run = subprocess.run([str(exe), "fmu", "--out", str(tmp_path / "a.fmu")], capture_output=True, text=True)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1
    assert "no FMU library beside this executable: build it with `cargo build --release -p geared-servo-fmu`" in run.stderr
    assert not (tmp_path / "a.fmu").exists()
