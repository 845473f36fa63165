"""The vectorised closed loop (attitude.simulation.batch) and its compiled kernel.

There is no external reference here: every test is an agreement between independent
implementations or code paths of the same definitions (:mod:`attitude.simulation.kernel`).

* Batch vs single run: :func:`attitude.simulation.batch.simulate_batch` (C or numpy per component)
  against :func:`attitude.simulation.engine.simulate` (casadi's virtual machine per run), run by
  run, with :func:`attitude.simulation.batch.closed_loop_metrics` on the single run as the metric
  reference: rounding only.
* Back ends: compiled C vs numpy (rounding only); a run is bit-identical whatever batch it is in, and
  a diverging run is isolated (the others bit-identical to a batch without it).
* :class:`attitude.rigid_body.ParametricBody` against :meth:`attitude.rigid_body.RigidBody.omega_dot_components`
  (Euler's equations, the one definition): rounding only.
* Compilation and cache (:mod:`attitude.simulation.codegen`): a compiled function's values computed
  by hand (``x^2 + 1``, ``x^3``), one compiler call per cached library, a damaged library rebuilt,
  thread safety, and the numpy fallback bit-identical to the numpy back end.
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

from __future__ import annotations

import shlex

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.config import default_config
from attitude.rigid_body import ParametricBody, RigidBody, symmetric_entries
from attitude.simulation import batch as mb
from attitude.simulation import codegen
from attitude.simulation.batch import closed_loop_metrics, simulate_batch
from attitude.simulation.build_cache import BuildCache
from attitude.simulation.engine import simulate
from controllers.pd import QuaternionPD

CONFIG = default_config()
BODY = assembly.rigid_body(CONFIG)
WHEELS = assembly.reaction_wheels(CONFIG)
Q_START = CONFIG.requirements.slew.q_start()
Q_TARGET = CONFIG.requirements.slew.q_target()
THRESHOLD = CONFIG.requirements.pointing_accuracy_rad
# Controller at 5 Hz on a 10 Hz tick: commands are held for two ticks.
CONTROLLER = QuaternionPD.from_bandwidth(BODY, wn=0.3, zeta=0.8, period=0.2, q_ref=Q_TARGET, gyroscopic=True)


def _dispersed(n: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    moments = BODY.principal_axes().moments * (1.0 + 0.05 * rng.standard_normal((n, 3)))
    axes = BODY.principal_axes().axes_B
    inertia = np.einsum("ij,nj,kj->nik", axes, moments, axes)
    q0 = quat.multiply(Q_START, quat.from_rotation_vector(0.01 * rng.standard_normal((n, 3))))
    omega0 = 1e-3 * rng.standard_normal((n, 3))
    disturbance = 1e-5 * rng.standard_normal((n, 3))
    return inertia, q0, omega0, disturbance


def _batch(backend: str, n: int = 5, duration: float = 60.0, **kwargs):
    inertia, q0, omega0, disturbance = _dispersed(n)
    kwargs.setdefault("history_stride", 7)
    return simulate_batch(
        RigidBody(inertia),
        q0,
        omega0,
        duration,
        controller=CONTROLLER,
        wheels=WHEELS,
        dt=0.1,
        substeps=2,
        disturbance=disturbance,
        pointing_threshold=THRESHOLD,
        backend=backend,
        **kwargs,
    )


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_batch_agrees_with_the_single_run_engine_run_by_run(backend):
    result = _batch(backend)
    assert result.info["backend"] == backend
    inertia, q0, omega0, disturbance = _dispersed(5)
    for i in range(5):
        single = simulate(
            RigidBody(inertia[i]),
            q0[i],
            omega0[i],
            60.0,
            controller=CONTROLLER,
            wheels=WHEELS,
            dt=0.1,
            substeps=2,
            disturbance=disturbance[i],
        )
        expected = closed_loop_metrics(single, THRESHOLD)
        # The same component arithmetic evaluated by C or numpy instead of casadi's virtual
        # machine: rounding only (measured <= 1e-13 relative over 600 ticks).
        for name, value in expected.items():
            np.testing.assert_allclose(result.metrics[name][i], value, rtol=1e-9, atol=1e-15, err_msg=name)
        np.testing.assert_allclose(result.q[i], single.q[-1], atol=1e-12)
        np.testing.assert_allclose(result.omega[i], single.omega[-1], atol=1e-14)
        np.testing.assert_allclose(result.h_wheels[i], single.h_wheels[-1], rtol=1e-10, atol=1e-15)
        np.testing.assert_allclose(result.histories["error_angle"][i], single.error_angle[::7], atol=1e-12)
        np.testing.assert_allclose(result.histories["wheel_speed"][i], single.wheel_speed[::7], rtol=1e-10)
    assert np.all(np.isnan(result.diverged_at))
    np.testing.assert_array_equal(result.history_t, np.arange(0, 601, 7) * 0.1)


def test_compiled_and_numpy_back_ends_agree_and_isolate_a_diverging_run():
    inertia, q0, omega0, disturbance = _dispersed(6)
    omega0[2] = [300.0, 200.0, -250.0]  # far beyond what RK4 at 0.1 s can follow: the run blows up
    common = dict(controller=CONTROLLER, wheels=WHEELS, disturbance=disturbance, pointing_threshold=THRESHOLD)
    out = {
        b: simulate_batch(RigidBody(inertia), q0, omega0, 60.0, backend=b, history_stride=50, **common)
        for b in ("compiled", "numpy")
    }
    c, n = out["compiled"], out["numpy"]
    assert np.isfinite(c.diverged_at[2]) and c.diverged_at[2] == n.diverged_at[2]
    assert np.all(np.isnan(np.delete(c.diverged_at, 2)))
    for name in c.metrics:
        assert np.isnan(c.metrics[name][2]) and np.isnan(n.metrics[name][2])
        # Rounding only (C vs numpy evaluation order of the same expressions).
        np.testing.assert_allclose(c.metrics[name], n.metrics[name], rtol=1e-10, atol=1e-15, err_msg=name)
    # The other runs do not see the diverging one: bit-identical to a batch without it.
    keep = [0, 1, 3, 4, 5]
    alone = simulate_batch(
        RigidBody(inertia[keep]),
        q0[keep],
        omega0[keep],
        60.0,
        backend="compiled",
        history_stride=50,
        controller=CONTROLLER,
        wheels=WHEELS,
        disturbance=disturbance[keep],
        pointing_threshold=THRESHOLD,
    )
    for name in c.metrics:
        np.testing.assert_array_equal(alone.metrics[name], c.metrics[name][keep])
    np.testing.assert_array_equal(alone.q, c.q[keep])
    np.testing.assert_array_equal(alone.histories["omega"], c.histories["omega"][keep])


def test_a_run_is_bit_identical_whatever_batch_it_is_in():
    many = _batch("compiled", n=5, history_stride=None)
    inertia, q0, omega0, disturbance = _dispersed(5)
    one = simulate_batch(
        RigidBody(inertia[3:4]),
        q0[3:4],
        omega0[3:4],
        60.0,
        controller=CONTROLLER,
        wheels=WHEELS,
        dt=0.1,
        substeps=2,
        disturbance=disturbance[3:4],
        pointing_threshold=THRESHOLD,
        backend="compiled",
    )
    for name in many.metrics:
        assert one.metrics[name][0] == many.metrics[name][3]
    np.testing.assert_array_equal(one.q[0], many.q[3])


def test_without_a_compiler_auto_falls_back_to_numpy_and_compiled_raises(tmp_path, monkeypatch):
    monkeypatch.setenv(codegen.CACHE_ENV, str(tmp_path))  # nothing cached: the compiler must run
    monkeypatch.setenv("CC", "false")  # a "compiler" that always fails
    monkeypatch.setattr(mb, "_TICKS_CACHE", BuildCache(4))
    with pytest.raises(codegen.CompilationError, match="failed"):
        _batch("compiled", n=2, duration=1.0)
    with pytest.warns(RuntimeWarning, match="numpy fallback"):
        fallback = _batch("auto", n=2, duration=1.0)
    assert fallback.info["backend"] == "numpy"
    assert "numpy fallback" in fallback.info["backend_note"]
    reference = _batch("numpy", n=2, duration=1.0)
    for name in reference.metrics:
        np.testing.assert_array_equal(fallback.metrics[name], reference.metrics[name])


def test_an_unusable_cache_directory_falls_back_to_numpy_with_a_warning(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(codegen.CACHE_ENV, str(blocker / "kernels"))
    monkeypatch.setattr(mb, "_TICKS_CACHE", BuildCache(4))
    with pytest.raises(codegen.CompilationError, match="ATTITUDE_CACHE_DIR"):
        _batch("compiled", n=2, duration=1.0)
    with pytest.warns(RuntimeWarning, match="numpy fallback"):
        fallback = _batch("auto", n=2, duration=1.0)
    assert fallback.info["backend"] == "numpy"


def test_bad_arguments_are_rejected_with_their_name():
    with pytest.raises(ValueError, match="backend must be"):
        _batch("fortran", n=2, duration=1.0)
    with pytest.raises(ValueError, match="history_stride"):
        _batch("numpy", n=2, duration=1.0, history_stride=0)
    with pytest.raises(ValueError, match="progress must be callable"):
        _batch("numpy", n=2, duration=1.0, progress=0.5)


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_progress_reports_the_fraction_of_ticks_and_changes_no_number(backend, monkeypatch):
    """The progress callback sees the batch's ticks done, in order up to all of them; the results are the same bits.

    Every report let through (no wait between reports), and the numpy batch in 3 chunks of 2 runs, so
    the fraction runs over every chunk's ticks. The compiled back end splits its ticks into
    ``PROGRESS_SEGMENTS`` calls, which must leave the state, the metrics and the histories unchanged.
    """
    import attitude.progress

    monkeypatch.setattr(attitude.progress, "REFRESH_PERIOD_S", 0.0)
    monkeypatch.setattr(mb, "BATCH_CHUNK", 2)
    reference = _batch(backend, n=5)
    fractions: list[float] = []
    reported = _batch(backend, n=5, progress=fractions.append)
    for name in reference.metrics:
        np.testing.assert_array_equal(reported.metrics[name], reference.metrics[name], err_msg=name)
    np.testing.assert_array_equal(reported.q, reference.q)
    np.testing.assert_array_equal(reported.h_wheels, reference.h_wheels)
    for name in reference.histories:
        np.testing.assert_array_equal(reported.histories[name], reference.histories[name], err_msg=name)
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and fractions[0] >= 0.0
    n_ticks = 600
    if backend == "numpy":  # one report per tick of each of the 3 chunks, and the last tick of each
        assert len(fractions) == 3 * (n_ticks + 1)
    else:  # one report per compiled call
        assert mb.PROGRESS_SEGMENTS <= len(fractions) <= mb.PROGRESS_SEGMENTS + n_ticks // 7 + 1


def test_compiled_kernels_are_cached_on_disk_and_rebuilt_when_damaged(tmp_path, monkeypatch):
    import casadi as ca

    real = shlex.join(codegen.find_compiler())
    log = tmp_path / "calls.log"
    counting = tmp_path / "counting-cc"
    counting.write_text(f'#!/bin/sh\necho "$@" >> "{log}"\nexec {real} "$@"\n')
    counting.chmod(0o755)
    monkeypatch.setenv("CC", str(counting))
    monkeypatch.setenv(codegen.CACHE_ENV, str(tmp_path / "cache"))
    x = ca.SX.sym("x", 2)
    f = ca.Function("square_plus", [x], [x * x + 1.0])
    (first,) = codegen.compile_functions([f])
    np.testing.assert_array_equal(np.array(first(ca.DM([2.0, -3.0]))).ravel(), [5.0, 10.0])
    (again,) = codegen.compile_functions([f])
    np.testing.assert_array_equal(np.array(again(ca.DM([0.5, 1.0]))).ravel(), [1.25, 2.0])
    assert log.read_text().count("-shared") == 1  # the second call loaded the cached library
    # A damaged entry (never loaded by this process: a loaded library is never rewritten in place).
    g = ca.Function("cube", [x], [x * x * x])
    damaged = codegen.library_path([g])
    damaged.write_bytes(b"not a shared library")
    (rebuilt,) = codegen.compile_functions([g])
    np.testing.assert_array_equal(np.array(rebuilt(ca.DM([2.0, -1.0]))).ravel(), [8.0, -1.0])
    assert log.read_text().count("-shared") == 2
    with pytest.raises(ValueError, match="distinct names"):
        codegen.compile_functions([f, f])


def test_parametric_body_is_the_rigid_body_with_its_entries_as_inputs():
    rng = np.random.default_rng(5)
    body = RigidBody(BODY.inertia)
    para = ParametricBody(list(symmetric_entries(body.inertia)), list(symmetric_entries(body.inertia_inv)))
    omega = list(rng.standard_normal((3, 10)))
    torque = list(1e-3 * rng.standard_normal((3, 10)))
    h = list(1e-2 * rng.standard_normal((3, 10)))
    expected = body.omega_dot_components(omega, torque, h)
    got = para.omega_dot_components(omega, torque, h)
    # Same formula; only the zero-entry skipping of RigidBody can change the rounding.
    np.testing.assert_allclose(np.array(got), np.array(expected), rtol=1e-13, atol=1e-18)
    with pytest.raises(ValueError, match="6 entries"):
        ParametricBody([1.0, 2.0, 3.0], [1.0] * 6)


def test_batches_in_threads_share_the_compiled_kernel_safely():
    # A Dask worker with several threads runs batches concurrently on one process's kernel cache.
    from concurrent.futures import ThreadPoolExecutor

    seeds = [1, 2, 3, 4, 5, 6]

    def run(seed):
        inertia, q0, omega0, disturbance = _dispersed(40, seed)
        return simulate_batch(
            RigidBody(inertia),
            q0,
            omega0,
            30.0,
            controller=CONTROLLER,
            wheels=WHEELS,
            disturbance=disturbance,
            pointing_threshold=THRESHOLD,
            backend="compiled",
        )

    serial = [run(s) for s in seeds]
    with ThreadPoolExecutor(max_workers=3) as pool:
        threaded = list(pool.map(run, seeds))
    for a, b in zip(serial, threaded):
        np.testing.assert_array_equal(a.q, b.q)
        for name in a.metrics:
            np.testing.assert_array_equal(a.metrics[name], b.metrics[name])


def test_a_compiler_command_with_arguments_and_a_library_that_will_not_load(tmp_path, monkeypatch):
    import casadi as ca

    monkeypatch.setenv(codegen.CACHE_ENV, str(tmp_path / "cache"))
    x = ca.SX.sym("x")
    monkeypatch.setenv("CC", "env " + shlex.join(codegen.find_compiler()))  # a launcher, like "ccache gcc"
    (f,) = codegen.compile_functions([ca.Function("twice", [x], [2.0 * x])])
    assert float(f(3.0)) == 6.0
    junk = tmp_path / "junk-cc"  # "compiles" into a file that is no shared library
    junk.write_text('#!/bin/sh\nfor a; do o="$n"; n="$a"; [ "$o" = "-o" ] && echo junk > "$a"; done; exit 0\n')
    junk.chmod(0o755)
    monkeypatch.setenv("CC", str(junk))
    with pytest.raises(codegen.CompilationError, match="cannot be loaded"):
        codegen.compile_functions([ca.Function("thrice", [x], [3.0 * x])])
    monkeypatch.setenv("CC", "no-such-compiler --fast")
    with pytest.raises(codegen.CompilationError, match="CC='no-such-compiler --fast' is not on the PATH"):
        codegen.compile_functions([ca.Function("four", [x], [4.0 * x])])
