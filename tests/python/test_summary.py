"""Solution.summary is a SolveSummary (issue #30): the fields of the C++ struct as attributes
(the toolkit's enums as their words), to_dict() built from those fields, and `json`, the object
`servokit solve` prints. Each attribute is checked against a fact found another way: the
arguments of the solve, its table, the model's analysis, Eq. (65) for the output of the forward
check, and the JSON text, which the C++ writer renders apart from the binding."""
import json
import os
import pathlib

import numpy as np
import pytest

import servokit

MODELS = pathlib.Path(os.environ.get("SERVOKIT_MODELS_DIR",
                                     pathlib.Path(__file__).parents[2] / "models"))
# Paper Sect. 5.1 case 2 (alpha = 5 deg, d = 1): stable internal dynamics, integrated forward.
CASE_2 = {"y0": 0.5, "yf": 2.5, "t0": 0.0, "tf": 6.0, "t_end": 10.0, "sample_time": 0.25}
# The rotational arm with s = l: unstable zero dynamics, stable inversion with pre-actuation.
ARM = {"y0": 0.0, "yf": 1.0, "t0": 0.0, "tf": 1.0, "t_end": 2.0}


def eq65(t, y0, yf, T):
    """The rest-to-rest output of paper Eq. (65): y0 + (yf - y0) p(t / T)."""
    tau = np.clip(t, 0.0, T) / T
    p = tau**5 * (126 - 420 * tau + 540 * tau**2 - 315 * tau**3 + 70 * tau**4)
    return y0 + (yf - y0) * p


@pytest.fixture
def case_2(mass_on_car):
    model = servokit.load(mass_on_car, alpha="5 deg", d=1)
    return model, model.solve(**CASE_2, verify=True)


def test_the_summary_holds_the_facts_of_its_solve(case_2):
    model, result = case_2
    summary = result.summary
    assert isinstance(summary, servokit.SolveSummary)
    # auto runs the solver the analysis recommends (the page's first session: bdf).
    analysis = model.analyze()
    assert summary.method == analysis.recommended_solver == "bdf"
    assert summary.method_reason.startswith("auto")
    assert summary.status == "converged" and summary.message
    assert (result.method, result.status, result.message, result.warnings) == \
        (summary.method, summary.status, summary.message, summary.warnings)
    # The span and the grid are the arguments'; the rows are the table's.
    assert summary.t_start == CASE_2["t0"] and summary.t_end == CASE_2["t_end"]
    assert summary.stop_time == CASE_2["t_end"]
    assert summary.sample_time == CASE_2["sample_time"]
    assert summary.samples == len(result.t) == len(result.table) == 41
    assert result.t[0] == summary.t_start and result.t[-1] == summary.t_end
    assert summary.steps > 0 and summary.rejected_steps >= 0
    assert summary.newton_iterations >= summary.steps and summary.function_evaluations > 0
    assert summary.rtol > 0 and summary.atol > 0 and summary.step is None
    assert 0 <= summary.max_servo_residual < 1e-6
    assert summary.window is None and summary.out_file == "" and summary.trajectory_note == ""
    # The classification is the analysis at the same operating point.
    assert isinstance(summary.classification, servokit.Analysis)
    assert summary.classification.realization == analysis.realization == "non-ideal-orthogonal"
    assert summary.classification.stability == analysis.stability == "asymptotically-stable"
    assert np.array_equal(summary.classification.eigenvalues, analysis.eigenvalues)


def test_the_verification_holds_eq65_within_its_bound(case_2):
    _, result = case_2
    verification = result.summary.verification
    assert isinstance(verification, servokit.Verification)
    assert verification.passed and verification.status == "converged"
    assert verification.segments == 1 and verification.steps > 0
    assert 0 < verification.max_tracking_error <= verification.bound
    assert verification.bound_rule
    t, y = verification.t, verification.y
    assert isinstance(t, np.ndarray) and t.ndim == 1
    assert isinstance(y, np.ndarray) and y.shape == (len(t), 1)
    assert t[0] == result.summary.t_start and t[-1] == result.summary.t_end
    assert t[0] <= verification.time_of_max_error <= t[-1]
    # The forward runs' output against Eq. (65) itself: within the bound, and no larger than the
    # largest error the check reports (it may look between these steps too).
    errors = np.abs(y[:, 0] - eq65(t, CASE_2["y0"], CASE_2["yf"], CASE_2["tf"]))
    assert errors.max() <= verification.max_tracking_error * (1 + 1e-9) + 1e-15
    assert abs(y[-1, 0] - CASE_2["yf"]) <= verification.bound


