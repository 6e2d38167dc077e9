"""The Python module gives what the `servokit` command writes: the same sweep tables, the same
solve, the same analyze JSON (issue #17). Both sides are parsed; numbers compare exactly, since
the command writes them in shortest round-trip form."""
import csv
import json
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

import servokit


def run(binary, *arguments):
    completed = subprocess.run([binary, *map(str, arguments)], capture_output=True, text=True)
    assert completed.returncode == 0, completed.stderr
    return completed.stdout


def is_missing(value):
    """An empty CSV field: None, pandas.NA, NaN or empty text."""
    if value is None or (isinstance(value, str) and value == ""):
        return True
    try:
        import pandas
        if value is pandas.NA:
            return True
    except ImportError:
        pass
    try:
        return bool(np.isnan(value))
    except TypeError:
        return False


def column(table, name):
    return list(table[name])


def assert_table_equals_csv(table, path, missing_integer=None):
    """Every field of the CSV at `path` equals the table's cell: empty fields are missing cells
    (or `missing_integer` in a numpy structured array), numbers exact, text as written."""
    with open(path, newline="") as file:
        rows = list(csv.reader(file))
    header, rows = rows[0], rows[1:]
    names = list(table.columns) if hasattr(table, "columns") else list(table.dtype.names)
    assert names == header
    assert len(table) == len(rows)
    for j, name in enumerate(header):
        values = column(table, name)
        for i, row in enumerate(rows):
            field, value = row[j], values[i]
            if field == "":
                assert is_missing(value) or value == missing_integer, (name, i, value)
            elif isinstance(value, str):
                assert value == field, (name, i)
            else:
                assert float(value) == float(field), (name, i, value, field)


GRID = {"alpha": [0.0, math.radians(5), math.radians(30), math.pi / 2], "d": [0.0, 1.0]}


@pytest.fixture
def cli_sweep(servokit_binary, mass_on_car, tmp_path):
    run(servokit_binary, "sweep", mass_on_car,
        "--vary", "alpha=" + ",".join(repr(v) for v in GRID["alpha"]),
        "--vary", "d=" + ",".join(repr(v) for v in GRID["d"]), "--out", tmp_path / "sweep")
    return tmp_path / "sweep"


def test_sweep_dataframes_equal_the_command_line_csv(cli_sweep, mass_on_car):
    pandas = pytest.importorskip("pandas")
    points, eigenvalues = servokit.load(mass_on_car).sweep(GRID, threads=2)
    assert isinstance(points, pandas.DataFrame) and isinstance(eigenvalues, pandas.DataFrame)
    assert str(points["P_rank"].dtype) == "Int64"
    assert_table_equals_csv(points, cli_sweep / "points.csv")
    assert_table_equals_csv(eigenvalues, cli_sweep / "eigenvalues.csv")
    # alpha = 0, d = 0 is flat: no eigenvalues, an empty max_real_part.
    assert math.isnan(points["max_real_part"][0])


def test_sweep_structured_arrays_equal_the_command_line_csv(cli_sweep, mass_on_car):
    points, eigenvalues = servokit.load(mass_on_car).sweep(GRID, table="numpy")
    assert isinstance(points, np.ndarray) and points.dtype.names[:2] == ("alpha_deg", "d")
    assert points["P_rank"].dtype == np.int64
    assert_table_equals_csv(points, cli_sweep / "points.csv", missing_integer=-1)
    assert_table_equals_csv(eigenvalues, cli_sweep / "eigenvalues.csv", missing_integer=-1)


SOLVE = {"y0": 0.5, "yf": 2.5, "t0": 0, "tf": 6, "t_end": 10, "sample_time": 0.25}


