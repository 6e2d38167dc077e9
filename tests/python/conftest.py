"""Shared fixtures of the Python module's tests (tests/python, run by CTest as python.*).

CTest sets PYTHONPATH to the built module's folder, SERVOKIT_BINARY to the `servokit` command
and SERVOKIT_MODELS_DIR to the shipped models."""
import math
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


def _agree(fields, printed, path):
    if isinstance(printed, dict):
        assert isinstance(fields, dict), (path, fields)
        for key in fields.keys() & printed.keys():
            _agree(fields[key], printed[key], f"{path}[{key!r}]")
    elif isinstance(printed, list):
        assert isinstance(fields, list) and len(fields) == len(printed), (path, fields, printed)
        for i, (value, written) in enumerate(zip(fields, printed)):
            _agree(value, written, f"{path}[{i}]")
    elif printed is None:  # the JSON writes NaN (and an unset number) as null
        assert fields is None or (isinstance(fields, float) and math.isnan(fields)), (path, fields)
    else:
        assert fields == printed, (path, fields, printed)
        assert isinstance(fields, bool) == isinstance(printed, bool), (path, fields, printed)


@pytest.fixture
def assert_agrees():
    """assert_agrees(fields, printed): a dict of values (to_dict()) and a parsed JSON object
    hold the same value under every key both have, at every depth: lists item by item, numbers
    exactly (the JSON's are shortest round-trip), a null of the JSON as None or NaN."""
    return lambda fields, printed: _agree(fields, printed, "")
