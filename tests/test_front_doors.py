"""Each package's ``__init__`` is its front door: every name it lists resolves to the object of its home module."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import attitude

FRONT_DOORS = (
    "attitude",
    "attitude.config",
    "attitude.environment",
    "attitude.montecarlo",
    "attitude.simulation",
    "controllers",
    "controllers.slew",
    "estimation",
    "estimation.mekf",
)


@pytest.mark.parametrize("package", FRONT_DOORS)
def test_every_listed_name_resolves(package):
    module = importlib.import_module(package)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert not missing, f"{package} lists {missing} but does not provide them"


def test_the_lazy_names_of_attitude_are_the_objects_of_their_home_modules():
    assert set(attitude.__all__) - {"RigidBody", "__version__"} == set(attitude._FRONT_DOOR)
    for name, home in attitude._FRONT_DOOR.items():
        assert getattr(attitude, name) is getattr(importlib.import_module(home), name), name


def test_an_unknown_name_is_an_attribute_error_naming_it():
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        attitude.simulat  # noqa: B018


def test_importing_attitude_loads_neither_the_engine_nor_python_control():
    code = "import sys, attitude; print(sorted(m for m in ('attitude.simulation', 'control') if m in sys.modules))"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert proc.stdout.strip() == "[]"