def test_solve_equals_the_command_line_csv(servokit_binary, mass_on_car, tmp_path,
                                           assert_agrees):
    # Damped (d = 1) at 5 deg: stable internal dynamics, integrated forward.
    cli_csv = tmp_path / "cli.csv"
    printed = run(servokit_binary, "solve", mass_on_car, "--set", "alpha=5 deg", "--set", "d=1",
                  "--trajectory", "rest-to-rest", "--y0", SOLVE["y0"], "--yf", SOLVE["yf"],
                  "--t0", SOLVE["t0"], "--tf", SOLVE["tf"], "--t-end", SOLVE["t_end"],
                  "--sample-time", SOLVE["sample_time"], "--verify", "--out", cli_csv)
    model = servokit.load(mass_on_car, alpha="5 deg", d=1)
    python_csv = tmp_path / "python.csv"
    result = model.solve(**SOLVE, verify=True, out=python_csv)
    assert result.usable
    assert_table_equals_csv(result.table, cli_csv)
    assert python_csv.read_bytes() == cli_csv.read_bytes()
    summary, expected = result.summary, json.loads(printed)
    assert summary.out_file == str(python_csv) and expected.pop("out") == str(cli_csv)
    # The attributes against the command's JSON (the writer of `servokit solve`, not the
    # binding): every number exact, a null as NaN or None.
    attributes = {name: getattr(summary, name) for name in (
        "method", "method_reason", "status", "message", "stop_time", "t_start", "t_end",
        "sample_time", "steps", "rejected_steps", "newton_iterations", "function_evaluations",
        "samples", "max_servo_residual", "warnings")}
    attributes["tolerances"] = {"rtol": summary.rtol, "atol": summary.atol, "step": summary.step}
    assert set(attributes) <= set(expected)
    assert_agrees(attributes, expected)
    verification = summary.verification
    assert_agrees({name: getattr(verification, name) for name in (
        "passed", "max_tracking_error", "time_of_max_error", "bound", "bound_rule", "segments",
        "status", "message", "steps")}, expected["verification"])
    assert verification.passed is True
    classification = summary.classification
    assert_agrees({name: getattr(classification, name) for name in (
        "P_rank", "realization", "relative_degree", "differentiation_index", "projected_index",
        "internal_dynamics_order", "flat", "recommended_solver")}, expected["classification"])
    assert classification.stability == expected["classification"]["zero_dynamics"]["stability"]
    assert [complex(e["re"], e["im"]) for e in expected["classification"]["zero_dynamics"][
        "eigenvalues"]] == list(classification.eigenvalues)
    # to_dict() agrees on every key the two share, and `json` is the printed object.
    fields = summary.to_dict()
    assert fields.pop("out") == str(python_csv)
    assert_agrees(fields, expected)
    assert json.loads(summary.json) == {**expected, "out": str(python_csv)}
    numpy_table = model.solve(**SOLVE, table="numpy").table
    assert_table_equals_csv(numpy_table, cli_csv)


def test_analysis_to_dict_agrees_with_analyze_json(servokit_binary, mass_on_car,
                                                   assert_agrees):
    # to_dict() is built from the fields, under the JSON's keys and in its layout; the JSON has
    # report-only keys besides (the model, P's singular values, the nonlinear structure, ...).
    printed = run(servokit_binary, "analyze", mass_on_car, "--set", "alpha=5 deg", "--set", "d=0",
                  "--format", "json")
    analysis = servokit.load(mass_on_car, alpha="5 deg", d=0).analyze()
    expected = json.loads(printed)
    fields = analysis.to_dict()
    assert set(fields) <= set(expected)
    assert set(fields["zero_dynamics"]) <= set(expected["zero_dynamics"])
    assert_agrees(fields, expected)
    assert fields["realization"] == analysis.realization == expected["realization"]
    assert fields["zero_dynamics"]["stability"] == analysis.stability == "critical"
    assert analysis.json + "\n" == printed or analysis.json == printed
    at_y0 = run(servokit_binary, "analyze", mass_on_car, "--y0", "0.25", "--format", "json")
    fields = servokit.load(mass_on_car).analyze(y0=0.25).to_dict()
    assert fields["operating_point"]["y"] == [0.25]
    assert_agrees(fields, json.loads(at_y0))


MODELS = pathlib.Path(os.environ.get("SERVOKIT_MODELS_DIR",
                                     pathlib.Path(__file__).parents[2] / "models"))


@pytest.mark.parametrize("name", sorted(path.name for path in MODELS.glob("*.yaml")))
def test_analysis_to_dict_agrees_with_analyze_json_for_every_shipped_model(
        servokit_binary, assert_agrees, name):
    printed = json.loads(run(servokit_binary, "analyze", MODELS / name, "--format", "json"))
    fields = servokit.load(str(MODELS / name)).analyze().to_dict()
    assert set(fields) <= set(printed)
    assert_agrees(fields, printed)


def test_a_linear_models_to_dict_agrees_with_analyze_json(servokit_binary, tmp_path,
                                                          assert_agrees):
    path = servokit.generate.chain(masses=20, out=tmp_path)
    printed = json.loads(run(servokit_binary, "analyze", path, "--format", "json"))
    fields = servokit.load(path).analyze().to_dict()
    assert set(fields) <= set(printed)
    # One field a linear model's report writes otherwise: q holds the dof zeros the report
    # leaves out ("not listed"). P is the decoupling matrix in both: the force on mass 1 moves
    # mass 1 by F/m, m = 1 kg.
    assert fields["P"] == [[1.0]]
    assert fields["operating_point"].pop("q") == [0.0] * 20
    assert printed["operating_point"].pop("q") == []
    assert_agrees(fields, printed)
