"""The robust MPC optimisation problem on plain arrays, and its HiGHS solver."""
