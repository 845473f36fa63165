"""Every docstring example (``>>>``) in ``attitude``, ``controllers`` and ``estimation`` runs and prints what it shows.

The examples are run by the standard library's :mod:`doctest` (``DocTestFinder``
and ``DocTestRunner``, the machinery behind ``python -m doctest`` and pytest's
``--doctest-modules``), one test per module, so they run with the rest of the
suite (``pytest``, ``pytest -n 2``) under ``--import-mode=importlib`` without a
second collection mode. Flags: ``ELLIPSIS`` (``...`` in an expected output
matches anything) and ``NORMALIZE_WHITESPACE``; numpy prints with its default
options, so an expected array is written as numpy prints it.

Modules are found from the files on disk, so a new module is picked up
without editing this file. Each test also checks that importing the module
prints nothing: collecting the examples must not run anything.
``attitude/__main__.py`` (the ``python -m attitude`` entry point) is not a
library module and is skipped.
"""

from __future__ import annotations

import contextlib
import doctest
import importlib
import io
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("attitude", "controllers", "estimation")
#: Entry points that are scripts, not library modules.
SKIP = {"attitude.__main__"}
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def module_names() -> list[str]:
    names = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            name = ".".join(parts)
            if name not in SKIP:
                names.append(name)
    return names


MODULES = module_names()


def test_modules_found():
    assert len(MODULES) > 50, MODULES
    assert "attitude.__main__" not in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str):
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        module = importlib.import_module(name)
    assert out.getvalue() == "", f"importing {name} printed:\n{out.getvalue()}"
    tests = [t for t in doctest.DocTestFinder(exclude_empty=True).find(module, name) if t.examples]
    # Only the module's own objects: re-exports are checked in the module that defines them.
    tests = [t for t in tests if t.filename and Path(t.filename).resolve() == Path(module.__file__).resolve()]
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    report = io.StringIO()
    for test in tests:
        runner.run(test, out=report.write)
    results = runner.summarize(verbose=False)
    assert results.failed == 0, (
        f"{results.failed} of {results.attempted} examples failed in {name}:\n{report.getvalue()}"
    )
