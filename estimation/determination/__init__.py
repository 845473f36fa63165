"""Static attitude determination from vector observations: TRIAD, Davenport's q method, QUEST.

Each solver takes body-frame directions and their inertial counterparts
(``(..., m, 3)``, any batch shape) with weights or measurement standard
deviations, and returns an :class:`AttitudeSolution` (``q_BN``, the
attitude-error covariance, Wahba's loss). The solvers, named like their
modules, are imported from them or from the ``estimation`` front door:
``from estimation.determination.quest import quest``,
``from estimation import quest, q_method, triad``.

See docs/attitude_determination.md for the algorithms and conventions.
"""

from estimation.determination.covariance import triad_covariance, wahba_covariance
from estimation.determination.solution import AttitudeSolution
from estimation.determination.vectors import OBSERVABILITY_MIN, observability

__all__ = ["OBSERVABILITY_MIN", "AttitudeSolution", "observability", "triad_covariance", "wahba_covariance"]
