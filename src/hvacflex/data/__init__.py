"""Data from the outside world: prices, weather and solar, gains, forecasts, uncertainty.

Submodules (imported on demand, so ``import hvacflex.data`` stays light):

* :mod:`hvacflex.data.market` — NEMS USEP loader, synthetic / user reserve prices;
* :mod:`hvacflex.data.weather` — EPW reader and its validation, 30-min weather;
* :mod:`hvacflex.data.solar` — sun geometry over periods, façade irradiance (pvlib);
* :mod:`hvacflex.data.gains` — office schedules, internal gains, comfort band;
* :mod:`hvacflex.data.forecast` — ``Exogenous``, ``load_exogenous``, ``Forecaster``;
* :mod:`hvacflex.data.uncertainty` — ``UncertaintyBox``, ``DisturbanceSampler``, δ_k.
"""