def test_to_dict_is_built_from_the_fields(case_2):
    _, result = case_2
    summary = result.summary
    fields = summary.to_dict()
    for name in ("method", "method_reason", "status", "message", "stop_time", "t_start", "t_end",
                 "sample_time", "rtol", "atol", "step", "steps", "rejected_steps",
                 "newton_iterations", "function_evaluations", "samples", "max_servo_residual",
                 "window", "trajectory_note", "warnings", "out_file"):
        assert fields[name] == getattr(summary, name), name
        assert summary[name] == fields[name] and name in summary
    assert fields["steps"] == summary.steps
    assert fields["tolerances"] == {"rtol": summary.rtol, "atol": summary.atol, "step": None}
    assert "out" not in fields and "pre_actuation_start" not in summary
    assert fields["classification"] == summary.classification.to_dict()
    assert fields["classification"]["realization"] == summary.classification.realization
    verification = fields["verification"]
    assert verification == summary.verification.to_dict()
    assert verification["passed"] is True and summary["verification"]["passed"]
    assert verification["t"] == list(summary.verification.t)
    assert verification["y"] == summary.verification.y.tolist()
    with pytest.raises(KeyError):
        summary["no such key"]
    assert set(summary.keys()) == set(fields) == set(summary)


def test_to_dict_agrees_with_the_printed_json(case_2, assert_agrees):
    _, result = case_2
    fields, printed = result.summary.to_dict(), json.loads(result.summary.json)
    # Every key of the printed object is a key of to_dict() ...
    assert set(printed) <= set(fields)
    assert set(printed["classification"]) >= set(fields["classification"])
    # ... and holds the same value, at every depth (the analysis's report-only keys and the
    # verification's start state are the JSON's only).
    assert_agrees(fields, printed)


def test_stable_inversion_gives_its_window(assert_agrees, tmp_path):
    model = servokit.load(str(MODELS / "rotational_arm.yaml"))
    out = tmp_path / "arm.csv"
    result = model.solve(**ARM, verify=True, out=out)
    summary = result.summary
    assert summary.method == model.analyze().recommended_solver == "stable-inversion"
    assert summary.status == "converged" and summary.verification.passed
    window = summary.window
    assert isinstance(window, servokit.ActuationWindow)
    # Pre-actuation starts before the motion, post-actuation ends after it, both inside the
    # span the boundary value problem was solved on; the table starts where that span does.
    assert window.start <= window.pre_actuation_start < ARM["t0"]
    assert ARM["tf"] < window.post_actuation_end <= window.end
    assert result.t[0] == summary.t_start == window.start and summary.t_end == ARM["t_end"]
    assert window.mesh_points > 0 and window.widenings >= 0
    assert 0 <= window.boundary_value_residual < 1e-6
    assert summary.out_file == str(out) and out.exists()
    fields = summary.to_dict()
    assert fields["window"] == window.to_dict()
    assert fields["pre_actuation_start"] == window.pre_actuation_start == \
        summary["window"]["pre_actuation_start"]
    assert fields["post_actuation_end"] == window.post_actuation_end
    assert fields["out"] == fields["out_file"] == str(out)
    printed = json.loads(summary.json)
    # The JSON writes the window as [start, end]; its other numbers are top-level keys.
    assert printed.pop("window") == [window.start, window.end]
    fields.pop("window")
    assert set(printed) <= set(fields)
    assert_agrees(fields, printed)


def test_a_solve_without_the_check_has_no_verification(mass_on_car):
    model = servokit.load(mass_on_car, alpha="5 deg", d=1)
    result = model.solve(y0=0.5, yf=2.5, t0=0, tf=6, t_end=8, method="radau")
    summary = result.summary
    assert summary.method == "radau" and summary.status == "converged" and result.usable
    assert summary.verification is None and summary["verification"] is None
    assert "verification" not in json.loads(summary.json)
    assert repr(summary) == f"<servokit.SolveSummary radau, converged, {len(result.t)} samples>"
