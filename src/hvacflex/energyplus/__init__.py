"""EnergyPlus: an independent model of a hvacflex building (IDF export)."""
