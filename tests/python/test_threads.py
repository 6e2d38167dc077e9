"""The module from several threads at once (issue #29): the binding releases the GIL while the
toolkit computes, and 8 threads calling servokit.load(...).analyze() on the shipped models
crashed inside GiNaC (not thread-safe) before its work went under one lock
(modeling/symbolic_lock.h). Each test makes every call once on this thread for the reference, then
from 8 threads at once, and requires every answer to equal its reference exactly: the numbers
are deterministic, so any difference is a race.

Each call is made up to 50 times per thread, fewer when it is slow (as often as fits in about
0.4 s of its reference time, at least twice): a symbolic call (load, analyze's nonlinear
structure, a model's first algebraic solve) runs one thread at a time, 10 to 100 ms each. The
last test makes a fresh interpreter's first calls from 8 threads at once, with no reference."""
import concurrent.futures
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

import servokit

MODELS = pathlib.Path(os.environ.get("SERVOKIT_MODELS_DIR",
                                     pathlib.Path(__file__).parents[2] / "models"))
SHIPPED = sorted(path.name for path in MODELS.glob("*.yaml"))
THREADS = 8
MAX_CALLS, MIN_CALLS, SECONDS_PER_CALL = 50, 2, 0.4


def analysis_answer(analysis):
    """Everything an analysis gives: its three reports and its numbers' bytes."""
    return (analysis.json, analysis.text, analysis.markdown, analysis.q.tobytes(),
            analysis.u.tobytes(), analysis.y.tobytes(), analysis.P.tobytes(),
            analysis.eigenvalues.tobytes())


def solution_answer(solution):
    """Everything a solve gives: its summary, messages and every row's bytes."""
    return (solution.summary.json, solution.status, solution.message, solution.warnings,
            solution.notes, np.asarray(solution.t).tobytes(), solution.q.tobytes(),
            solution.q_dot.tobytes(), solution.u.tobytes(), solution.y_d.tobytes())


def answer(call):
    try:
        return call()
    except Exception as error:  # an error is an answer too: its type and message
        return ("exception", type(error).__name__, str(error))


def check_threaded_answers_equal_single_threaded(calls):
    """calls: {name: function}. Thread t starts at the t-th call and goes round."""
    names = list(calls)
    reference, counts = {}, {}
    for name in names:
        started = time.perf_counter()
        reference[name] = answer(calls[name])
        seconds = time.perf_counter() - started
        assert reference[name][0] != "exception", (name, reference[name])
        counts[name] = max(MIN_CALLS, min(MAX_CALLS, int(SECONDS_PER_CALL / (THREADS * seconds))))

    def work(thread):
        mismatches, made = [], 0
        left = dict(counts)
        k = thread % len(names)
        while any(left.values()):
            name = names[k]
            k = (k + 1) % len(names)
            if left[name] == 0:
                continue
            left[name] -= 1
            made += 1
            result = answer(calls[name])
            if result != reference[name]:
                mismatches.append((name, str(result)[:300]))
        return made, mismatches

    with concurrent.futures.ThreadPoolExecutor(max_workers=THREADS) as pool:
        results = list(pool.map(work, range(THREADS)))
    for made, mismatches in results:
        assert made == sum(counts.values())
        assert mismatches == []


def test_loading_and_analyzing_the_shipped_models_from_8_threads_gives_one_answer():
    assert "acrobot.yaml" in SHIPPED and len(SHIPPED) >= 8
    shared = {name: servokit.load(str(MODELS / name)) for name in SHIPPED}
    calls = {}
    for name in SHIPPED:
        # A fresh load in every call (loading, and dropping models while others analyze), and
        # one model shared by every thread.
        calls[name + " loaded per call"] = (
            lambda name=name: analysis_answer(servokit.load(str(MODELS / name)).analyze()))
        calls[name + " shared"] = lambda name=name: analysis_answer(shared[name].analyze())
    check_threaded_answers_equal_single_threaded(calls)


EQ65 = np.polynomial.Polynomial([0, 0, 0, 0, 0, 126, -420, 540, -315, 70])


