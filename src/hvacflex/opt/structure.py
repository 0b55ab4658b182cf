"""What fixes an RMPC problem's LP: its columns, rows and constant coefficients
(:class:`RMPCStructure`). A solver is built once per structure; problems of the same
structure differ only in costs, bounds and the step-varying coefficients."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True, eq=False, kw_only=True)
class RMPCStructure:
    """The parts of a problem that fix the LP's columns, rows and constant coefficients."""

    a_matrix: FloatArray
    b_matrix: FloatArray
    e_matrix: FloatArray
    c_matrix: FloatArray
    horizon: int
    reserve_mask: BoolArray
    robust: str
    il_event_max_steps: int | None = None  # D; None = whole-horizon model
    il_event_recovery_steps: int = 0  # R (α and c enter row bounds only)
    visible_offers: bool = False  # offer columns and rows (add_visible_offers)
    comfort_knee: bool = False  # ε beyond the knee: columns and rows (add_comfort_knee)
    input_scale: FloatArray | None = None  # (N, m) s_k of B diag(s_k); None = ones

    @property
    def step_b_matrix(self) -> FloatArray:
        """(N, n, m) B diag(s_k) of each step (read-only)."""
        b = self.b_matrix[None]
        if self.input_scale is None:
            steps: FloatArray = np.broadcast_to(b, (self.horizon, *self.b_matrix.shape))
            return steps
        scaled: FloatArray = b * self.input_scale[:, None, :]
        scaled.setflags(write=False)
        return scaled

    def differences(self, other: RMPCStructure) -> list[str]:
        """Names of the fields in which ``other`` differs from this structure."""
        arrays = ("a_matrix", "b_matrix", "e_matrix", "c_matrix", "reserve_mask")
        names = [n for n in arrays if not np.array_equal(getattr(self, n), getattr(other, n))]
        mine, theirs = self.input_scale, other.input_scale
        if (mine is None) != (theirs is None) or (
            mine is not None and theirs is not None and not np.array_equal(mine, theirs)
        ):
            names.append("input_scale")
        return names + [
            f.name
            for f in fields(self)
            if f.name not in (*arrays, "input_scale")
            and getattr(self, f.name) != getattr(other, f.name)
        ]

    def fingerprint(self) -> str:
        """A hex digest identifying this structure (used to match saved solver bases)."""
        digest = hashlib.sha256()
        for array in (self.a_matrix, self.b_matrix, self.e_matrix, self.c_matrix):
            digest.update(str(array.shape).encode())
            digest.update(np.ascontiguousarray(array).tobytes())
        digest.update(np.ascontiguousarray(self.reserve_mask).tobytes())
        digest.update(f"{self.horizon}|{self.robust}".encode())
        if self.il_event_max_steps is not None:
            digest.update(f"|D={self.il_event_max_steps}|R={self.il_event_recovery_steps}".encode())
        if self.visible_offers:
            digest.update(b"|visible-offers")
        if self.comfort_knee:
            digest.update(b"|comfort-knee")
        if self.input_scale is not None:
            digest.update(b"|input-scale")
            digest.update(np.ascontiguousarray(self.input_scale).tobytes())
        return digest.hexdigest()
