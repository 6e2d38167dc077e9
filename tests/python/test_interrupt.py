"""Ctrl-C during a long sweep: the sweep stops after the block it is in and Python raises
KeyboardInterrupt, as it does for any long call (issue #17, "Long runs").

Python would raise the KeyboardInterrupt after the call anyway, once the sweep had finished; what
shows that the sweep stopped is the time: one block (4096 points) after the signal, not the
whole grid."""
import os
import pathlib
import signal
import threading
import time

import numpy as np
import pytest

import servokit

MODELS = pathlib.Path(os.environ.get("SERVOKIT_MODELS_DIR",
                                     pathlib.Path(__file__).parents[2] / "models"))


def test_ctrl_c_stops_a_sweep_with_keyboard_interrupt():
    model = servokit.load(str(MODELS / "three_link_arm.yaml"))
    values = np.linspace(0.5, 2.0, 400_000)
    # The time of 1/20 of the grid, measured on this machine now (it may be loaded).
    started = time.monotonic()
    assert len(model.sweep({"l": values[:20_000]})[0]) == 20_000
    twentieth = time.monotonic() - started

    timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
    started = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        model.sweep({"l": values})
    elapsed = time.monotonic() - started
    timer.join()
    # Stopped: 0.2 s plus at most a block or two (about a fifth of `twentieth` each). Not
    # stopped: the whole grid, 20 times `twentieth`. Half of that separates the two.
    assert elapsed < 0.2 + 10 * twentieth
