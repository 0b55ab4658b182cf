"""EnergyPlus 25.2 as an outside plant and an independent model: the C API binding
(:mod:`~hvacflex.energyplus.api`), IDF text handling (:mod:`~hvacflex.energyplus.idf`), the
period-by-period co-simulation (:mod:`~hvacflex.energyplus.runner`) and the IDF export of a
hvacflex building (:mod:`~hvacflex.energyplus.export`). Running EnergyPlus needs the extra
``pip install -e ".[energyplus]"`` (in the hvacflex clone); the plant built on it is
:class:`hvacflex.sim.energyplus_plant.EnergyPlusPlant`."""
