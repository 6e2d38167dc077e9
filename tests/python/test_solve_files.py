"""`servokit solve --format mat|modelica` (issue #17): the files MATLAB, SciPy and Modelica read
hold the numbers of the CSV that the same solve writes. The MAT file is read with
scipy.io.loadmat, the Modelica table with the small parser below; every number compares
exactly with the CSV field (both are written to read back to the same double), and the MAT
file's struct `solve` with the JSON summary the run prints. Both files are byte-identical run
to run."""
import csv
import json
import pathlib
import subprocess

import numpy as np
import pytest

scipy_io = pytest.importorskip("scipy.io")

# Paper Sect. 5.1 case 2 (alpha = 5 deg, d = 1), sampled every 10 ms; and the rotational arm with
# s = l (unstable zero dynamics), whose stable inversion adds the pre- and post-actuation times.
CASE_2 = ["--set", "alpha=5 deg", "--trajectory", "rest-to-rest", "--y0", "0.5", "--yf", "2.5",
          "--t0", "0", "--tf", "6", "--t-end", "10", "--sample-time", "0.01", "--verify"]
ARM = ["--trajectory", "rest-to-rest", "--y0", "0", "--yf", "1", "--t0", "0", "--tf", "2",
       "--t-end", "4", "--verify"]


def solve(binary, model, arguments, out, *more):
    completed = subprocess.run([binary, "solve", model, *arguments, "--out", str(out), *more],
                               capture_output=True, text=True)
    assert completed.returncode == 0, completed.stderr
    return json.loads(completed.stdout)


def read_csv(path):
    with open(path, newline="") as file:
        rows = list(csv.reader(file))
    return rows[0], rows[1:]


def assert_equals_json(value, expected, where):
    """A MAT value (as loadmat gives it) equals the JSON value: numbers exactly, null and []
    as empty, text as text, true/false as logical, objects as structs, lists as rows or cells."""
    if expected is None or expected == []:
        assert value.size == 0, where
    elif isinstance(expected, bool):
        assert value.dtype == np.uint8 and value.shape == (1, 1) and bool(value[0, 0]) == expected, where
    elif isinstance(expected, (int, float)):
        assert value.dtype == np.float64 and value.shape == (1, 1), where
        assert value[0, 0] == float(expected), where
    elif isinstance(expected, str):
        assert value.shape == (1,) and str(value[0]) == expected, where
    elif isinstance(expected, dict):
        assert value.shape == (1, 1), where
        assert list(value.dtype.names) == list(expected), where
        for key, item in expected.items():
            assert_equals_json(value[0, 0][key], item, where + "." + key)
    elif all(isinstance(item, (int, float)) and not isinstance(item, bool) for item in expected):
        assert value.dtype == np.float64 and value.shape == (1, len(expected)), where
        assert list(value[0]) == [float(item) for item in expected], where
    else:
        assert value.dtype == object and value.shape == (1, len(expected)), where
        for k, item in enumerate(expected):
            assert_equals_json(value[0, k], item, f"{where}[{k}]")


def assert_mat_equals_csv_and_json(mat_path, csv_path, summary, degrees=("alpha",),
                                   breakpoints=(0.0, 6.0)):
    """`degrees`: the parameters the model gives in degrees; `breakpoints`: t0 and tf."""
    header, rows = read_csv(csv_path)
    mat = scipy_io.loadmat(mat_path)
    variables = [name for name in mat if not name.startswith("__")]
    assert variables == header + ["solve"]
    for j, name in enumerate(header):
        column = mat[name]
        assert column.dtype == np.float64 and column.shape == (len(rows), 1), name
        assert [float(row[j]) for row in rows] == list(column[:, 0]), name
    facts = mat["solve"]
    expected = {key: value for key, value in summary.items()
                if key not in ("classification", "out")}
    expected["columns"] = header
    # What the numbers are of: the model, its parameters (SI) and their units, y_d's motion.
    classification = summary["classification"]
    expected["model"] = classification["model"]
    expected["parameters"] = classification["parameters"]
    expected["parameter_units"] = {
        name: "deg" if name in degrees else "SI" for name in classification["parameters"]}
    expected["trajectory_breakpoints"] = list(breakpoints)
    assert_equals_json(facts, expected, "solve")


