"""EnergyPlus 25.2 as an outside plant: the C API binding (:mod:`~hvacflex.energyplus.api`),
IDF text handling (:mod:`~hvacflex.energyplus.idf`) and the period-by-period co-simulation
(:mod:`~hvacflex.energyplus.runner`). Needs the extra ``pip install "hvacflex[energyplus]"``;
the plant built on it is :class:`hvacflex.sim.energyplus_plant.EnergyPlusPlant`."""
