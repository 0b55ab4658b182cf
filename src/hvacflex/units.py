"""Physical constants and unit conversions.

Quantities carry their unit in their name throughout hvacflex (``power_kw``, ``temp_degc``,
``price_sgd_per_mwh``, ``dt_s``). This module holds the few constants and conversions that
several modules share, so that no magic number appears twice.
"""

from __future__ import annotations

CP_AIR_J_PER_KG_K = 1006.0
"""Specific heat of dry air at constant pressure [J/(kg·K)]."""

RHO_AIR_KG_PER_M3 = 1.2
"""Density of air at about 20 °C and sea level [kg/m³]."""

H_FG_J_PER_KG = 2.501e6
"""Latent heat of vaporisation of water at 0 °C [J/kg]."""

SECONDS_PER_HOUR = 3600.0
W_PER_KW = 1000.0
KWH_PER_MWH = 1000.0
KELVIN_OFFSET = 273.15

STEFAN_BOLTZMANN_W_PER_M2K4 = 5.670374419e-8
"""Stefan–Boltzmann constant σ [W/(m²K⁴)] (CODATA 2018, exact)."""
