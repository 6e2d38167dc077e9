"""The paper's mass on a car (Seifried and Blajer 2013, Sect. 3, Eqs. 26-27) through the
Python module, against closed forms (models/mass_on_car.yaml: m1 = 1, m2 = 2, k = 5); and a
closed chain (Sect. 2, Eqs. 6-7) through the same calls."""
import math

import numpy as np
import pytest

import servokit
from conftest import MODELS

M1, M2, K = 1.0, 2.0, 5.0


def test_undamped_zero_dynamics_at_5_deg(mass_on_car):
    # d = 0 (Eq. 36 with y_d = 0): m2 sin^2(alpha) s'' + k s = 0, so the zero dynamics are
    # +-i sqrt(k / (m2 sin^2 alpha)) = +-18.1415i at alpha = 5 deg.
    model = servokit.load(mass_on_car, alpha="5 deg", d=0)
    assert model.parameters["alpha"] == pytest.approx(math.radians(5), rel=1e-15)
    analysis = model.analyze()
    omega = math.sqrt(K / (M2 * math.sin(math.radians(5)) ** 2))
    assert omega == pytest.approx(18.1415, abs=5e-5)
    assert analysis.realization == "non-ideal-orthogonal"
    assert analysis.relative_degree == [2]
    assert analysis.stability == "critical"
    eigenvalues = analysis.zero_dynamics.eigenvalues
    assert eigenvalues.dtype == np.complex128 and eigenvalues.shape == (2,)
    assert np.allclose(eigenvalues.real, 0.0, atol=1e-9 * omega)
    assert sorted(eigenvalues.imag) == pytest.approx([-omega, omega], rel=1e-10)
    assert analysis.zero_dynamics.modes[0].frequency_hz == pytest.approx(omega / (2 * math.pi),
                                                                         rel=1e-10)
    assert analysis.P.shape == (1, 1)


def test_over_damping_threshold_at_d_1(mass_on_car):
    # m2 sin^2(alpha) s^2 + d s + k = 0 has a double root where d^2 = 4 m2 k sin^2(alpha):
    # alpha = asin(sqrt(1/40)) = 9.0974 deg at d = 1.
    model = servokit.load(mass_on_car, d=1)
    # alpha is declared in degrees: bare numbers are degrees, texts may name their unit.
    thresholds = model.threshold("alpha", 1, 80, event="oscillation")
    assert model.threshold("alpha", "1 deg", f"{math.radians(80)} rad",
                           event="oscillation") == thresholds
    assert len(thresholds) == 1
    assert thresholds[0]["value"] == pytest.approx(math.asin(math.sqrt(1 / 40)), rel=1e-9)
    # alpha is given in degrees by the model: the value in degrees too.
    assert thresholds[0]["value_deg"] == thresholds[0]["value"] * 180 / math.pi
    assert thresholds[0]["from"] != thresholds[0]["to"]


def rest_to_rest(t, y0, yf, T, order):
    """Eq. (65) and its derivatives in time: y0 + (yf - y0) p(t / T)."""
    coefficients = {5: 126, 6: -420, 7: 540, 8: -315, 9: 70}
    tau = np.minimum(t, T) / T
    value = np.zeros_like(t)
    for power, c in coefficients.items():
        falling = math.prod(range(power - order + 1, power + 1))
        value += c * falling * tau ** (power - order)
    return (y0 if order == 0 else 0.0) + (yf - y0) * value / T ** order


def test_flat_case_follows_its_closed_form(mass_on_car):
    # alpha = 0, d = 0: y = x + s and m2 y'' = -k s, so s = -(m2/k) y'' and
    # F = (m1 + m2) y'' + (m1 m2 / k) y'''' (flat: no internal dynamics), y_d from Eq. (65).
    model = servokit.load(mass_on_car, alpha=0, d=0)
    result = model.solve(y0=0.5, yf=2.5, t0=0, tf=6, t_end=8, sample_time=0.5, verify=True)
    assert result.method == "algebraic"
    assert result.status == "converged" and result.usable
    assert result.summary["verification"]["passed"]
    table = result.table
    assert list(table.columns) == ["t", "x", "s", "x_dot", "s_dot", "F", "y1_d"]
    t = np.asarray(table["t"], dtype=float)
    assert t == pytest.approx(np.arange(17) * 0.5, abs=1e-12)
    moving = t < 6
    force = (M1 + M2) * rest_to_rest(t, 0.5, 2.5, 6.0, 2) + \
        np.where(moving, M1 * M2 / K * rest_to_rest(t, 0.5, 2.5, 6.0, 4), 0.0)
    assert np.asarray(table["F"]) == pytest.approx(force, abs=1e-9)  # round-off of p''''
    assert np.asarray(table["y1_d"]) == pytest.approx(rest_to_rest(t, 0.5, 2.5, 6.0, 0),
                                                      rel=1e-12)
    s = -(M2 / K) * np.where(moving, rest_to_rest(t, 0.5, 2.5, 6.0, 2), 0.0)
    assert np.asarray(table["s"]) == pytest.approx(s, abs=1e-9)
    assert result.q.shape == (17, 2) and result.u.shape == (17, 1)


