"""Casadi functions compiled to C once, cached on disk, and loaded back.

casadi evaluates an expression graph in its virtual machine; the same graph
generated as C and compiled runs several times faster, which is what the
vectorised Monte Carlo path needs (:mod:`attitude.simulation.kernel`).
:func:`compile_functions` writes the C source of some casadi Functions with
``casadi.CodeGenerator``, compiles it into a shared library with the
system's C compiler and loads it with ``casadi.external``.

The library is cached under :func:`cache_dir`, named by a SHA-256 of the
source, the compiler (path and version), the machine architecture and the
flags: a kernel is compiled once per machine
(about 0.2 s for a closed-loop tick with gcc ``-O2``) and reused by later
campaigns and by every worker process. A library is written under a temporary
name and renamed into place, so workers compiling the same kernel at once
do not read each other's half-written files.

No fast-math flags: the kernels rely on IEEE semantics (``fabs(x) < inf``
detects NaN and infinity; ``fmax`` ignores NaN).
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import platform
import shlex
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

import casadi as ca
import numpy as np

__all__ = [
    "CACHE_ENV",
    "COMPILE_FLAGS",
    "BufferedFunction",
    "CompilationError",
    "cache_dir",
    "compile_functions",
    "compile_library",
    "entry_source",
    "find_compiler",
    "library_path",
]

#: Environment variable that overrides the cache directory.
CACHE_ENV = "ATTITUDE_CACHE_DIR"
#: Optimisation flags: portable code (no ``-march=native``) and no fused multiply-add contraction
#: (``-ffp-contract=off``: gcc contracts by default where the target has FMA, which would change rounding).
COMPILE_FLAGS = ("-O2", "-ffp-contract=off")


class CompilationError(RuntimeError):
    """No C compiler was found, or it failed on the generated source."""


def cache_dir() -> Path:
    """Where compiled kernels are kept.

    ``$ATTITUDE_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/attitude/kernels``
    (``~/.cache/attitude/kernels`` by default).
    """
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "attitude" / "kernels"


def find_compiler() -> list[str] | None:
    """The C compiler command: ``$CC`` if set (it may hold arguments, e.g. ``ccache gcc``), else ``cc``,
    ``gcc`` or ``clang`` on the PATH (None if none is found)."""
    if os.environ.get("CC"):
        parts = shlex.split(os.environ["CC"])
        path = shutil.which(parts[0]) if parts else None
        return None if path is None else [path, *parts[1:]]
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    return None


def compile_functions(functions: Sequence[ca.Function], *, flags: Sequence[str] = COMPILE_FLAGS) -> list[ca.Function]:
    """Compile casadi Functions into one cached shared library and load them.

    Parameters
    ----------
    functions : sequence of casadi.Function
        Functions with distinct names (SX or MX graphs casadi can generate).
    flags : sequence of str
        Compiler flags (besides ``-shared -fPIC``).

    Returns
    -------
    list of casadi.Function
        ``casadi.external`` functions, same names, signatures and order.

    Raises
    ------
    ValueError
        If ``functions`` is empty or two share a name.
    CompilationError
        If no compiler is found or compiling fails (its message is kept).
    """
    compiler, source, library = _plan(functions, flags)
    names = [f.name() for f in functions]
    try:
        if not library.exists():
            _build(compiler, list(flags), source, library)
        try:
            return [ca.external(name, str(library)) for name in names]
        except RuntimeError:
            # A damaged cache entry (e.g. a disk that filled up): build it again once. The new
            # file replaces the old one's directory entry; a process that has it loaded keeps the old one.
            library.unlink(missing_ok=True)
            _build(compiler, list(flags), source, library)
            try:
                return [ca.external(name, str(library)) for name in names]
            except RuntimeError as exc:  # e.g. a cache on a noexec mount, or a cross-compiler in CC
                raise CompilationError(f"{library} was built but cannot be loaded: {exc}") from exc
    except OSError as exc:  # an unwritable or missing cache directory, a full disk
        raise CompilationError(f"cannot build or load {library}: {exc} (set {CACHE_ENV} to a writable folder)") from exc


def compile_library(
    functions: Sequence[ca.Function], extra_source: str, *, flags: Sequence[str] = COMPILE_FLAGS
) -> Path:
    """Compile casadi Functions and hand-written C beside them into one cached shared library.

    For callers that load the library with :mod:`ctypes` and call a C entry
    point of their own (``extra_source``) that calls the generated functions
    with no Python in between (:mod:`attitude.simulation.protocol_tick`).

    Parameters
    ----------
    functions : sequence of casadi.Function
        Functions with distinct names; their C names are the Function names.
    extra_source : str
        C code appended to the generated source (it may use ``casadi_real``,
        ``casadi_int`` and the generated functions and their ``*_work``).
    flags : sequence of str
        Compiler flags (besides ``-shared -fPIC``).

    Returns
    -------
    pathlib.Path
        The library, built if it was not cached.

    Raises
    ------
    ValueError, CompilationError
        As :func:`compile_functions`.
    """
    compiler, source, library = _plan(functions, flags, extra_source)
    try:
        if not library.exists():
            _build(compiler, list(flags), source, library)
    except OSError as exc:
        raise CompilationError(f"cannot build {library}: {exc} (set {CACHE_ENV} to a writable folder)") from exc
    return library


def entry_source(function: ca.Function, template: str, **defines: int) -> str:
    """A hand-written C entry point calling ``function``, with its work-array sizes (and ``defines``) as macros.

    The template may use ``SZ_ARG``, ``SZ_RES``, ``SZ_IW`` and ``SZ_W`` (the sizes casadi's generated function
    needs for its ``arg``, ``res``, ``iw`` and ``w`` arrays, at least 1) and the names in ``defines``; they are
    ``#define``-d before it and ``#undef``-ined after, for :func:`compile_library`'s ``extra_source``.

    Parameters
    ----------
    function : casadi.Function
        The generated function the entry point calls.
    template : str
        The entry point's C source.
    **defines : int
        Further integer macros (e.g. a state size).

    Returns
    -------
    str
        The C source.
    """
    macros = {
        "SZ_ARG": function.sz_arg(),
        "SZ_RES": function.sz_res(),
        "SZ_IW": function.sz_iw() + 1,
        "SZ_W": function.sz_w() + 1,
        **defines,
    }
    head = "".join(f"#define {name} {int(value)}\n" for name, value in macros.items())
    tail = "".join(f"#undef {name}\n" for name in macros)
    return f"\n{head}{template}{tail}"


_BUFFERED_ENTRY = """
/* The function on fixed buffers: ctx holds the input pointers, then the output pointers. */
CASADI_SYMBOL_EXPORT int NAME_buffered(double **ctx) {
  const casadi_real *arg[SZ_ARG];
  casadi_real *res[SZ_RES];
  casadi_int iw[SZ_IW];
  casadi_real w[SZ_W];
  int i;
  for (i = 0; i < N_IN; i++) arg[i] = ctx[i];
  for (i = 0; i < N_OUT; i++) res[i] = ctx[N_IN + i];
  return NAME(arg, res, iw, w, 0);
}
"""


class BufferedFunction:
    """A casadi Function compiled to C and called through :mod:`ctypes` on fixed numpy buffers.

    Calling a casadi Function from Python costs some 50 us (argument
    conversion and the virtual machine); a per-tick function of a few hundred
    operations runs in a microsecond or two this way. Write the inputs into
    :attr:`inputs`, call, read :attr:`outputs` (overwritten by the next call:
    copy what is kept). Dense inputs and outputs only.

    Without a C compiler the same Function is evaluated by casadi on the same
    buffers (:attr:`compiled` is False, :attr:`compile_error` says why).

    Parameters
    ----------
    function : casadi.Function
        The function (its name names the C symbols).
    """

    def __init__(self, function: ca.Function) -> None:
        self.function = function
        self.inputs = [np.zeros(function.numel_in(i)) for i in range(function.n_in())]
        self.outputs = [np.zeros(function.numel_out(i)) for i in range(function.n_out())]
        self.compile_error: str | None = None
        self._keep = (*self.inputs, *self.outputs)
        self._ctx = (ctypes.c_void_p * len(self._keep))(*[a.ctypes.data for a in self._keep])
        self._entry = None
        template = _BUFFERED_ENTRY.replace("NAME", function.name())  # the C symbols are named by the function
        source = entry_source(function, template, N_IN=function.n_in(), N_OUT=function.n_out())
        try:
            library = ctypes.CDLL(str(compile_library([function], source)))
        except (CompilationError, OSError) as exc:
            self.compile_error = str(exc)
            return
        entry = getattr(library, f"{function.name()}_buffered")
        entry.argtypes = (ctypes.c_void_p,)
        entry.restype = ctypes.c_int
        self._library = library
        self._entry = entry
        self._address = ctypes.addressof(self._ctx)

    @property
    def compiled(self) -> bool:
        """Whether calls run the generated C (else casadi's virtual machine)."""
        return self._entry is not None

    def __call__(self) -> None:
        """Evaluate the function on :attr:`inputs` into :attr:`outputs`.

        Raises
        ------
        RuntimeError
            If the generated function reports a failure.
        """
        if self._entry is not None:
            if self._entry(self._address) != 0:
                raise RuntimeError(f"the compiled {self.function.name()} failed")
            return
        for out, value in zip(self.outputs, self.function(*self.inputs)):
            out[:] = np.asarray(value, dtype=float).ravel()


def library_path(functions: Sequence[ca.Function], *, flags: Sequence[str] = COMPILE_FLAGS) -> Path:
    """Where :func:`compile_functions` keeps the library of these functions (it may not exist yet).

    Parameters
    ----------
    functions : sequence of casadi.Function
        The functions of the library.
    flags : sequence of str, optional
        C compiler flags (part of the cache key).

    Raises
    ------
    ValueError, CompilationError
        As :func:`compile_functions`.
    """
    return _plan(functions, flags)[2]


def _plan(
    functions: Sequence[ca.Function], flags: Sequence[str], extra_source: str = ""
) -> tuple[list[str], str, Path]:
    """Compiler, C source and cache path of a set of functions."""
    names = [f.name() for f in functions]
    if not names:
        raise ValueError("functions must hold at least one casadi Function")
    if len(set(names)) != len(names):
        raise ValueError(f"functions must have distinct names, got {names}")
    compiler = find_compiler()
    if compiler is None:
        cc = os.environ.get("CC")
        where = f"CC={cc!r} is not on the PATH" if cc else "none of cc, gcc, clang is on the PATH"
        raise CompilationError(f"no C compiler found ({where}; set CC, or install one)")
    generator = ca.CodeGenerator("kernel.c", {"with_header": False})
    for f in functions:
        generator.add(f)
    source = generator.dump() + extra_source
    identity = [source, *compiler, _compiler_version(tuple(compiler)), platform.machine(), platform.system(), *flags]
    key = hashlib.sha256("\n".join([*identity, ca.__version__]).encode()).hexdigest()[:24]
    return compiler, source, cache_dir() / f"kernel_{key}.so"


@functools.lru_cache(maxsize=8)
def _compiler_version(compiler: tuple[str, ...]) -> str:
    """The compiler's ``--version`` banner (part of the cache key: another compiler, another library)."""
    try:
        done = subprocess.run([*compiler, "--version"], capture_output=True, text=True, check=False, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    return done.stdout.strip()


def _build(compiler: list[str], flags: list[str], source: str, library: Path) -> None:
    library.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        c_file = Path(work) / "kernel.c"
        c_file.write_text(source)
        built = Path(work) / library.name
        done = subprocess.run(
            [*compiler, *flags, "-shared", "-fPIC", str(c_file), "-o", str(built), "-lm"],
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            command = " ".join(compiler)
            raise CompilationError(f"{command} failed (exit {done.returncode}): {done.stderr.strip()[:2000]}")
        os.replace(built, library)
