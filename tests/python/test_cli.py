"""The Python module gives what the `servokit` command writes: the same sweep tables, the same
solve, the same analyze JSON (issue #17). Both sides are parsed; numbers compare exactly, since
the command writes them in shortest round-trip form."""
import csv
import json
import math
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


def test_solve_equals_the_command_line_csv(servokit_binary, mass_on_car, tmp_path):
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
    assert summary.pop("out") == str(python_csv) and expected.pop("out") == str(cli_csv)
    assert summary == expected
    numpy_table = model.solve(**SOLVE, table="numpy").table
    assert_table_equals_csv(numpy_table, cli_csv)


def test_analysis_to_dict_equals_analyze_json(servokit_binary, mass_on_car):
    printed = run(servokit_binary, "analyze", mass_on_car, "--set", "alpha=5 deg", "--set", "d=0",
                  "--format", "json")
    analysis = servokit.load(mass_on_car, alpha="5 deg", d=0).analyze()
    assert analysis.to_dict() == json.loads(printed)
    assert analysis.json + "\n" == printed or analysis.json == printed
    at_y0 = run(servokit_binary, "analyze", mass_on_car, "--y0", "0.25", "--format", "json")
    assert servokit.load(mass_on_car).analyze(y0=0.25).to_dict() == json.loads(at_y0)