def test_sweep_follows_the_closed_form(mass_on_car):
    model = servokit.load(mass_on_car, d=0)
    # The model gives alpha in degrees: numbers are degrees, and the tables show them so, as
    # alpha_deg (values are SI inside).
    points, eigenvalues = model.sweep({"alpha": [5.0, 30.0, 60.0]}, threads=2)
    assert list(points["alpha_deg"]) == [5.0, 30.0, 60.0]
    assert list(points["stability"]) == ["critical"] * 3
    omega = np.sqrt(K / (M2 * np.sin(np.radians(np.asarray(eigenvalues["alpha_deg"]))) ** 2))
    assert np.abs(np.asarray(eigenvalues["im"])) == pytest.approx(omega, rel=1e-10)
    assert np.asarray(eigenvalues["frequency_hz"]) == pytest.approx(omega / (2 * np.pi),
                                                                    rel=1e-10)


def test_generated_chain_with_mean_output_has_the_closed_form_zeros(tmp_path):
    # output_weights="uniform" on two masses: y = (q1 + q2) / 2 = 0 holds q1 = -q2, and mass 2
    # hangs on one spring-damper stretched by q2 - q1 = 2 q2: m s^2 + 2 d s + 2 k = 0, so
    # s = -0.01 +- i sqrt(2 - 0.01^2) for m = k = 1, d = 0.01.
    path = servokit.generate.chain(masses=2, output_weights="uniform", out=tmp_path)
    eigenvalues = servokit.load(path).analyze().eigenvalues
    assert eigenvalues.real == pytest.approx([-0.01, -0.01], rel=1e-10)
    assert sorted(eigenvalues.imag) == pytest.approx(
        [-math.sqrt(2 - 0.01**2), math.sqrt(2 - 0.01**2)], rel=1e-10)
    with pytest.raises(servokit.UsageError, match="output_weights 'quadratic'"):
        servokit.generate.chain(masses=2, output_weights="quadratic", out=tmp_path)


def test_generated_chain_has_the_free_mass_as_zero_dynamics(tmp_path):
    # Force and output on mass 1 of two: holding it, mass 2 hangs on one spring-damper, so the
    # zero dynamics are m s^2 + d s + k = 0: s = -0.005 +- i sqrt(1 - 0.005^2).
    path = servokit.generate.chain(masses=2, out=tmp_path)
    assert path.endswith(".yaml")
    model = servokit.load(path)
    assert model.kind == "linear"
    assert model.coordinates == ["q1", "q2"]
    eigenvalues = model.analyze().eigenvalues
    assert eigenvalues.real == pytest.approx([-0.005, -0.005], rel=1e-10)
    assert sorted(eigenvalues.imag) == pytest.approx(
        [-math.sqrt(1 - 0.005**2), math.sqrt(1 - 0.005**2)], rel=1e-10)
    beam = servokit.load(servokit.generate.beam(elements=4, out=tmp_path / "beam"))
    assert beam.kind == "linear" and beam.name == "beam_4"


def test_crane_in_absolute_coordinates_holds_its_load_on_the_rope():
    # The gantry crane with the rope as a constraint (tests/data/loops): the load at rest hangs
    # on it, m g = -dc/dzL lambda = -2 zL lambda, and it is classified as models/gantry_crane.yaml.
    crane = servokit.load(str(MODELS / "gantry_crane_absolute.yaml"))
    analysis = crane.analyze(y0=[0.3, 1.5], q0=[0, 0, 0, 2])
    assert analysis.multipliers == pytest.approx([-5.0 * 9.81 / (2 * 1.5)], rel=1e-12)
    assert analysis.to_dict()["operating_point"]["multipliers"] == list(analysis.multipliers)
    minimal = servokit.load(str(MODELS / "gantry_crane.yaml")).analyze(y0=[0.3, 1.5])
    assert analysis.realization == minimal.realization == "mixed-orthogonal-tangential"
    assert list(analysis.relative_degree) == list(minimal.relative_degree) == [4, 2]
    assert analysis.flat and minimal.flat
    assert len(minimal.multipliers) == 0


def test_crane_in_absolute_coordinates_is_solved_with_its_rope_force():
    # The same crane moved out and up: Python gets the multipliers as solve writes them, and at
    # rest after the motion the rope holds the load again, lambda = -m g / (2 zL) at zL = 1.5 m;
    # the feedforward is the minimal crane's (both exact: the algebraic inverse).
    crane = servokit.load(str(MODELS / "gantry_crane_absolute.yaml"))
    assert crane.multipliers == ["lambda1"]
    motion = dict(y0=[0.0, 2.0], yf=[1.0, 1.5], t0=0, tf=2, t_end=3, sample_time=0.5,
                  verify=True)
    loops = crane.solve(q0=[0, 0, 0, 2], **motion)
    assert loops.usable and loops.method == "algebraic"
    assert loops.multipliers.shape == (7, 1)
    assert loops.multipliers[-1, 0] == pytest.approx(-5.0 * 9.81 / (2 * 1.5), rel=1e-12)
    table = loops.table  # a DataFrame, or a structured array where pandas is missing
    names = list(table.columns) if hasattr(table, "columns") else list(table.dtype.names)
    assert names[-1] == "lambda1"
    minimal = servokit.load(str(MODELS / "gantry_crane.yaml")).solve(**motion)
    assert minimal.multipliers.shape == (7, 0)
    assert loops.u == pytest.approx(minimal.u, rel=1e-10, abs=1e-10)
