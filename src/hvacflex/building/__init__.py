"""Buildings: description (TOML), RC network, linear model, nonlinear plant, HVAC power."""
