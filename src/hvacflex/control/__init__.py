"""Controllers: building + forecast → problem each step, and rule-based baselines."""
