"""A sweep's grid written as `servokit sweep --vary` writes it: degrees stay degrees."""
import warnings

import numpy as np
import pytest

import servokit


def test_a_degree_range_sweeps_whole_degrees(mass_on_car):
    model = servokit.load(mass_on_car, d=0)
    points, _ = model.sweep({"alpha": "5deg:85deg:9"}, table="numpy")
    # 5, 15, ..., 85 degrees exactly, each the angle "<n> deg" is in a model file.
    assert list(points["alpha_deg"]) == [5.0 + 10.0 * i for i in range(9)]
    # Undamped (d = 0), the zero dynamics m2 sin^2(alpha) s'' + k s = 0 (paper Eq. 36) are a
    # pair on the imaginary axis at every angle.
    assert set(points["stability"]) == {"critical"}


def test_a_text_and_its_values_sweep_the_same_grid(mass_on_car):
    model = servokit.load(mass_on_car)
    by_text, _ = model.sweep({"d": "0:2:step=0.5", "k": "4,5"}, table="numpy")
    by_values, _ = model.sweep({"d": np.arange(0.0, 2.01, 0.5), "k": [4.0, 5.0]}, table="numpy")
    assert list(by_text["d"]) == list(by_values["d"]) and list(by_text["k"]) == list(by_values["k"])
    assert list(by_text["max_real_part"]) == list(by_values["max_real_part"])


def test_a_bad_text_names_the_grid_and_a_doubtful_one_warns(mass_on_car):
    model = servokit.load(mass_on_car)
    with pytest.raises(servokit.UsageError, match=r"^grid alpha=5 knots: '5 knots' is not a number"):
        model.sweep({"alpha": "5 knots"})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.sweep({"d": "0:2:4"}, table="numpy")
    assert any("grid d=0:2:4 is read as 4 values from 0 to 2" in str(w.message) for w in caught)
