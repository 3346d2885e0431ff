"""The geared_servo package against the parameter file and the `geared-servo` command line."""

import json
import os
import signal
import tomllib
import warnings

import numpy as np
import pandas as pd
import pytest

import geared_servo as gs
from conftest import REPO, read_csv, write_record

REFERENCE_FILE = REPO / "data" / "reference-actuator.toml"


def flat(table, prefix=""):
    """{key path: value} of a parsed TOML document."""
    out = {}
    for k, v in table.items():
        if isinstance(v, dict):
            out.update(flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def test_reference_is_the_bundled_file_key_for_key():
    p = gs.Params.reference()
    with open(REFERENCE_FILE, "rb") as f:
        want = flat(tomllib.load(f))
    # The file's keys in its order, then the effects the file predates (off).
    assert p.keys()[: len(want)] == list(want)
    extra = p.keys()[len(want):]
    assert extra and all(k.startswith("effects.") for k in extra), extra
    assert all(p[k] == 0.0 for k in extra)
    for key, value in want.items():
        assert p[key] == value, key
    assert p.motor.resistance_ohm == 32.5
    assert p.gear_stage_2.revolving is True
    assert p.sample_period_s == 0.0005
    assert p == gs.Params.from_toml(REFERENCE_FILE)


def test_params_round_trip_through_toml_for_both_stiffness_forms():
    for p in [gs.Params.reference(), gs.Params.from_toml(REPO / "data" / "kord-geartrain.toml")]:
        p2 = gs.Params.from_string(p.to_toml())
        assert p2 == p
        assert p2.to_dict() == p.to_dict()
    kord = gs.Params.from_toml(REPO / "data" / "kord-geartrain.toml")
    assert kord.stiffness.k1_nm_per_rad == 4.86
    with pytest.raises(AttributeError):
        kord.gear_stage_1.face_width_m


def test_attributes_are_documented_with_their_units():
    p = gs.Params.reference()
    assert "ohm" in type(p.motor).resistance_ohm.__doc__
    assert "kg*m^2" in type(p.load).__doc__
    assert p.unit("backlash.total_deg") == "deg"
    assert p.unit("effects.mesh_damping") == "N*m*s/rad"
    assert "armature resistance" in p.description("motor.resistance_ohm")


def test_setting_a_key_validates_the_set_with_the_files_message():
    p = gs.Params.reference()
    p.backlash.total_deg = 0.08
    p.effects.mesh_damping = 0.05
    p.gear_stage_2.revolving = False
    assert (p.backlash.total_deg, p["effects.mesh_damping"], p.gear_stage_2.revolving) == (0.08, 0.05, False)
    before = p.to_dict()
    with pytest.raises(gs.InputError) as e:
        p.load.inertia_kg_m2 = -1.0
    assert str(e.value) == "<bundled reference-actuator.toml>: key `load.inertia_kg_m2` must be greater than zero"
    assert p.to_dict() == before
    with pytest.raises(KeyError):
        p["motor.nope"] = 1.0
    with pytest.raises(AttributeError):
        p.motor.resistanse_ohm = 1.0


def test_nan_parameter_raises_the_clis_message(tmp_path, cli):
    bad = tmp_path / "bad.toml"
    bad.write_text(REFERENCE_FILE.read_text().replace("inertia_kg_m2 = 1.0e-3", "inertia_kg_m2 = nan"))
    run = cli("--params", bad, "info")
    assert run.returncode == 2
    message = run.stderr.strip().removeprefix("error: ")
    assert "key `load.inertia_kg_m2` must be a finite number" in message
    with pytest.raises(gs.InputError) as e:
        gs.Params.from_toml(bad)
    assert str(e.value) == message
    p = gs.Params.reference()
    with pytest.raises(gs.InputError, match="key `load.inertia_kg_m2` must be a finite number"):
        p.load.inertia_kg_m2 = float("nan")


def test_missing_csv_column_raises_the_clis_message(tmp_path, cli):
    path = tmp_path / "novolts.csv"
    write_record(path, {"time_s": [0.0, 0.0005, 0.001], "tach_voltage_v": [0.0, 0.1, 0.2]})
    run = cli("simulate", "--input", path, "--output", tmp_path / "out.csv")
    assert run.returncode == 2
    message = run.stderr.strip().removeprefix("error: ")
    assert message.endswith("missing required column `motor_voltage_v`")
    with pytest.raises(gs.InputError) as e:
        gs.simulate(gs.Params.reference(), str(path))
    assert str(e.value) == message
    frame = pd.DataFrame({"time_s": [0.0, 0.0005, 0.001], "tach_voltage_v": [0.0, 0.1, 0.2]})
    with pytest.raises(gs.InputError, match=r"^<DataFrame>: missing required column `motor_voltage_v`$"):
        gs.diagnose(gs.Params.reference(), frame)


def test_simulate_matches_the_cli_on_the_same_record(tmp_path, cli, voltage_record):
    path, t, v = voltage_record
    p = gs.Params.reference()
    p.backlash.total_deg = 0.08
    params = tmp_path / "p.toml"
    params.write_text(p.to_toml())
    run = cli("--params", params, "simulate", "--input", path, "--output", tmp_path / "sim.csv")
    assert run.returncode == 0, run.stderr
    want = read_csv(tmp_path / "sim.csv")
    from_path = gs.simulate(p, str(path))
    from_array = gs.simulate(p, v, dt=0.0005)
    assert list(from_path) == list(want) == ["time_s", "motor_voltage_v", *gs.SIMULATE_COLUMNS]
    for name, column in want.items():
        assert from_path[name].shape == (len(t),)
        # The CLI writes each f32 output as its shortest f32 text: equal after f32 rounding.
        assert np.array_equal(from_path[name].astype(np.float32), column.astype(np.float32)), name
        if name != "time_s":
            assert np.array_equal(from_array[name], from_path[name]), name
    assert np.ptp(from_path["tach_voltage_v"]) > 0.1  # it moved


def test_simulate_rejects_bad_input_as_the_cli_does():
    p = gs.Params.reference()
    with pytest.raises(gs.InputError, match=r"^volts: row 2, column `motor_voltage_v`: `NaN` is not finite$"):
        gs.simulate(p, [1.0, 2.0, float("nan"), 3.0])
    with pytest.raises(gs.InputError, match=r"^dt \(sample period of the record\): key `sample_period_s`"):
        gs.simulate(p, [1.0, 2.0], dt=-1.0)
    with pytest.raises(gs.InputError, match=r"^--backlash-deg: value must not be negative$"):
        gs.simulate(p, [1.0, 2.0], backlash_deg=-0.1)


def test_bode_matches_the_cli(cli):
    args = dict(vpk=10.0, backlash_deg=0.08, from_hz=100.0, to_hz=140.0, step_hz=10.0)
    b = gs.bode(gs.Params.reference(), **args)
    run = cli("bode", "--vpk", 10, "--backlash-deg", 0.08, "--from", 100, "--to", 140, "--step", 10, "--json")
    assert run.returncode == 0, run.stderr
    want = json.loads(run.stdout)
    points = want.pop("points")
    assert {k: b[k] for k in want} == want
    for key in ["freq_hz", "gain_db", "phase_deg"]:
        assert np.array_equal(b[key], [q[key] for q in points]), key
    assert b["settled"].tolist() == [q["settled"] for q in points]
    assert b["freq_hz"].tolist() == [100.0, 110.0, 120.0, 130.0, 140.0]


def test_resonances_match_the_cli(cli):
    r = gs.resonances(gs.Params.reference(), 10.0, backlash_deg=0.08)
    run = cli("resonances", "--vpk", 10, "--backlash-deg", 0.08, "--json")
    assert run.returncode == 0, run.stderr
    assert r == json.loads(run.stdout)
    # Backlash lowers the notch below the closed form's (127.6 Hz, no backlash): about 80 Hz
    # at 0.08 deg and 10 V (docs/frequency-response.md).
    assert 60.0 < r["f_ar_hz"] < r["closed_form"]["f_ar_hz"]
    with pytest.raises(gs.InputError, match=r"^--vpk must be a positive number of volts, got -1$"):
        gs.resonances(gs.Params.reference(), -1.0)


def test_design_query_arguments_are_checked_as_on_the_command_line():
    p = gs.Params.reference()
    with pytest.raises(gs.InputError, match=r"^--bandwidth-hz must be a positive frequency, got 0$"):
        gs.max_backlash(p, 0.0, 10.0)
    with pytest.raises(gs.InputError, match=r"^--hold must be `continuous` or `zoh`, got `square`$"):
        gs.min_voltage(p, 100.0, 0.05, hold="square")


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """A short synthetic record: an actuator with mesh damping the reference file lacks."""
    tmp = tmp_path_factory.mktemp("diag")
    true = gs.Params.reference()
    true.backlash.total_deg = 0.03
    true.effects.mesh_damping = 0.05
    k = np.arange(1600)
    v = 8.0 * np.sign(np.sin(2 * np.pi * 5.0 * k * 0.0005)) + 4.0 * np.sin(2 * np.pi * 140.0 * k * 0.0005)
    out = gs.simulate(true, v, dt=0.0005)
    rng = np.random.default_rng(3)
    record = {
        "time_s": out["time_s"],
        "motor_voltage_v": v,
        "tach_voltage_v": out["tach_voltage_v"] + 0.01 * rng.standard_normal(len(v)),
    }
    path = tmp / "meas.csv"
    write_record(path, record)
    return path, record


def test_diagnose_returns_the_documented_report_and_the_clis_numbers(measured, cli):
    path, record = measured
    d = gs.diagnose(gs.Params.reference(), str(path), max_steps=1)
    r = d.report
    for key in ["samples", "sample_period_s", "output", "nominal", "steps", "added_effects", "final", "unexplained"]:
        assert key in r, key
    for key in ["nrmse", "fit_percent", "parameters"]:
        assert key in r["nominal"], key
    for key in ["nrmse", "fit_percent", "residual_white"]:
        assert key in r["final"], key
    assert r["samples"] == 1600 and r["output"] == d.output == "tach_voltage_v" and d.output_unit == "V"
    assert r["final"]["nrmse"] < r["nominal"]["nrmse"]
    run = cli("diagnose", "--data", path, "--max-steps", 1, "--json")
    assert run.returncode == 0, run.stderr
    assert r == json.loads(run.stdout)
    # The calibrated set is valid, and it is what the report says was fitted.
    assert isinstance(d.params, gs.Params)
    for key, value in r["final"]["fit"]["parameters"].items():
        if key in d.params:
            assert d.params[key] == pytest.approx(value, rel=1e-12), key
    assert gs.Params.from_string(d.to_toml()) == d.params
    assert d.to_toml().startswith("# calibrated by geared-servo")
    assert d.measured.shape == d.model_before.shape == d.model_after.shape == d.time_s.shape
    err = lambda y: np.linalg.norm(y - d.measured)
    assert err(d.model_after) < err(d.model_before)


def test_limits_are_the_clis(measured, cli):
    path, record = measured
    p = gs.Params.reference()
    d = gs.diagnose(p, str(path), max_steps=0, limits=["load_viscous", "tach_offset"])
    limits = d.report["limits"]
    assert sorted((x["effect"], x["side"]) for x in limits) == [
        ("load_viscous", "+"),
        ("tach_offset", "+"),
        ("tach_offset", "-"),
    ]
    for x in limits:
        assert x["kind"] in ("within", "below_range", "beyond_range")
        assert (x["limit"] > 0) == (x["side"] == "+")
    run = cli("diagnose", "--data", path, "--max-steps", 0, "--limits", "load_viscous,tach_offset", "--json")
    assert run.returncode == 0, run.stderr
    assert d.report == json.loads(run.stdout)
    assert "limits" not in gs.diagnose(p, str(path), max_steps=0).report
    with pytest.raises(gs.InputError, match=r"^limits: unknown effect `nope`"):
        gs.diagnose(p, str(path), max_steps=0, limits=["nope"])


def test_a_misspelt_option_is_named_by_its_keyword(measured):
    path, record = measured
    p = gs.Params.reference()
    with pytest.raises(gs.InputError, match=r"^candidates: unknown effect `stiction`"):
        gs.diagnose(p, str(path), candidates=["load_viscous", "stiction"])
    with pytest.raises(gs.InputError, match=r"^fit: `nope` cannot be calibrated"):
        gs.diagnose(p, str(path), fit=["nope"])


def test_a_dataframe_or_a_dict_is_the_same_record_as_its_csv(measured):
    path, record = measured
    p = gs.Params.reference()
    frame = pd.DataFrame(record).assign(comment="bench 1")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from_frame = gs.diagnose(p, frame, max_steps=0)
    assert any("column `comment` is not used" in str(w.message) for w in caught)
    from_dict = gs.diagnose(p, {k: np.asarray(v) for k, v in record.items()}, max_steps=0)
    from_csv = gs.diagnose(p, path, max_steps=0)
    structured = np.rec.fromarrays([record[k] for k in record], names=list(record))
    from_structured = gs.diagnose(p, structured, max_steps=0)
    assert from_frame.report == from_dict.report == from_csv.report == from_structured.report
    with pytest.raises(gs.InputError, match=r"^a record is a CSV path, a pandas DataFrame"):
        gs.diagnose(p, 42)


def test_diagnose_reports_each_phase_and_stops_when_asked(measured):
    path, _ = measured
    p = gs.Params.reference()
    seen = []
    watched = gs.diagnose(p, str(path), max_steps=0, progress=seen.append)
    assert watched.report == gs.diagnose(p, str(path), max_steps=0).report
    assert seen[0] == "pass: 1 record, their noise levels estimated", seen
    assert seen[1].startswith("pass: base settled, NRMSE "), seen
    assert seen[-1] == "fine search", seen

    class Stop(Exception):
        pass

    calls = []

    def stop(stage):
        calls.append(stage)
        raise Stop(stage)

    # An exception of the callback stops the diagnosis at once and is raised again.
    with pytest.raises(Stop, match="noise levels estimated"):
        gs.diagnose(p, str(path), max_steps=0, progress=stop)
    assert calls == ["pass: 1 record, their noise levels estimated"]
    # So does an interrupt (Ctrl-C), seen between phases. Python's own handler, which turns
    # SIGINT into KeyboardInterrupt, is installed here: a test run in the background (as CI's
    # can be) inherits SIGINT ignored, and Python then keeps it ignored.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            gs.diagnose(p, str(path), max_steps=0, progress=lambda stage: os.kill(os.getpid(), signal.SIGINT))
    finally:
        signal.signal(signal.SIGINT, previous)
