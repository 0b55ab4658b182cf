"""Load a shipped building, run one day on it and print the run's summary.

``hvacflex.load_building`` takes a shipped name (``office5``, ``room1``) or a building TOML
file; ``hvacflex.kpi_summary`` reads a run folder as ``hvacflex kpi`` does. Run from any
folder: ``python one_room.py``.
"""

from __future__ import annotations

import hvacflex

BUILDING = "room1"
"""One zone: the quickest shipped building."""


def main() -> None:
    building = hvacflex.load_building(BUILDING)
    floor_area_m2 = sum(zone.floor_area_m2 for zone in building.zones)
    print(f"{building.name}: {len(building.zones)} zone(s), {floor_area_m2:.1f} m² floor area")
    run = hvacflex.simulate(
        "rmpc", "results/examples/room1", quiet=True, building=BUILDING, start="2014-03-03", days=1
    )
    summary = hvacflex.kpi_summary(run.out_dir)
    for key in ("energy_kwh", "net_cost_sgd", "peak_power_kw", "discomfort_kelvin_hours"):
        print(f"{key:<26}{summary[key]:>10.2f}")
    print(f"{'energy_kwh_per_m2':<26}{summary['energy_kwh'] / floor_area_m2:>10.3f}")


if __name__ == "__main__":
    main()
