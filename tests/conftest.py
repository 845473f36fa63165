"""Shared test configuration: hypothesis profiles and a non-interactive backend."""

import os
import signal

import matplotlib
import pytest
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

# CI runs more examples than a local edit-test loop; both are deterministic
# (derandomize) so a failure reproduces from the same commit.
settings.register_profile(
    "ci", max_examples=300, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "dev", max_examples=100, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The tests marked slow first, each group in its collection order.

    With two workers a minute-long test collected last (the rate EKF's Monte Carlo, in ``tests/estimation``)
    ran alone at the end while the other worker idled; started first, the short tests fill in around it. The
    slow tests that share a module fixture are all marked, so moving them keeps each fixture's users together.
    """
    items[:] = sorted(items, key=lambda item: item.get_closest_marker("slow") is None)


def _sigint_in_ipopt(monkeypatch: pytest.MonkeyPatch, at_solve: int = 1, at_iteration: int = 2) -> list[int]:
    """Deliver SIGINT inside IPOPT's iteration loop of the slew planner's ``at_solve``-th solve (a real Ctrl-C).

    The signal is sent from IPOPT's per-iteration callback, so it arrives while
    the solver runs, deterministically, as a key press would. The patch lasts
    as long as ``monkeypatch`` (a test's, or a ``monkeypatch.context()``).
    Returns the list counting the solves started.
    """
    from controllers.slew import transcription

    original = transcription.Transcription.solve
    count: list[int] = []

    def solve(self, initial, values):
        count.append(1)
        if len(count) == at_solve:
            self.opti.callback(lambda i: os.kill(os.getpid(), signal.SIGINT) if i == at_iteration else None)
        return original(self, initial, values)

    monkeypatch.setattr(transcription.Transcription, "solve", solve)
    return count


@pytest.fixture
def sigint_in_ipopt():
    """The function ``sigint_in_ipopt(monkeypatch, at_solve=1, at_iteration=2)``: Ctrl-C during a planner solve."""
    return _sigint_in_ipopt
