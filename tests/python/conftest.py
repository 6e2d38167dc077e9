"""Shared fixtures of the Python module's tests (tests/python, run by CTest as python.*).

CTest sets PYTHONPATH to the built module's folder, SERVOKIT_BINARY to the `servokit` command
and SERVOKIT_MODELS_DIR to the shipped models."""
import os
import pathlib

import pytest

MODELS = pathlib.Path(os.environ.get("SERVOKIT_MODELS_DIR",
                                     pathlib.Path(__file__).parents[2] / "models"))


@pytest.fixture
def mass_on_car():
    return str(MODELS / "mass_on_car.yaml")


@pytest.fixture
def servokit_binary():
    binary = os.environ.get("SERVOKIT_BINARY")
    if not binary:
        pytest.skip("SERVOKIT_BINARY is not set (run through ctest)")
    return binary
