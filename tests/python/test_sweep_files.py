"""`servokit sweep --format hdf5|mat` writes the tables of points.csv and eigenvalues.csv into
sweep.h5 and sweep.mat (issue #17). The reference is the CSV of the same sweep, read with pandas:
every number must be the same double (the CSV holds shortest round-trip text; Python's float()
reads it exactly), every text the same, an empty CSV field NaN (numbers) or "" (text). Interrupted and resumed, or run on more
threads, a sweep must give the same bytes."""
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

pandas = pytest.importorskip("pandas")
h5py = pytest.importorskip("h5py")
scipy_io = pytest.importorskip("scipy.io")

DATA = pathlib.Path(__file__).parents[1] / "data"


def sweep(binary, model, vary, out, *extra, env=None, status=0):
    arguments = [binary, "sweep", str(model), "--out", str(out)]
    for text in vary:
        arguments += ["--vary", text]
    arguments += [str(value) for value in extra]
    completed = subprocess.run(arguments, capture_output=True, text=True,
                               env={**os.environ, **(env or {})})
    assert completed.returncode == status, completed.stderr
    return completed


def hdf5_table(group):
    """A group of sweep.h5 as a DataFrame: one column per dataset, in the order of `columns`."""
    columns = {}
    for name in group.attrs["columns"]:
        dataset = group[name]
        columns[name] = dataset.asstr()[()] if dataset.dtype.kind == "S" else dataset[()]
    return pandas.DataFrame(columns)


def mat_table(structure):
    """A struct of sweep.mat (scipy.io.loadmat) as a DataFrame: doubles as they are, a cell of
    char rows as text ('' for an empty char array)."""
    columns = {}
    for name in structure.dtype.names:
        value = structure[name][0, 0]
        if value.dtype == object:
            columns[name] = ["".join(cell.ravel()) if cell.size else "" for cell in value.ravel()]
        else:
            columns[name] = value.ravel()
    return pandas.DataFrame(columns)


def assert_same_table(table, csv_path):
    with open(csv_path) as file:
        header = file.readline().rstrip("\n").split(",")
    assert list(table.columns) == header  # unique: a clash is refused before the sweep
    number_columns = [name for name in table.columns if table[name].dtype.kind == "f"]
    expected = pandas.read_csv(csv_path, dtype=str, keep_default_na=False)
    for name in number_columns:
        expected[name] = [float(text) if text else math.nan for text in expected[name]]
    # check_exact: the same doubles, not close ones; NaN equals NaN here.
    assert len(table) == len(expected)
    pandas.testing.assert_frame_equal(table.reset_index(drop=True),
                                      expected.reset_index(drop=True), check_exact=True,
                                      check_dtype=False, check_index_type=False)


# Sweeps that reach every kind of cell: flat points (no eigenvalues: max_real_part empty), a
# parameter in degrees, two outputs (relative_degree "a;b"), points without a solution.
SWEEPS = {
    "mass_on_car": ("models/mass_on_car.yaml", ["alpha=0deg:90deg:7", "d=0:2:5"], []),
    "gantry_crane": ("models/gantry_crane.yaml", ["m=5,10"], []),
    "no_equilibrium": ("tests/data/no_equilibrium.yaml", ["a=-1,1"], ["--q0", "0,0.5"]),
    # A varied parameter named like the eigenvalue index column k.
    "chain": ("tests/data/chain_output_x3.yaml", ["m=0.5,2", "k=50:150:3"], []),
}


def model_path(relative):
    root = pathlib.Path(__file__).parents[2]
    return root / relative


@pytest.mark.parametrize("name", SWEEPS)
def test_hdf5_and_mat_hold_the_csv_tables(servokit_binary, tmp_path, name):
    model, vary, extra = SWEEPS[name]
    for file_format in ("csv", "hdf5", "mat"):
        sweep(servokit_binary, model_path(model), vary, tmp_path / file_format, "--format",
              file_format, *extra)
    csv = tmp_path / "csv"
    with h5py.File(tmp_path / "hdf5" / "sweep.h5", "r") as file:
        assert_same_table(hdf5_table(file["points"]), csv / "points.csv")
        assert_same_table(hdf5_table(file["eigenvalues"]), csv / "eigenvalues.csv")
    mat = scipy_io.loadmat(tmp_path / "mat" / "sweep.mat")
    assert_same_table(mat_table(mat["points"]), csv / "points.csv")
    assert_same_table(mat_table(mat["eigenvalues"]), csv / "eigenvalues.csv")


def test_the_files_record_the_model_the_grid_and_the_units(servokit_binary, tmp_path,
                                                           mass_on_car):
    for file_format in ("hdf5", "mat"):
        sweep(servokit_binary, mass_on_car, ["alpha=5deg,10deg", "d=0:2:3"],
              tmp_path / file_format, "--format", file_format)
    with h5py.File(tmp_path / "hdf5" / "sweep.h5", "r") as file:
        assert file.attrs["model"] == "mass_on_car"
        assert len(file.attrs["model_content_hash"]) > 0
        # The grid in SI: 5 and 10 degrees in radians (alpha shown in degrees), d as given.
        grid = file.attrs["grid"]
        assert grid.startswith("alpha=[") and grid.endswith("] shown in deg d=0:2:3")
        assert [float(v) for v in grid[len("alpha=["):grid.index("]")].split(",")] == [
            math.radians(5), math.radians(10)]
        assert file.attrs["servokit_version"]
        units = {name: file["eigenvalues"][name].attrs["unit"]
                 for name in file["eigenvalues"].attrs["columns"]}
        assert units["re"] == units["im"] == "1/s"
        assert units["frequency_hz"] == "Hz"
        assert units["damping_ratio"] == "1"
        assert file["points"]["max_real_part"].attrs["unit"] == "1/s"
        assert file["points"]["d"].attrs["unit"] == ""
        # h5py lists the datasets in table order.
        assert list(file["points"]) == list(file["points"].attrs["columns"])
        hdf5_attributes = dict(file.attrs)
    about = scipy_io.loadmat(tmp_path / "mat" / "sweep.mat", simplify_cells=True)["sweep"]
    for key in ("model", "model_content_hash", "grid", "servokit_version"):
        assert about[key] == hdf5_attributes[key]
    assert about["eigenvalues_units"]["frequency_hz"] == "Hz"
    assert about["points_units"]["max_real_part"] == "1/s"


