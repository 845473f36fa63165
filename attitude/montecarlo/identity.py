"""The identity of a scenario by its content: the code it runs and the values it runs with.

A campaign's checkpoint may only be resumed by the same campaign
(:mod:`attitude.montecarlo.campaign`), so a scenario without a ``fingerprint``
string attribute is identified by what it is made of, never by its name:

* a **function** (a lambda, a closure): its code object, recursively (the
  bytecode, the constants including nested functions' code, the names it
  uses, its argument names), its defaults and keyword defaults, the values in
  its closure cells, and the values of the module globals it names;
* a **callable object**: its class (the code of every method, the class
  attributes, the base classes) and its state, read through the pickle
  protocol (``__reduce_ex__``: ``__dict__``, ``__slots__``, ``__getstate__``);
* **values** reached on the way: numbers, strings, bytes, ``None``, tuples,
  lists, dicts and sets (sets in an order independent of ``PYTHONHASHSEED``),
  numpy arrays (dtype, shape and bytes) and numpy scalars, by content; other
  objects through their pickle state, recursively.

Functions and classes of the user's own code (any module outside the
standard library, the installed packages and this toolkit) are identified by
their content, whatever module they live in; so is a module of the user's
reached as a value (``import helpers`` then ``helpers.g(x)``): by the
attributes the code that reaches it looks up on it (the names in its code
objects, followed through submodules: ``pkg.sub.g``), or, reached from data
(an object's state, a class attribute), by everything it defines. A wrapper
(``functools.lru_cache``, ``functools.wraps``: anything holding
``__wrapped__``) is identified with the function it wraps, by content. Those
of the standard library,
of installed packages and of this toolkit by their module, qualified name and
the package's ``__version__`` (they change with an upgrade, not with the
user's edits). Line numbers and file names are left out: moving a function in
its file keeps its identity; any edit of its code, a docstring included,
changes it. Bytecode is specific to the Python version, so a new Python
interpreter gives new identities.

What cannot be identified (a lock, an open file, a generator, a built-in
function or C-extension callable given as the scenario itself, anything whose
pickle protocol refuses) raises :class:`UnidentifiableScenario`, naming the
value and where it was found; :func:`attitude.montecarlo.campaign.run_campaign`
then runs the campaign afresh, with an :class:`UnidentifiableScenarioWarning`
when it starts, but refuses to resume it. A ``fingerprint``
string attribute on the scenario names its settings instead and always wins.
"""

from __future__ import annotations

import hashlib
import struct
import sys
import sysconfig
import types
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["UnidentifiableScenario", "UnidentifiableScenarioWarning", "scenario_identity"]

#: Top-level packages of this toolkit: identified by name and version, like any installed package.
_TOOLKIT = frozenset({"attitude", "controllers", "estimation"})
_PLAIN = (type(None), bool, int, float, complex, str, bytes)
#: Class attributes every class has, which say nothing about what it does.
_CLASS_NOISE = frozenset({"__dict__", "__weakref__", "__module__", "__qualname__", "__firstlineno__"})


class UnidentifiableScenario(ValueError):
    """The scenario's content cannot be identified reliably (the message names the value and where it is)."""


class UnidentifiableScenarioWarning(UserWarning):
    """A campaign with an output directory whose scenario cannot be identified: it runs, but can never resume."""


def scenario_identity(scenario: Any) -> str:
    """A hex digest of a scenario's content (module docstring), the same in every process.

    Parameters
    ----------
    scenario : callable
        A function or a callable object ``scenario(params, rng)``.

    Returns
    -------
    str
        SHA-256 hex digest of the scenario's code and values.

    Raises
    ------
    UnidentifiableScenario
        When a part of the scenario can only be identified by its memory address, or the scenario is
        a built-in or C-extension callable.
    """
    if isinstance(scenario, (types.BuiltinFunctionType, types.MethodWrapperType, types.WrapperDescriptorType)):
        raise UnidentifiableScenario(f"the scenario {scenario!r} is a built-in (C) callable, whose code cannot be read")
    try:
        return _Hasher().digest(scenario)
    except RecursionError:
        raise UnidentifiableScenario("the scenario's values nest too deeply to be identified") from None


def _is_library(module_name: str | None) -> bool:
    """Whether a module belongs to the standard library, an installed package or this toolkit."""
    if not module_name or module_name == "__main__":
        return False
    top = module_name.partition(".")[0]
    if top in _TOOLKIT or top in sys.stdlib_module_names or top == "builtins":
        return True
    module = sys.modules.get(top)
    if module is None:
        return False  # a module made on the fly (exec): the user's
    file = getattr(module, "__file__", None)
    if file is None:  # compiled into the interpreter (a library), or made on the fly (the user's)
        return getattr(getattr(module, "__spec__", None), "origin", None) in ("built-in", "frozen")
    path = Path(file).resolve()
    if any(part in ("site-packages", "dist-packages") for part in path.parts):
        return True
    stdlib = Path(sysconfig.get_paths()["stdlib"]).resolve()
    return stdlib in path.parents


