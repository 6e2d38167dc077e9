"""The Model object as Python code uses it (issue #34): read-only parameters, new models by
with_parameters, and pickling, so that multiprocessing, joblib and Dask can fan work out to
processes that load the model again."""
import concurrent.futures
import multiprocessing
import pickle

import pytest

import servokit


def undamped_frequency(model):
    """|Im| of the mass on car's zero pair: m2 sin^2(alpha) s^2 + d s + k = 0 (Eq. 36)."""
    return max(abs(value.imag) for value in model.analyze().zero_dynamics.eigenvalues)


def test_parameters_are_read_only(mass_on_car):
    model = servokit.load(mass_on_car)
    with pytest.raises(TypeError):
        model.parameters["d"] = 1  # an assignment would have changed nothing
    assert model.parameters["k"] == 5.0


def test_with_parameters_makes_a_new_model_with_the_others_kept(mass_on_car):
    model = servokit.load(mass_on_car, alpha=30, d=0)
    stiffer = model.with_parameters(k=7)
    assert stiffer.parameters["k"] == 7.0
    assert stiffer.parameters["alpha"] == model.parameters["alpha"]  # 30 deg, exactly
    assert model.parameters["k"] == 5.0  # the first model is unchanged
    # d = 0: s = +-i sqrt(k / (m2 sin^2 alpha)), m2 = 2, sin 30 deg = 1/2.
    assert undamped_frequency(stiffer) == pytest.approx((7 / 0.5) ** 0.5, rel=1e-12)


def test_a_model_pickles_as_its_file_and_parameters(mass_on_car):
    model = servokit.load(mass_on_car, alpha="45 deg", k=3)
    copy = pickle.loads(pickle.dumps(model))
    assert dict(copy.parameters) == dict(model.parameters)
    assert copy.source == model.source
    text = servokit.load("name: x\nparameters: {}\ncoordinates: [x]\ninputs: [F]\n"
                         "mass_matrix: [[1]]\nforces: [x]\ninput_matrix: [[1]]\noutputs: [x]\n")
    with pytest.raises(servokit.UsageError, match="needs a model loaded from a file"):
        pickle.dumps(text)


def test_processes_analyze_pickled_models(mass_on_car):
    models = [servokit.load(mass_on_car, alpha=alpha, d=0) for alpha in (10, 30, 60)]
    context = multiprocessing.get_context("spawn")  # a fresh interpreter loads each model
    try:
        context.Lock()  # a process pool needs POSIX semaphores (/dev/shm)
    except OSError as error:
        pytest.skip(f"no process pool on this machine: {error}")
    with concurrent.futures.ProcessPoolExecutor(max_workers=2, mp_context=context) as pool:
        frequencies = list(pool.map(undamped_frequency, models))
    assert frequencies == [undamped_frequency(model) for model in models]


def test_sweep_takes_the_operating_point_and_writes_the_command_line_files(tmp_path,
                                                                         servokit_binary):
    import pathlib
    import subprocess
    model = servokit.load(pathlib.Path(__file__).parents[1] / "data" / "ball_and_beam.yaml")
    points, _ = model.sweep({"M": [0.05, 0.1]}, y0=[0.3])
    # Each point as analyze classifies it at the same operating point.
    for mass, relative_degree in zip(points["M"], points["relative_degree"]):
        analysis = model.with_parameters(M=float(mass)).analyze(y0=[0.3])
        assert list(analysis.relative_degree) == [relative_degree]
    assert model.sweep({"M": [0.05, 0.1]}, y0=[0.3], out=tmp_path / "python") == 2
    subprocess.run([servokit_binary, "sweep", model.source, "--vary", "M=0.05,0.1", "--y0", "0.3",
                    "--out", str(tmp_path / "cli")], check=True, capture_output=True)
    for table in ("points.csv", "eigenvalues.csv"):
        assert (tmp_path / "python" / table).read_bytes() == (tmp_path / "cli" / table).read_bytes()


def test_linearization_is_the_state_space_of_eqs_26_27(mass_on_car):
    """(A, B, C, D) of the mass on car at rest, against its matrices written out (Eqs. 26-27):
    M = [[m1 + m2, m2 c], [m2 c, m2]], K = diag(0, k), D = diag(0, d), B = [1, 0], H = [1, c]."""
    import numpy as np
    model = servokit.load(mass_on_car, alpha=30)
    m1, m2, k, d, c = 1.0, 2.0, 5.0, 1.0, np.cos(np.radians(30))
    mass = np.array([[m1 + m2, m2 * c], [m2 * c, m2]])
    inverse = np.linalg.inv(mass)
    A, B, C, D = model.linearization()
    expected_a = np.block([[np.zeros((2, 2)), np.eye(2)],
                           [-inverse @ np.diag([0.0, k]), -inverse @ np.diag([0.0, d])]])
    assert A == pytest.approx(expected_a, abs=1e-14)
    assert B.ravel() == pytest.approx(np.concatenate([[0, 0], inverse @ [1.0, 0.0]]), abs=1e-14)
    assert C.ravel() == pytest.approx([1.0, c, 0.0, 0.0], abs=1e-15)
    assert D.shape == (1, 1) and D[0, 0] == 0.0
    # Its invariant zeros are the zero dynamics analyze reports: the finite eigenvalues of the
    # Rosenbrock pencil [[A, B], [C, D]] - s [[I, 0], [0, 0]].
    pencil = np.block([[A, B], [C, D]])
    identity = np.zeros_like(pencil)
    identity[:4, :4] = np.eye(4)
    import scipy.linalg
    zeros = scipy.linalg.eigvals(pencil, identity)
    zeros = np.sort_complex(zeros[np.isfinite(zeros)])
    assert zeros == pytest.approx(np.sort_complex(model.analyze().zero_dynamics.eigenvalues),
                                  rel=1e-10)


def test_sweep_reports_progress_and_stops_on_its_exception(mass_on_car):
    model = servokit.load(mass_on_car)
    calls = []
    # 5000 points: two blocks of at most 4096, so two calls, the last with every point done.
    points, _ = model.sweep({"d": "0:1:n=5000"}, threads=1,
                            progress=lambda done, total: calls.append((done, total)))
    assert len(points) == 5000
    assert calls == [(4096, 5000), (5000, 5000)]

    def stop(done, total):
        raise RuntimeError(f"stopped at {done} of {total}")

    with pytest.raises(RuntimeError, match="stopped at 4096 of 5000"):
        model.sweep({"d": "0:1:n=5000"}, threads=1, progress=stop)