def test_mat_file_holds_the_csv_columns_and_the_json_summary(servokit_binary, mass_on_car,
                                                            tmp_path):
    csv_summary = solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "u.csv")
    # The format from the name, and the same asked for.
    summary = solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "u.mat")
    solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "v.mat", "--format", "mat")
    assert summary["out"] == str(tmp_path / "u.mat")
    assert summary["verification"]["passed"] is True
    assert {k: v for k, v in summary.items() if k != "out"} == \
        {k: v for k, v in csv_summary.items() if k != "out"}
    assert_mat_equals_csv_and_json(tmp_path / "u.mat", tmp_path / "u.csv", summary)
    # The bytes do not depend on the run, nor on the file's name.
    first = (tmp_path / "u.mat").read_bytes()
    solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "u.mat")
    assert (tmp_path / "u.mat").read_bytes() == first
    assert (tmp_path / "v.mat").read_bytes() == first
    assert first[:40] == b"MATLAB 5.0 MAT-file, written by servokit"
    assert not list(tmp_path.glob("*.partial"))


def test_mat_file_of_a_stable_inversion_gives_the_actuation_times(servokit_binary, mass_on_car,
                                                                 tmp_path):
    arm = str(pathlib.Path(mass_on_car).with_name("rotational_arm.yaml"))
    solve(servokit_binary, arm, ARM, tmp_path / "u.csv")
    summary = solve(servokit_binary, arm, ARM, tmp_path / "u.mat")
    assert summary["method"] == "stable-inversion"
    # models/rotational_arm.yaml: no parameter in degrees; ARM moves from t0 = 0 to tf = 2.
    assert_mat_equals_csv_and_json(tmp_path / "u.mat", tmp_path / "u.csv", summary, degrees=(),
                                   breakpoints=(0.0, 2.0))
    facts = scipy_io.loadmat(tmp_path / "u.mat")["solve"][0, 0]
    assert facts["pre_actuation_start"][0, 0] == summary["pre_actuation_start"]
    assert facts["post_actuation_end"][0, 0] == summary["post_actuation_end"]
    assert facts["pre_actuation_start"][0, 0] < 0  # non-causal: u_d starts before the motion


def read_modelica_tables(path):
    """CombiTimeTable's text format (Modelica.Blocks.Sources.CombiTimeTable, "#1"): the first
    line "#1", comment lines starting with #, then matrices, each `double NAME(ROWS, COLUMNS)`
    followed by ROWS lines of COLUMNS numbers separated by blanks. Returns the comments and
    {name: rows}, checking each matrix's declared size."""
    lines = pathlib.Path(path).read_text().splitlines()
    assert lines[0] == "#1"
    comments, tables, k = [], {}, 1
    while k < len(lines):
        line = lines[k]
        if line.startswith("#"):
            comments.append(line)
            k += 1
            continue
        assert line.startswith("double ") and line.endswith(")"), line
        name, dimensions = line[len("double "):-1].split("(")
        rows, columns = (int(text) for text in dimensions.split(","))
        table = [[float(text) for text in row.split()] for row in lines[k + 1:k + 1 + rows]]
        assert len(table) == rows and all(len(row) == columns for row in table)
        tables[name] = table
        k += 1 + rows
    return comments, tables


