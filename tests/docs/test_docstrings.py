"""Every parameter of every public function, constructor and method is documented.

In the spirit of python-control's ``control/tests/docstrings_test.py``: walk
the public modules of ``attitude``, ``controllers`` and ``estimation`` (no
leading underscore in the module path; the names in ``__all__`` when the
module has one, else the names without a leading underscore), and for each
public function, class constructor and public method defined there, check
that every parameter of the signature appears in the numpydoc ``Parameters``
section of its docstring (parsed with :mod:`numpydoc.docscrape`). ``self``
and ``cls`` are not checked, nor ``*args`` / ``**kwargs`` unless they are
documented. A constructor's parameters may be documented in the class
docstring or in ``__init__``'s; a dataclass's fields may be documented under
``Attributes`` (numpydoc's place for them). The conventions are DESIGN.md's
(numpydoc, units for every physical parameter); units are reviewed by eye,
this test checks presence.

The failure lists each function with its undocumented parameters.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import warnings
from pathlib import Path

from numpydoc.docscrape import NumpyDocString

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("attitude", "controllers", "estimation")
#: Entry points that are scripts, not library modules.
SKIP_MODULES = {"attitude.__main__"}


def public_modules() -> list[str]:
    names = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            if any(part.startswith("_") for part in parts):
                continue
            name = ".".join(parts)
            if name not in SKIP_MODULES:
                names.append(name)
    return names


def public_names(module) -> list[str]:
    if hasattr(module, "__all__"):
        return list(module.__all__)
    return [name for name in vars(module) if not name.startswith("_")]


def documented(doc: str | None, sections: tuple[str, ...] = ("Parameters",)) -> set[str] | None:
    """Names documented in the given numpydoc sections, or None when the docstring does not parse."""
    if not doc:
        return set()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            parsed = NumpyDocString(doc)
    except Exception:
        return None
    names = set()
    for section in sections:
        for param in parsed[section]:
            for name in param.name.split(","):
                names.add(name.strip().lstrip("*"))
    return names


def required(func, skip_first: bool) -> list[str]:
    try:
        signature = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    params = list(signature.parameters.values())
    if skip_first and params and params[0].name in ("self", "cls"):
        params = params[1:]
    return [p.name for p in params if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]


def check(label: str, func, docs: set[str] | None, skip_first: bool, problems: dict[str, list[str]]) -> int:
    if docs is None:
        problems[label] = ["(docstring does not parse as numpydoc)"]
        return 1
    missing = [name for name in required(func, skip_first) if name not in docs]
    if missing:
        problems[label] = missing
    return 1


def collect() -> tuple[int, dict[str, list[str]]]:
    """(number of callables checked, {qualified name: undocumented parameters})."""
    problems: dict[str, list[str]] = {}
    seen: set[int] = set()
    checked = 0
    for module_name in public_modules():
        module = importlib.import_module(module_name)
        for name in public_names(module):
            obj = getattr(module, name, None)
            if obj is None or id(obj) in seen or getattr(obj, "__module__", None) != module_name:
                continue
            seen.add(id(obj))
            label = f"{module_name}.{name}"
            if inspect.isfunction(obj):
                checked += check(label, obj, documented(inspect.getdoc(obj)), False, problems)
            elif inspect.isclass(obj):
                checked += check_class(label, obj, problems)
    return checked, problems


def check_class(label: str, cls: type, problems: dict[str, list[str]]) -> int:
    checked = 0
    init = cls.__dict__.get("__init__")
    if init is not None or dataclasses.is_dataclass(cls) or "__new__" in cls.__dict__:
        sections = ("Parameters", "Attributes") if dataclasses.is_dataclass(cls) else ("Parameters",)
        docs = documented(cls.__doc__ and inspect.cleandoc(cls.__doc__), sections)
        if init is not None and init.__doc__ and docs is not None:
            init_docs = documented(inspect.getdoc(init))
            docs = None if init_docs is None else docs | init_docs
        ctor = init if init is not None else cls
        checked += check(f"{label}.__init__", ctor, docs, True, problems)
    for attr, member in vars(cls).items():
        if attr.startswith("_"):
            continue
        if isinstance(member, (classmethod, staticmethod)):
            func = member.__func__
            skip_first = isinstance(member, classmethod)
        elif inspect.isfunction(member):
            func, skip_first = member, True
        else:
            continue
        checked += check(f"{label}.{attr}", func, documented(inspect.getdoc(func)), skip_first, problems)
    return checked


def test_modules_found():
    modules = public_modules()
    assert "attitude.quaternion" in modules and "estimation.rate_ekf" in modules
    assert "attitude.__main__" not in modules


def test_every_parameter_is_documented():
    checked, problems = collect()
    assert checked > 100, checked
    lines = [f"{label}: {', '.join(missing)}" for label, missing in sorted(problems.items())]
    count = sum(len(missing) for missing in problems.values())
    assert not problems, (
        f"{count} undocumented parameters in {len(problems)} of {checked} public callables "
        "(numpydoc 'Parameters' section):\n" + "\n".join(lines)
    )
