"""Errors raise servokit.UsageError, ModelError and NoSolution (all servokit.Error), each by the
kind of the C++ error and with the command line's one-line message (issue #17)."""
import os
import pathlib
import subprocess
import sys

import pytest

import servokit

DATA = pathlib.Path(__file__).parents[1] / "data"
MODELS = pathlib.Path(__file__).parents[2] / "models"


def command_line_message(binary, *arguments):
    completed = subprocess.run([binary, *map(str, arguments)], capture_output=True, text=True)
    assert completed.returncode != 0
    line = completed.stderr.strip()
    assert line.startswith("servokit: error: ") and "\n" not in line
    return line[len("servokit: error: "):]


def test_the_classes_form_a_hierarchy():
    for kind in (servokit.UsageError, servokit.ModelError, servokit.NoSolution):
        assert issubclass(kind, servokit.Error)
    assert issubclass(servokit.Error, Exception)
    # Each is also the Python exception it means (issue #34): a bad argument or model file is a
    # ValueError, a problem without a solution a RuntimeError.
    assert issubclass(servokit.UsageError, ValueError)
    assert issubclass(servokit.ModelError, ValueError)
    assert issubclass(servokit.NoSolution, RuntimeError)


def test_python_code_catches_them_by_their_python_meaning():
    with pytest.raises(ValueError, match="unknown parameter 'nosuch'"):
        servokit.load(MODELS / "mass_on_car.yaml", nosuch=1)
    with pytest.raises(RuntimeError, match="no equilibrium found"):
        servokit.load(DATA / "tora.yaml").analyze(y0=[0.01])


def test_a_bad_model_file_is_a_model_error_with_the_command_line_message(servokit_binary):
    path = DATA / "errors" / "duplicate_key.yaml"
    with pytest.raises(servokit.ModelError) as raised:
        servokit.load(str(path))
    assert str(raised.value) == command_line_message(servokit_binary, "analyze", path)


def test_bad_yaml_text_is_a_model_error():
    with pytest.raises(servokit.ModelError, match="<string>"):
        servokit.load("name: x\ncoordinates: [q]\n")


def test_no_equilibrium_is_no_solution_with_the_command_line_message(servokit_binary):
    path = DATA / "no_equilibrium.yaml"
    with pytest.raises(servokit.NoSolution) as raised:
        servokit.load(str(path)).analyze()
    assert str(raised.value) == command_line_message(servokit_binary, "analyze", path)


def test_bad_arguments_are_usage_errors(mass_on_car):
    with pytest.raises(servokit.UsageError, match="nope"):
        servokit.load(mass_on_car, nope=1)
    with pytest.raises(servokit.UsageError, match="alpha"):
        servokit.load(mass_on_car, alpha=[1, 2])
    model = servokit.load(mass_on_car)
    with pytest.raises(servokit.UsageError, match="weather"):
        model.threshold("alpha", 0.1, 1.0, event="weather")
    with pytest.raises(servokit.UsageError, match="ode45"):
        model.solve(y0=0, yf=1, tf=1, t_end=2, method="ode45")
    with pytest.raises(servokit.UsageError, match="y0, yf and tf"):
        model.solve(y0=0, t_end=2)
    with pytest.raises(servokit.UsageError, match="table"):
        model.sweep({"d": [0, 1]}, table="excel")
    with pytest.raises(servokit.UsageError):
        model.sweep({"nope": [0, 1]})
    with pytest.raises(servokit.UsageError, match="masses"):
        servokit.generate.chain(masses=0, out="/nonexistent")


@pytest.mark.parametrize("call, message", [
    (lambda model: model.solve(y0=0, yf=1, tf=1, t_end=2, method="ode45"),
     "SolveOptions::method = ode45: expected auto, algebraic, euler, radau, bdf, normal-form, "
     "stable-inversion or linearized"),
    (lambda model: model.solve(y0=0, yf=1, tf=1, t_end=2, format="hdf5"),
     "SolveOptions::file_format = hdf5: expected csv, mat or modelica (or empty: from out_file)"),
    (lambda model: model.threshold("alpha", 0.1, 1.0, event="weather"),
     "ThresholdQuery::event = weather: expected stability, oscillation, realization or "
     "structure"),
    (lambda model: model.analyze(eigen_solver="qr"),
     "AnalyzeOptions::eigen_solver = qr: expected auto, dense or arpack"),
    (lambda model: model.analyze(which="leftmost"),
     "AnalyzeOptions::which = leftmost: expected nearest or rightmost"),
])
def test_a_word_that_names_nothing_is_a_usage_error_naming_the_option(mass_on_car, call,
                                                                      message):
    # Python passes the toolkit's words; the module reads them with the vocabulary's tables
    # (servokit/servokit.h) and says what the library's option check says.
    with pytest.raises(servokit.UsageError) as raised:
        call(servokit.load(mass_on_car))
    assert str(raised.value) == message


def test_a_missing_file_is_an_error(tmp_path):
    with pytest.raises(servokit.Error):
        servokit.load(str(tmp_path / "missing.yaml"))


def test_too_many_threads_is_a_usage_error_naming_threads(mass_on_car):
    # libgomp crashed the interpreter at threads=10**6; the limit is kMaxSweepThreads = 1024.
    model = servokit.load(mass_on_car)
    with pytest.raises(servokit.UsageError, match=r"threads = 1000000: must be <= 1024"):
        model.sweep({"d": [0.0, 1.0]}, threads=10**6)


def test_omp_num_threads_above_the_limit_is_a_usage_error_naming_it(mass_on_car):
    # OpenMP reads the variable when the module loads, so it is set for a fresh interpreter.
    script = ("import servokit, sys\n"
              "try:\n"
              "    servokit.load(sys.argv[1]).sweep({'d': [0.0, 1.0]})\n"
              "except servokit.UsageError as error:\n"
              "    print(error)\n")
    completed = subprocess.run([sys.executable, "-c", script, mass_on_car], capture_output=True,
                               text=True, env={**os.environ, "OMP_NUM_THREADS": "100000"})
    assert completed.returncode == 0, completed.stderr
    assert completed.stdout == "OMP_NUM_THREADS=100000: 100000 threads: must be at most 1024\n"


def test_trajectory_sizes_beyond_their_limits_are_usage_errors(mass_on_car):
    model = servokit.load(mass_on_car)
    with pytest.raises(servokit.UsageError,
                       match="continuous derivatives = 1000000: must be from 1 to 32"):
        model.solve(function=lambda t, order: 0.0, continuous_derivatives=10**6, t_end=2)
    times = [float(i) for i in range(1_000_001)]
    with pytest.raises(servokit.UsageError, match="1000001 samples: at most 1000000"):
        model.solve(samples=(times, [0.0] * len(times)), t_end=2)