def _version(module_name: str) -> str:
    module = sys.modules.get(module_name.partition(".")[0])
    return str(getattr(module, "__version__", ""))


class _Hasher:
    """Feeds a stable, typed serialisation of a value graph into SHA-256 (cycles as back references)."""

    def __init__(self) -> None:
        self._sha = hashlib.sha256()
        self._seen: dict[int, int] = {}
        self._alive: list[Any] = []  # keeps every visited object alive, so no id() is reused meanwhile
        # The attribute names the code being hashed looks up (None: reached from data, not code), which
        # say what a user's module reached as a value contributes.
        self._names: frozenset[str] | None = None
        self._modules_seen: dict[tuple[int, frozenset[str] | None], int] = {}

    def digest(self, value: Any) -> str:
        self._value(value, "the scenario")
        return self._sha.hexdigest()

    def _put(self, tag: str, data: bytes = b"") -> None:
        # Length-prefixed, so no two different sequences of items give the same bytes.
        self._sha.update(tag.encode() + b"\0" + struct.pack("<Q", len(data)) + data)

    def _text(self, tag: str, text: str) -> None:
        self._put(tag, text.encode("utf-8", "surrogatepass"))

    def _sub_digest(self, value: Any, where: str) -> bytes:
        """A value's own digest (to sort the members of a set or the items of a dict)."""
        sub = _Hasher()
        sub._value(value, where)
        return sub._sha.digest()

    def _value(self, value: Any, where: str) -> None:
        if isinstance(value, _PLAIN):
            self._text(type(value).__name__, repr(value))  # repr of a float round trips exactly
            return
        if isinstance(value, types.ModuleType):
            self._module(value, where)  # not by id alone: what it contributes depends on the code reaching it
            return
        key = id(value)
        if key in self._seen:
            self._put("backref", struct.pack("<Q", self._seen[key]))
            return
        self._seen[key] = len(self._seen)
        self._alive.append(value)
        self._compound(value, where)

    def _compound(self, value: Any, where: str) -> None:
        if isinstance(value, np.ndarray):
            self._array(value, where)
        elif isinstance(value, np.generic):
            self._text("npscalar", value.dtype.str)
            self._put("bytes", value.tobytes())
        elif isinstance(value, (tuple, list)):
            self._put(type(value).__name__, struct.pack("<Q", len(value)))
            for i, item in enumerate(value):
                self._value(item, f"{where}[{i}]")
        elif isinstance(value, (set, frozenset)):
            members = sorted(self._sub_digest(v, f"a member of {where}") for v in value)
            self._put(type(value).__name__, b"".join(members))
        elif type(value) is dict or isinstance(value, types.MappingProxyType):
            # In an order independent of how the dict was filled (e.g. from a set, whose order hashes decide).
            items = sorted(value.items(), key=lambda kv: self._sub_digest(kv[0], f"a key of {where}"))
            self._put("dict", struct.pack("<Q", len(items)))
            for k, v in items:
                self._value(k, f"a key of {where}")
                self._value(v, f"{where}[{k!r}]")
        elif isinstance(value, types.CodeType):
            self._code(value, where)
        elif isinstance(value, types.FunctionType):
            self._function(value, where)
        elif isinstance(value, type):
            self._class(value, where)
        elif isinstance(value, (staticmethod, classmethod)):
            self._put(type(value).__name__)
            self._value(value.__func__, where)
        elif isinstance(value, property):
            self._put("property")
            for part in (value.fget, value.fset, value.fdel):
                self._value(part, where)
        elif isinstance(value, (types.MemberDescriptorType, types.GetSetDescriptorType)):
            self._text("descriptor", value.__name__)  # a __slots__ member: its value is in the instance state
        elif isinstance(value, types.CellType):
            try:
                contents = value.cell_contents
            except ValueError:
                self._put("emptycell")
            else:
                self._value(contents, where)
        elif isinstance(value, (types.BuiltinFunctionType, types.MethodDescriptorType)) and _importable(value):
            self._reference(value)
        else:
            self._reduced(value, where)

    def _array(self, value: np.ndarray, where: str) -> None:
        self._text("ndarray", f"{value.dtype.str} {value.shape}")
        if value.dtype.hasobject:
            for i, item in enumerate(value.ravel(order="C").tolist()):
                self._value(item, f"{where}.flat[{i}]")
        else:
            self._put("bytes", np.ascontiguousarray(value).tobytes())

    def _code(self, code: types.CodeType, where: str) -> None:
        # Not co_filename, co_firstlineno nor the line table: moving code keeps its identity.
        self._text("code", code.co_name)
        self._put("co_code", code.co_code)
        self._put(
            "co_flags",
            struct.pack("<5Q", code.co_flags, code.co_argcount, code.co_posonlyargcount, code.co_kwonlyargcount, 0),
        )
        for name in ("co_names", "co_varnames", "co_freevars", "co_cellvars"):
            self._value(getattr(code, name), where)
        self._value(code.co_consts, f"the constants of {code.co_name}")

    def _module(self, module: types.ModuleType, where: str) -> None:
        if _is_library(module.__name__):
            self._text("module", f"{module.__name__} {_version(module.__name__)}")
            return
        key = (id(module), self._names)
        if key in self._modules_seen:  # a cycle of imports
            self._put("modref", struct.pack("<Q", self._modules_seen[key]))
            return
        self._modules_seen[key] = len(self._modules_seen)
        self._alive.append(module)
        defined = vars(module)
        if self._names is None:
            names = sorted(n for n in defined if not (n.startswith("__") and n.endswith("__")))
        else:
            names = sorted(n for n in self._names if n in defined)
        self._text("usermodule", module.__name__)
        self._put("attrs", struct.pack("<Q", len(names)))
        for n in names:
            self._text("attr", n)
            self._value(defined[n], f"{module.__name__}.{n} (reached from {where})")

    def _function(self, func: types.FunctionType, where: str) -> None:
        if _is_library(func.__module__):
            self._reference(func)
            self._wrapped(func, where)
            return
        outer, self._names = self._names, frozenset(_global_names(func.__code__))
        try:
            self._user_function(func)
        finally:
            self._names = outer

    def _user_function(self, func: types.FunctionType) -> None:
        name = f"{func.__module__}.{func.__qualname__}"
        self._text("function", func.__qualname__)
        self._code(func.__code__, name)
        self._value(func.__defaults__, f"the defaults of {name}")
        self._value(func.__kwdefaults__, f"the keyword defaults of {name}")
        self._value(func.__closure__, f"the closure of {name}")
        self._value(func.__dict__ or None, f"the attributes of {name}")
        names = sorted(_global_names(func.__code__))
        referenced = {n: func.__globals__[n] for n in names if n in func.__globals__}
        self._put("globals", struct.pack("<Q", len(referenced)))
        for n, v in referenced.items():
            self._text("global", n)
            self._value(v, f"the global {n!r} of {name}")

    def _class(self, cls: type, where: str) -> None:
        if _is_library(cls.__module__):
            self._reference(cls)
            return
        outer, self._names = self._names, None  # a module as a class attribute: any method may look up anything
        try:
            self._user_class(cls)
        finally:
            self._names = outer

    def _user_class(self, cls: type) -> None:
        name = f"{cls.__module__}.{cls.__qualname__}"
        self._text("class", cls.__qualname__)
        self._value(cls.__bases__, f"the bases of {name}")
        attrs = sorted((k, v) for k, v in vars(cls).items() if k not in _CLASS_NOISE)
        self._put("attrs", struct.pack("<Q", len(attrs)))
        for k, v in attrs:
            self._text("attr", k)
            self._value(v, f"{name}.{k}")

    def _reference(self, value: Any) -> None:
        module = getattr(value, "__module__", None) or ""
        self._text("ref", f"{module}:{getattr(value, '__qualname__', '')}:{_version(module)}")

    def _wrapped(self, value: Any, where: str) -> None:
        """The function a wrapper named by reference wraps (``__wrapped__``, set by functools), by content."""
        attrs = getattr(value, "__dict__", None)
        wrapped = attrs.get("__wrapped__") if isinstance(attrs, dict) else None
        if wrapped is not None:
            self._put("wraps")
            self._value(wrapped, f"the function {where} wraps")

    def _reduced(self, value: Any, where: str) -> None:
        """Any other object, through the pickle protocol (its class and its state)."""
        outer, self._names = self._names, None  # a module in an object's state: any method may look up anything
        try:
            self._reduced_state(value, where)
        finally:
            self._names = outer

    def _reduced_state(self, value: Any, where: str) -> None:
        what = f"{where} ({type(value).__module__}.{type(value).__qualname__})"
        try:
            reduced = value.__reduce_ex__(4)
        except Exception as exc:
            raise UnidentifiableScenario(
                f"{what} cannot be identified by its content ({type(exc).__name__}: {exc})"
            ) from None
        if isinstance(reduced, str):  # a module-level singleton, pickled by name
            self._text("global", f"{type(value).__module__}.{reduced}")
            self._wrapped(value, where)  # functools.lru_cache pickles by name: what it caches is its content
            return
        parts = list(reduced) + [None] * (6 - len(reduced))
        constructor, args, state, list_items, dict_items = parts[:5]
        self._text("reduce", "")
        self._value(constructor, f"the constructor of {what}")
        self._value(args, f"the arguments of {what}")
        self._value(state, f"the state of {what}")
        self._value(None if list_items is None else list(list_items), f"the items of {what}")
        self._value(None if dict_items is None else dict(dict_items), f"the items of {what}")


def _importable(value: Any) -> bool:
    """Whether a built-in function is found again at its module and qualified name (``math.sqrt``)."""
    module = sys.modules.get(getattr(value, "__module__", None) or "")
    obj: Any = module
    for part in (getattr(value, "__qualname__", "") or "").split("."):
        obj = getattr(obj, part, None)
    return obj is value


def _global_names(code: types.CodeType) -> set[str]:
    """The names a code object and the code nested in it look up (globals among them)."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names
