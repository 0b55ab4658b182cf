"""Closed-loop simulation (receding horizon against the nonlinear plant) and sweeps."""
