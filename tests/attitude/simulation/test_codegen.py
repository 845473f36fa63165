"""Generated C called through ctypes (attitude.simulation.codegen.BufferedFunction) against casadi's own evaluation.

The same casadi Function evaluated two ways, the generated C on fixed buffers and casadi's virtual
machine: identical operations, so agreement to rounding (the C compiler may not contract a*b+c into one
fused operation: ``-ffp-contract=off``, codegen.COMPILE_FLAGS), and the fallback without a compiler
gives the same numbers.
"""

import casadi as ca
import numpy as np
import pytest

from attitude.simulation import codegen


def _function():
    x = ca.SX.sym("x", 3)
    p = ca.SX.sym("p", 2)
    return ca.Function("buffered_test", [x, p], [ca.sin(x) * p[0] + p[1], ca.vertcat(ca.dot(x, x), ca.exp(-x[0]))])


def test_the_compiled_function_on_buffers_equals_casadi():
    f = _function()
    buffered = codegen.BufferedFunction(f)
    assert buffered.compiled, buffered.compile_error
    rng = np.random.default_rng(0)
    for _ in range(50):
        x, p = rng.standard_normal(3), rng.standard_normal(2)
        buffered.inputs[0][:] = x
        buffered.inputs[1][:] = p
        buffered()
        for got, want in zip(buffered.outputs, f(x, p)):
            np.testing.assert_allclose(got, np.asarray(want).ravel(), rtol=1e-15, atol=1e-15)


def test_without_a_compiler_the_buffers_are_evaluated_by_casadi(monkeypatch):
    monkeypatch.setattr(codegen, "find_compiler", lambda: None)
    f = _function()
    buffered = codegen.BufferedFunction(f)
    assert not buffered.compiled and "no C compiler" in buffered.compile_error
    buffered.inputs[0][:] = [0.1, -0.2, 0.3]
    buffered.inputs[1][:] = [2.0, 0.5]
    buffered()
    expected = np.asarray(f([0.1, -0.2, 0.3], [2.0, 0.5])[0]).ravel()
    np.testing.assert_array_equal(buffered.outputs[0], expected)
    with pytest.raises(ValueError):
        buffered.inputs[0][:] = [1.0, 2.0]  # a buffer keeps its size: a wrong-length input is refused
