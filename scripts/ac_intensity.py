"""office5's air-conditioning intensity over a year under the 24 °C thermostat, hvacflex and
EnergyPlus.

hvacflex: the ``thermostat`` preset (24 °C occupied, 29 °C otherwise, flows ≥ the ventilation
flow while occupied, 0 allowed otherwise) on the nonlinear RC plant with the realised
forecast error set to zero, as :func:`hvacflex.validation.energyplus.rc_thermostat_run`; its
``power_kw`` is fans + cooling plant. EnergyPlus: the ``vav`` export under its own thermostat
(the same rule), Electricity:HVAC + Electricity:Plant. Both over the calendar year of the
export (2014), the same EPW; intensity = HVAC electricity / floor area [kWh/m²·yr].

    python scripts/ac_intensity.py [--days 365] [--out DIR]
"""

from __future__ import annotations

import argparse
import tempfile
from datetime import date
from pathlib import Path

from hvacflex.building.io import load_building
from hvacflex.data.forecast import default_weather_file
from hvacflex.energyplus.export import EXPORT_YEAR, export_idf
from hvacflex.paths import buildings_dir
from hvacflex.validation.energyplus import J_PER_KWH, rc_thermostat_run, run_energyplus

HOURS_PER_PERIOD = 0.5
"""Length of one control period [h]."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--days", type=int, default=365)
    parser.add_argument("--out", type=Path, default=None, help="keep EnergyPlus's files here")
    args = parser.parse_args()
    first = date(EXPORT_YEAR, 1, 1)
    building = load_building(buildings_dir() / "office5.toml")
    area_m2 = building.floor_area_m2
    scale = 365.0 / args.days
    _, _, per_period = rc_thermostat_run(first, args.days)
    hvacflex_kwh = float(per_period["hvac_kw"].sum()) * HOURS_PER_PERIOD
    coil_kwh = float(per_period["coil_w"].sum()) * HOURS_PER_PERIOD / 1000.0
    weather = default_weather_file()
    with tempfile.TemporaryDirectory() as scratch:
        workdir = args.out if args.out is not None else Path(scratch)
        run = run_energyplus(
            export_idf(building, hvac="vav", epw_path=weather),
            epw_path=weather, start=first, days=args.days, workdir=workdir,
        )  # fmt: skip
    hourly = run.hourly
    energyplus_kwh = (
        float((hourly["Electricity:HVAC [J]"] + hourly["Electricity:Plant [J]"]).sum()) / J_PER_KWH
    )
    coil_columns = [c for c in hourly.columns if "Cooling Coil Total Cooling Rate" in c]
    energyplus_coil_kwh = float(hourly[coil_columns].sum().sum()) / 1000.0
    print(f"office5, {args.days} days from {first} (scaled to a year), floor {area_m2:,.0f} m²")
    print("| model | HVAC electricity [MWh/yr] | intensity [kWh/m²·yr] | coil heat [MWh/yr] |")
    print("|---|---:|---:|---:|")
    for name, kwh, coil in (
        ("hvacflex (RC plant)", hvacflex_kwh, coil_kwh),
        ("EnergyPlus 25.2 (vav export)", energyplus_kwh, energyplus_coil_kwh),
    ):
        print(
            f"| {name} | {kwh * scale / 1000:,.1f} | {kwh * scale / area_m2:,.1f} "
            f"| {coil * scale / 1000:,.1f} |"
        )


if __name__ == "__main__":
    main()