def eq65(t, order):
    """The paper's Eq. (65) from 0 at t = 0 to 1 at t = 1, at rest outside, and its derivatives."""
    if t <= 0.0 or t >= 1.0:
        return (0.0 if t <= 0.0 else 1.0) if order == 0 else 0.0
    return float((EQ65.deriv(order) if order else EQ65)(t))


def rest_to_rest(model, y0, yf, t0, tf, **options):
    return lambda: solution_answer(model.solve(y0=y0, yf=yf, t0=t0, tf=tf, table="numpy",
                                               **options))


def test_solving_by_every_method_from_8_threads_gives_one_answer():
    crane = servokit.load(str(MODELS / "gantry_crane.yaml"))
    car = servokit.load(str(MODELS / "mass_on_car.yaml"))
    flat_car = servokit.load(str(MODELS / "mass_on_car.yaml"), alpha=0, d=0)
    arm_minimum_phase = servokit.load(str(MODELS / "rotational_arm.yaml"), s=0.5)
    arm = servokit.load(str(MODELS / "rotational_arm.yaml"), s=0.9)
    crane_move = dict(y0=[0, 2], yf=[1, 2], t0=0, tf=3)
    car_move = dict(y0=[0], yf=[1], t0=0, tf=2)
    arm_move = dict(y0=[0], yf=[0.1], t0=1, tf=3)
    calls = {
        "gantry_crane algebraic": rest_to_rest(crane, **crane_move, t_end=4, method="algebraic",
                                               step=0.01, verify=True),
        "gantry_crane linearized": rest_to_rest(crane, **crane_move, t_end=4,
                                                method="linearized"),
        "mass_on_car bdf": rest_to_rest(car, **car_move, t_end=3, method="bdf"),
        "mass_on_car radau": rest_to_rest(car, **car_move, t_end=3, method="radau"),
        "mass_on_car euler": rest_to_rest(car, **car_move, t_end=3, method="euler"),
        "rotational_arm normal-form": rest_to_rest(arm_minimum_phase, **arm_move, t_end=3.5,
                                                   method="normal-form"),
        "rotational_arm stable-inversion": rest_to_rest(arm, **arm_move, t_end=3.5,
                                                        method="stable-inversion"),
        # y_d from Python: the solve takes the GIL for each value, between the other threads.
        "flat mass_on_car algebraic from a function": lambda: solution_answer(flat_car.solve(
            function=eq65, breakpoints=[0.0, 1.0], t_end=1.5, sample_time=0.05,
            table="numpy")),
    }
    # The algebraic inverse is derived once per model and parameters, and the last 8 are kept:
    # 10 masses of the flat car (a derivation of 2 ms; the crane's takes 100 ms) make the
    # threads derive, share and evict inverses at once.
    for mass in range(1, 11):
        lighter = servokit.load(str(MODELS / "mass_on_car.yaml"), alpha=0, d=0, m1=mass)
        calls[f"flat mass_on_car m1 = {mass} algebraic"] = rest_to_rest(
            lighter, **car_move, t_end=3, method="algebraic", step=0.01)
    check_threaded_answers_equal_single_threaded(calls)


FIRST_CALLS = """
import sys, threading
import servokit
model = servokit.load(sys.argv[1], s=0.5)
barrier = threading.Barrier(8)
def work():
    barrier.wait()
    model.solve(y0=[0], yf=[0.1], t0=1, tf=3, t_end=3.5, method="normal-form", table="numpy")
threads = [threading.Thread(target=work) for _ in range(8)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
print("done")
"""


def test_the_first_calls_of_a_process_from_8_threads_at_once_finish():
    """The tests above make every call once on one thread first; here a fresh interpreter that
    has not imported numpy makes its first solves from 8 threads at once. pybind11 2.10 looked
    numpy's C API up on first use, under a static's guard that a thread holding the GIL waited
    for: every run hung (application/python/servokit_module.cpp looks it up at import)."""
    done = subprocess.run([sys.executable, "-c", FIRST_CALLS,
                           str(MODELS / "rotational_arm.yaml")],
                          capture_output=True, text=True, timeout=60)
    assert (done.returncode, done.stdout.strip()) == (0, "done"), done.stderr[-2000:]
