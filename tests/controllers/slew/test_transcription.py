"""Every IPOPT solve of the slew planner: Ctrl-C stops the planning instead of being taken for a failed start.

casadi polls for SIGINT inside IPOPT's callbacks and turns the
KeyboardInterrupt into an aborted solve: status ``User_Requested_Stop`` when it
arrives in the per-iteration callback, ``NonIpopt_Exception_Thrown`` (casadi
3.8) when it arrives during a function evaluation, and no Python exception
either way. The planner then went on with its next start, or rejected the
refinement and returned the unrefined grid plan.
"""

import math
import os
import signal

import casadi as ca
import numpy as np
import pytest

from attitude import RigidBody
from attitude import quaternion as quat
from controllers.slew import transcription
from controllers.slew.planner import plan_slew
from controllers.slew.transcription import sigint_guard, solve_nlp

UNIT = RigidBody([1.0, 1.0, 1.0])
Q_ID = [1.0, 0.0, 0.0, 0.0]
Q_180X = quat.from_axis_angle([1.0, 0.0, 0.0], math.pi)


def test_ctrl_c_in_the_first_start_stops_planning(monkeypatch, sigint_in_ipopt):
    # Two starts: the second used to run after the first was interrupted, and its plan was returned.
    solves = sigint_in_ipopt(monkeypatch, at_solve=1)
    with pytest.raises(KeyboardInterrupt):
        plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, nodes=20, starts=2)
    assert len(solves) == 1
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_ctrl_c_in_the_refinement_does_not_return_the_grid_plan(monkeypatch, sigint_in_ipopt):
    # The refinement is the solve after the two grid starts; it used to be "rejected" and the grid plan returned.
    solves = sigint_in_ipopt(monkeypatch, at_solve=3)
    with pytest.raises(KeyboardInterrupt):
        plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, nodes=20, starts=2)
    assert len(solves) == 3


class _SwallowingOpti:
    """Stands for casadi.Opti: Ctrl-C arrives inside ``solve``, which swallows it as casadi does."""

    def __init__(self, status: str, interrupt: bool) -> None:
        self.status = status
        self.interrupt = interrupt

    def solve(self) -> None:
        if self.interrupt:
            try:
                os.kill(os.getpid(), signal.SIGINT)
            except KeyboardInterrupt:
                pass  # casadi's handling: the solve ends, no exception reaches the caller
        raise RuntimeError(f"Error in Opti::solve [OptiNode] at .../casadi/core/optistack.cpp: {self.status}")

    def stats(self) -> dict:
        return {"return_status": self.status, "iter_count": 3}


def test_an_interrupt_casadi_swallowed_is_raised_again():
    with pytest.raises(KeyboardInterrupt):
        solve_nlp(_SwallowingOpti("NonIpopt_Exception_Thrown", interrupt=True))
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_failed_solve_without_interrupt_returns_its_status():
    # The same status without Ctrl-C (an exception in a user function) is a failed start, not an interrupt.
    assert solve_nlp(_SwallowingOpti("NonIpopt_Exception_Thrown", interrupt=False))["return_status"] == (
        "NonIpopt_Exception_Thrown"
    )


def test_user_requested_stop_is_an_interrupt():
    # The planner installs no iteration callback: only casadi's Ctrl-C check stops IPOPT this way.
    with pytest.raises(KeyboardInterrupt):
        solve_nlp(_SwallowingOpti("User_Requested_Stop", interrupt=False))


def test_ignored_sigint_is_left_alone(monkeypatch):
    # A campaign's worker ignores SIGINT (the parent decides): the solve must not install a handler there.
    monkeypatch.setattr(signal, "getsignal", lambda sig: signal.SIG_IGN)
    installed = []
    monkeypatch.setattr(signal, "signal", lambda *a: installed.append(a))
    assert solve_nlp(_SwallowingOpti("Solve_Succeeded", interrupt=False))["return_status"] == "Solve_Succeeded"
    assert installed == []


class _SigintOnShape(np.ndarray):
    """An array whose shape casadi reads through Python while it builds an expression: a Ctrl-C arriving there.

    casadi's SWIG layer discards the KeyboardInterrupt raised in that callback (it returns its result as if
    nothing happened), so without a guard around the whole planning it is lost.
    """

    @property
    def shape(self):
        os.kill(os.getpid(), signal.SIGINT)
        return np.ndarray.shape.__get__(self)


def test_casadi_discards_an_interrupt_in_a_python_callback():
    # The premise of the next test: no exception leaves casadi.
    assert np.array_equal(np.asarray(ca.DM(np.zeros(3).view(_SigintOnShape))).ravel(), np.zeros(3))


def test_ctrl_c_while_the_problem_is_built_stops_planning(monkeypatch):
    original = transcription.Transcription.__init__
    built: list[int] = []

    def init(self, *args, **kwargs):
        original(self, *args, **kwargs)
        built.append(1)
        if len(built) == 1:
            ca.DM(np.zeros(3).view(_SigintOnShape))  # a casadi call back into Python during the build

    solves: list[int] = []
    original_solve = ca.Opti.solve

    def solve(self):
        solves.append(1)
        return original_solve(self)

    monkeypatch.setattr(transcription.Transcription, "__init__", init)
    monkeypatch.setattr(ca.Opti, "solve", solve)
    with pytest.raises(KeyboardInterrupt):
        plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, nodes=20, starts=2)
    assert solves == []  # stopped at the first solve after the interrupt, before IPOPT ran
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_an_error_casadi_made_of_an_interrupt_gives_way_to_it():
    # casadi turns a KeyboardInterrupt in an operand's callback into "unsupported operand type(s)" (TypeError).
    with pytest.raises(KeyboardInterrupt) as caught, sigint_guard("stopped"):
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            raise TypeError("unsupported operand type(s) for +: 'MX' and 'ndarray'") from None
    assert isinstance(caught.value.__cause__, TypeError)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_an_error_without_interrupt_passes_through_the_guard():
    with pytest.raises(TypeError), sigint_guard("stopped"):
        raise TypeError("a bug, not a Ctrl-C")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
