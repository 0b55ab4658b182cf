"""hvacflex: robust predictive control of building HVAC in electricity markets.

A building's air-conditioning buys energy at real-time prices (Singapore NEMS USEP), offers
interruptible-load reserve, keeps a utility peak-power price in check, and keeps room comfort
for every forecast error inside a box. See ``docs/model.md`` for the model and the problem.
"""

from importlib import metadata

try:
    __version__ = metadata.version("hvacflex")
except metadata.PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
