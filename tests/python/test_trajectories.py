"""Desired outputs given as data from Python (issue #17): sampled arrays and callables, against
the closed form of the flat mass on a car (Seifried and Blajer 2013, Sect. 3 with alpha = 0):
y = x + s and m2 y'' = -k s, so F = (m1 + m2) y'' + (m1 m2 / k) y'''' (m1 = 1, m2 = 2, k = 5),
with y_d the paper's Eq. (65) from 0.5 at t = 0 to 2.5 at t = 6."""
import numpy as np
import pytest

import servokit

Y0, YF, T = 0.5, 2.5, 6.0
EQ65 = np.polynomial.Polynomial([0, 0, 0, 0, 0, 126, -420, 540, -315, 70])


def desired(t, order):
    """d^order y_d / dt^order of Eq. (65), at rest outside [0, T]."""
    if t <= 0.0 or t >= T:
        return (Y0 if t <= 0.0 else YF) if order == 0 else 0.0
    return (Y0 if order == 0 else 0.0) + (YF - Y0) * EQ65.deriv(order)(t / T) / T ** order


def closed_form_force(t):
    return 3.0 * desired(t, 2) + 0.4 * desired(t, 4)


@pytest.fixture
def flat_car(mass_on_car):
    return servokit.load(mass_on_car, alpha=0, d=0)


def check_force(result, margin):
    table = result.table
    assert result.summary["method"] == "algebraic"
    assert result.summary["status"] == "converged"
    assert result.summary["verification"]["passed"]
    expected = np.array([closed_form_force(t) for t in table["t"]])
    assert np.max(np.abs(table["F"].to_numpy() - expected)) < margin


def test_samples_of_eq65_give_its_force(flat_car):
    # The spline of degree 9 at rest to order 4 at both ends reproduces Eq. (65) from any
    # samples of it, so the force is the closed form's to round-off.
    t = np.array([0.0, 0.4, 1.3, 2.0, 2.2, 3.7, 4.1, 5.0, 6.0])
    y = np.array([desired(ti, 0) for ti in t])
    check_force(flat_car.solve(samples=(t, y), t_end=8, sample_time=0.25, verify=True), 1e-7)


def test_a_callable_gives_its_force(flat_car):
    result = flat_car.solve(function=desired, breakpoints=[0.0, T], t_end=8, sample_time=0.25,
                            verify=True)
    check_force(result, 1e-9)
    assert len(result.table) == 33


def test_a_list_of_callables_gives_its_force(flat_car):
    functions = [lambda t, order=order: desired(t, order) for order in range(5)]
    check_force(flat_car.solve(function=functions, breakpoints=[0.0, T], t_end=8,
                               sample_time=0.25, verify=True), 1e-9)
    with pytest.raises(servokit.UsageError, match="up to order 3, but 3 functions"):
        flat_car.solve(function=functions[:3], t_end=8)


def test_samples_follow_the_rest_to_rest_solve_of_a_non_flat_car(mass_on_car):
    # alpha = 30 deg, d = 1: stable internal dynamics. Samples of Eq. (65) are Eq. (65), so the
    # feedforward is the rest-to-rest one up to the integrator's tolerance.
    model = servokit.load(mass_on_car, alpha="30 deg", d=1)
    t = np.linspace(0.0, T, 13)
    y = np.array([desired(ti, 0) for ti in t])
    sampled = model.solve(samples=(t, y), t_end=10, sample_time=0.5, verify=True)
    reference = model.solve(y0=Y0, yf=YF, t0=0, tf=T, t_end=10, sample_time=0.5)
    assert sampled.summary["verification"]["passed"]
    assert np.allclose(sampled.table["F"], reference.table["F"], rtol=0, atol=1e-6)


def test_an_exception_in_the_callable_is_raised(flat_car):
    def failing(t, order):
        if t > 1.0:
            raise ValueError("no data after t = 1")
        return desired(t, order)

    with pytest.raises(ValueError, match="no data after t = 1"):
        flat_car.solve(function=failing, t_end=8)