@pytest.mark.parametrize("file_format,file_name", [("hdf5", "sweep.h5"), ("mat", "sweep.mat")])
def test_interrupted_resumed_or_threaded_sweeps_give_the_same_bytes(servokit_binary, tmp_path,
                                                                    mass_on_car, file_format,
                                                                    file_name):
    vary = ["alpha=0deg:90deg:20", "d=0:2:10"]
    options = ["--format", file_format, "--block-size", "16"]
    sweep(servokit_binary, mass_on_car, vary, tmp_path / "whole", *options, "--threads", "1")
    sweep(servokit_binary, mass_on_car, vary, tmp_path / "threads", *options, "--threads", "2")
    # Stopped after 3 blocks (status 130), then resumed by the same command on another count of
    # threads; then broken by an error after 2 more blocks, and resumed again.
    resumed = tmp_path / "resumed"
    sweep(servokit_binary, mass_on_car, vary, resumed, *options, "--threads", "2",
          env={"SERVOKIT_TEST_STOP_AFTER_BLOCKS": "3"}, status=130)
    assert not (resumed / file_name).exists()
    sweep(servokit_binary, mass_on_car, vary, resumed, *options, "--threads", "1",
          env={"SERVOKIT_TEST_FAIL_AFTER_BLOCKS": "2"}, status=1)
    completed = sweep(servokit_binary, mass_on_car, vary, resumed, *options, "--threads", "1")
    assert "resuming at point" in completed.stderr
    whole = (tmp_path / "whole" / file_name).read_bytes()
    assert (tmp_path / "threads" / file_name).read_bytes() == whole
    assert (resumed / file_name).read_bytes() == whole
    # Nothing but the file and sweep.json is left.
    assert sorted(p.name for p in resumed.iterdir()) == sorted([file_name, "sweep.json"])


def test_a_csv_sweep_is_not_resumed_as_hdf5(servokit_binary, tmp_path, mass_on_car):
    out = tmp_path / "out"
    sweep(servokit_binary, mass_on_car, ["d=0:1:3"], out)
    completed = sweep(servokit_binary, mass_on_car, ["d=0:1:3"], out, "--format", "hdf5",
                      status=2)
    assert "holds another sweep" in completed.stderr


def test_an_unknown_format_is_a_usage_error(servokit_binary, tmp_path, mass_on_car):
    completed = sweep(servokit_binary, mass_on_car, ["d=0:1:3"], tmp_path / "out", "--format",
                      "xlsx", status=2)
    assert completed.stderr == "servokit: error: --format xlsx: must be csv, hdf5 or mat\n"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("file_format,file_name", [("hdf5", "sweep.h5"), ("mat", "sweep.mat")])
def test_a_sweep_killed_again_and_again_resumes_to_the_same_bytes(servokit_binary, tmp_path,
                                                                  file_format, file_name):
    """SIGKILL at random moments (fixed seed), with checkpoints every 20 ms: while records are
    written past the checkpoint, and while the file is built; the same command resumes."""
    import random
    import time
    # Six eigenvalues a point, about 200 000 points/s on one thread: 90 000 points take about
    # half a second, so that most of the random moments below fall inside the run.
    model = DATA / "chain_output_x3.yaml"
    arguments = [servokit_binary, "sweep", str(model), "--vary", "m=0.5:2:300", "--vary",
                 "k=50:150:300", "--out", "out", "--format", file_format, "--threads", "1",
                 "--block-size", "250", "--checkpoint-interval", "0.02"]
    (tmp_path / "reference").mkdir()
    (tmp_path / "killed").mkdir()
    subprocess.run(arguments, cwd=tmp_path / "reference", check=True, capture_output=True)
    generator = random.Random(20261126)
    kills = 0
    for _ in range(12):
        process = subprocess.Popen(arguments, cwd=tmp_path / "killed",
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(generator.uniform(0.0, 0.3))
        process.kill()  # SIGKILL; no effect once it has exited
        status = process.wait()
        if status == 0:
            break
        assert status == -9
        kills += 1
    assert kills >= 3
    # The last run goes to the end (building the MAT file alone may take longer than a delay).
    subprocess.run(arguments, cwd=tmp_path / "killed", check=True, capture_output=True)
    out = tmp_path / "killed" / "out"
    assert (out / file_name).read_bytes() == (tmp_path / "reference" / "out" / file_name).read_bytes()
    assert (out / "sweep.json").read_bytes() == (
        tmp_path / "reference" / "out" / "sweep.json").read_bytes()
    assert sorted(p.name for p in out.iterdir()) == sorted([file_name, "sweep.json"])
