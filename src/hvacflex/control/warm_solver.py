"""The MPC's solver and the lifetime of its basis across periods.

One warm-started solver (:func:`hvacflex.opt.make_solver`) is kept from period to period;
its basis is what a checkpoint stores. A solver is built on the first solve (from a restored
basis, if any); a new model is a new LP structure, so the solver is rebuilt from the old
one's basis (the same columns and rows: it stays valid and is rotated as usual);
:meth:`SolverSlot.restart` drops HiGHS's live state and keeps the basis, as a run resumed
from a checkpoint starts.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from hvacflex.errors import ProblemError
from hvacflex.opt import RMPCProblem, RMPCSolution, RMPCSolver, SolverBasis, WarmSolver, make_solver
from hvacflex.opt.structure import RMPCStructure


class SolverSlot:
    """The MPC's warm solver, built on demand (see the module docstring).

    Parameters
    ----------
    time_limit_s : wall-clock limit per solve [s]; None = no limit.
    rebuilt_each_model : every model is a new structure of the same layout (trajectory
        and plan linearisation): a stored basis is taken over by each new solver, and a
        problem of another structure than the solver's rebuilds it from its basis.
    """

    def __init__(self, time_limit_s: float | None, *, rebuilt_each_model: bool = False) -> None:
        self.time_limit_s = time_limit_s
        self.rebuilt_each_model = rebuilt_each_model
        self._solver: WarmSolver | None = None
        self._pending: SolverBasis | None = None
        self._structure: RMPCStructure | None = None
        """The structure the live solver was built for."""

    def solve(self, problem: RMPCProblem) -> RMPCSolution:
        """Solve ``problem`` warm (the solver is built on first use)."""
        return self.solver(problem).solve(problem)

    def _follow(self, problem: RMPCProblem) -> None:
        """A problem of a new structure (``rebuilt_each_model``): the next solver is built
        from the live one's basis (:meth:`new_model`)."""
        built = self._structure
        if (
            self.rebuilt_each_model
            and built is not None
            and problem.structure is not built
            and built.differences(problem.structure)
        ):
            self.new_model(problem)

    def solver(self, problem: RMPCProblem) -> WarmSolver:
        """The solver of ``problem``'s structure (built on first use, from a stored basis
        if any; a basis of another row count starts it cold)."""
        return self._built(problem, lambda: make_solver(problem, time_limit_s=self.time_limit_s))

    def rmpc_solver(self, problem: RMPCProblem) -> RMPCSolver:
        """The open-loop solver of ``problem`` (a fleet's building re-solves it at the
        coordinator's prices and caps); as :meth:`solver`."""
        solver = self._built(problem, lambda: RMPCSolver(problem, time_limit_s=self.time_limit_s))
        assert isinstance(solver, RMPCSolver)
        return solver

    def _built(self, problem: RMPCProblem, build: Callable[[], WarmSolver]) -> WarmSolver:
        """The live solver of ``problem``'s structure, else a new one from ``build`` taking
        the stored basis (re-fingerprinted when rebuilt each model; another row count:
        cold)."""
        self._follow(problem)
        if self._solver is None:
            self._structure = problem.structure
            self._solver = build()
            pending = self._pending
            if pending is not None and self.rebuilt_each_model:
                pending = replace(pending, fingerprint=problem.structure.fingerprint())
            if pending is not None:
                try:
                    self._solver.set_basis(pending)
                except ProblemError:  # another row count (e.g. lazy event rows): cold start
                    pass
                self._pending = None
        return self._solver

    def new_model(self, problem: RMPCProblem) -> None:
        """``problem`` comes from a new model: the next solve starts a new solver from the
        current one's basis, re-fingerprinted for the new structure."""
        if self._solver is None:
            return
        basis = self._solver.get_basis()
        self._solver, self._structure = None, None
        self._pending = (
            None if basis is None else replace(basis, fingerprint=problem.structure.fingerprint())
        )

    def basis(self) -> SolverBasis | None:
        """The basis a resumed solver starts from (the live solver's, else the stored one)."""
        return self._solver.get_basis() if self._solver is not None else self._pending

    def restore(self, basis: SolverBasis | None) -> None:
        """Start from ``basis`` (:meth:`basis` of a checkpoint): handed to the live solver,
        or kept for the next one."""
        if self._solver is not None and basis is not None:
            if self.rebuilt_each_model:  # the next solver takes it over, re-fingerprinted
                self._solver, self._structure, self._pending = None, None, basis
            else:
                self._solver.set_basis(basis)
        else:
            self._pending = basis

    def restart(self) -> None:
        """Drop the solver (HiGHS's factorisation and internal state) and keep its basis to
        warm-start a new one at the next solve, as a restored controller starts."""
        if self._solver is not None:
            basis = self._solver.get_basis()
            self._solver, self._structure = None, None
            self._pending = basis