def test_bad_trajectory_data_is_a_usage_error(flat_car):
    with pytest.raises(servokit.UsageError, match="order 0 gave"):
        flat_car.solve(function=lambda t, order: [1.0, 2.0], t_end=8)
    with pytest.raises(servokit.UsageError, match="not after time"):
        flat_car.solve(samples=([0.0, 1.0, 1.0], [0.0, 1.0, 2.0]), t_end=8)
    with pytest.raises(servokit.UsageError, match="give one of"):
        flat_car.solve(samples=([0.0, 1.0], [0.0, 1.0]), function=desired, t_end=8)
    with pytest.raises(servokit.UsageError, match="belong to function"):
        flat_car.solve(y0=0, yf=1, tf=1, breakpoints=[0.0], t_end=2)
    with pytest.raises(servokit.UsageError, match="sample_tolerance belongs to samples"):
        flat_car.solve(y0=0, yf=1, tf=1, sample_tolerance=0.0, t_end=2)
    with pytest.raises(servokit.UsageError, match="sample_tolerance = -1: must be >= 0"):
        flat_car.solve(samples=([0.0, 1.0], [0.0, 1.0]), sample_tolerance=-1.0, t_end=8)


def test_noisy_samples_are_fitted_within_the_tolerance(flat_car):
    # F reads the fourth derivative of y_d (closed_form_force): 2001 samples of Eq. (65) with a
    # measurement's noise of 1e-6 interpolated give a force far off (the noise times some
    # (c/h)^4: here 1.9e5 N); fitted with the tolerance at the noise (1e-6 of the range 2), the
    # spline is the least-squares polynomial of Eq. (65)'s space (no inner knot), which averages
    # the noise over the 2001 samples, and the force is the closed form's to 1e-3 of its size.
    t = np.linspace(0.0, T, 2001)
    noise = 1e-6 * np.random.default_rng(7).uniform(-1.0, 1.0, len(t))
    noisy = np.array([desired(ti, 0) for ti in t]) + noise
    fitted = flat_car.solve(samples=(t, noisy), sample_tolerance=1e-6, t_end=8, sample_time=0.25)
    interpolated = flat_car.solve(samples=(t, noisy), sample_tolerance=0.0, t_end=8,
                                  sample_time=0.25)
    expected = np.array([closed_form_force(ti) for ti in fitted.table["t"]])
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(fitted.table["F"].to_numpy() - expected)) < 1e-3 * scale
    assert np.max(np.abs(interpolated.table["F"].to_numpy() - expected)) > scale
    assert "2001 samples joined by a spline of degree 9 without inner knots" in fitted.notes[0]


def test_the_command_reads_samples_from_csv(flat_car, mass_on_car, servokit_binary, tmp_path):
    import subprocess

    import pandas

    t = np.linspace(0.0, T, 7)
    samples = tmp_path / "samples.csv"
    samples.write_text("# Eq. (65) from 0.5 to 2.5\nt,y\n" +
                       "".join(f"{ti!r},{desired(ti, 0)!r}\n" for ti in t))
    out = tmp_path / "u.csv"
    subprocess.run([servokit_binary, "solve", mass_on_car, "--set", "alpha=0", "--set", "d=0",
                    "--trajectory", str(samples), "--t-end", "8", "--sample-time", "0.25",
                    "--out", str(out)], check=True, capture_output=True)
    command = pandas.read_csv(out, float_precision="round_trip")
    module = flat_car.solve(samples=(t, [desired(ti, 0) for ti in t]), t_end=8,
                            sample_time=0.25).table
    assert list(command.columns) == list(module.columns)
    assert np.array_equal(command.to_numpy(), module.to_numpy())
    expected = np.array([closed_form_force(ti) for ti in command["t"]])
    assert np.max(np.abs(command["F"].to_numpy() - expected)) < 1e-7

    samples.write_text("t,y\n0,0.5\n1,oops\n")
    failed = subprocess.run([servokit_binary, "solve", mass_on_car, "--trajectory", str(samples),
                             "--t-end", "8", "--out", str(out)], capture_output=True, text=True)
    assert failed.returncode == 2
    assert failed.stderr == f"servokit: error: {samples}:3: column 2: 'oops' is not a finite number\n"
