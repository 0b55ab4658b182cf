"""Closed-loop simulation (receding horizon against the nonlinear plant) and sweeps.

Importing it registers the types a stored state may hold (:mod:`hvacflex.sim.stored_types`).
"""

from hvacflex.sim import stored_types as _stored_types  # noqa: F401  (registers them)