def test_modelica_table_holds_t_and_the_inputs_of_the_csv(servokit_binary, mass_on_car,
                                                         tmp_path):
    solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "u.csv")
    solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "u.txt", "--format", "modelica")
    header, rows = read_csv(tmp_path / "u.csv")
    comments, tables = read_modelica_tables(tmp_path / "u.txt")
    assert list(tables) == ["u_d", "q_d", "y_d"]
    # models/mass_on_car.yaml: input F, coordinates x and s, output y1; the CSV's columns.
    for name, columns in [("u_d", ["F"]), ("q_d", ["x", "s", "x_dot", "s_dot"]),
                          ("y_d", ["y1_d"])]:
        table = tables[name]
        assert len(table) == len(rows) == 1001
        for j, column in enumerate(columns, start=1):
            assert [float(row[header.index(column)]) for row in rows] == [row[j] for row in table]
        # Times on the 0.01 s grid, written as the grid's decimals (0.07, not 0.07000000000000001),
        # within round-off of the CSV's exact ones.
        times = [row[0] for row in table]
        assert times == [k / 100 for k in range(1001)]
        assert times == pytest.approx([float(row[0]) for row in rows], rel=1e-15, abs=1e-15)
    assert any("table u_d: column 1 t [s], 2 F" in comment for comment in comments)
    assert any("3 s, 4 x_dot" in comment for comment in comments)
    first = (tmp_path / "u.txt").read_bytes()
    solve(servokit_binary, mass_on_car, CASE_2, tmp_path / "u.txt", "--format", "modelica")
    assert (tmp_path / "u.txt").read_bytes() == first


@pytest.mark.parametrize("arguments, says", [
    (["--format", "mat", "--out", "u.csv"],
     "--format mat --out u.csv: a MAT file's name must end in .mat"),
    (["--format", "csv", "--out", "u.mat"],
     "--format csv --out u.mat: a name ending in .mat is for a MAT file, not csv"),
    (["--format", "modelica", "--out", "u.csv"],
     "--format modelica --out u.csv: a name ending in .csv is for CSV, not a Modelica table"),
    (["--format", "hdf5", "--out", "u.h5"], "--format hdf5: expected csv, mat or modelica"),
])
def test_a_format_that_contradicts_the_name_is_refused_before_solving(
        servokit_binary, mass_on_car, tmp_path, arguments, says):
    completed = subprocess.run([servokit_binary, "solve", mass_on_car, *CASE_2, *arguments],
                               capture_output=True, text=True, cwd=tmp_path)
    assert completed.returncode == 2
    assert completed.stderr.startswith("servokit: error: " + says)
    assert completed.stderr.count("\n") == 1
    assert completed.stdout == ""
    assert not list(tmp_path.iterdir())


def test_a_column_matlab_cannot_load_is_refused_before_solving(servokit_binary, mass_on_car,
                                                               tmp_path):
    # The mass on car with the coordinate s named `end`, which `load` cannot make a variable.
    model = (pathlib.Path(mass_on_car).parents[1] / "tests" / "data" / "errors" /
             "matlab_keyword_coordinate.yaml")
    out = tmp_path / "u.mat"
    completed = subprocess.run([servokit_binary, "solve", str(model), *CASE_2, "--out", str(out)],
                               capture_output=True, text=True)
    assert completed.returncode == 2
    assert completed.stderr == (f"servokit: error: {out}: the column 'end' cannot be a MAT "
                                "variable: a MATLAB keyword; rename it in the model file or "
                                "write CSV\n")
    assert not out.exists()
    solve(servokit_binary, str(model), CASE_2, tmp_path / "u.csv")  # CSV takes any name


def test_the_module_writes_the_same_files_as_the_command(servokit_binary, mass_on_car, tmp_path):
    import servokit

    model = servokit.load(mass_on_car)
    for name, file_format in [("u.mat", ""), ("u.txt", "modelica")]:
        arguments = CASE_2 + (["--format", file_format] if file_format else [])
        solve(servokit_binary, mass_on_car, arguments, tmp_path / ("command-" + name))
        model.solve(y0=0.5, yf=2.5, t0=0, tf=6, t_end=10, sample_time=0.01, verify=True,
                    out=tmp_path / ("module-" + name), format=file_format)
        assert ((tmp_path / ("module-" + name)).read_bytes() ==
                (tmp_path / ("command-" + name)).read_bytes())
