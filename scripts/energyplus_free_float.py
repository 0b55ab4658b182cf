"""Free-floating zone air: hvacflex's RC plant against EnergyPlus on the exported building.

Runs :func:`hvacflex.validation.energyplus.free_float_comparison` (export with ``hvac="none"``,
same EPW and gain schedules, ``--spinup`` days discarded) for each ``--start``, writes
``OUT/temperatures.csv`` (``case, start, zone, rmse_k, bias_k, max_abs_k`` and both means, on
hourly means) and ``OUT/temperatures_hourly.csv``, and prints the table as markdown
(the one in docs/validation.md). Needs ``pip install "hvacflex[energyplus]"``.

    python scripts/energyplus_free_float.py --building office5 \\
        --start 2014-03-03 --start 2014-05-05 --days 7 --out ep_validation
"""

from __future__ import annotations

import argparse
import time
from datetime import date
from pathlib import Path

import pandas as pd

from hvacflex.building.io import load_building
from hvacflex.paths import resolve_building
from hvacflex.report.tables import to_markdown
from hvacflex.validation.energyplus import free_float_comparison


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--building", default="office5")
    parser.add_argument("--start", action="append", default=None, help="ISO date (repeatable)")
    parser.add_argument("--days", type=int, default=7)
    parser.add_argument("--spinup", type=int, default=7)
    parser.add_argument("--out", type=Path, default=Path("ep_validation"))
    args = parser.parse_args()
    building = load_building(resolve_building(args.building))
    tables, series = [], []
    for start_text in args.start or ["2014-03-03"]:
        start = date.fromisoformat(start_text)
        began = time.perf_counter()
        result = free_float_comparison(
            building,
            start=start,
            days=args.days,
            spinup_days=args.spinup,
            workdir=args.out / f"energyplus_{start_text}",
        )
        seconds = time.perf_counter() - began
        print(f"{start_text}: {seconds:.1f} s, EnergyPlus severe errors {result.severe_count}")
        tables.append(result.table.assign(case="free-float", start=start_text))
        series.append(result.hourly.assign(case="free-float", start=start_text))
    table = pd.concat(tables, ignore_index=True)
    first = ["case", "start", "zone"]
    table = table[first + [c for c in table.columns if c not in first]]
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "temperatures.csv", index=False, float_format="%.3f")
    pd.concat(series, ignore_index=True).to_csv(
        args.out / "temperatures_hourly.csv", index=False, float_format="%.3f"
    )
    print(to_markdown(table.set_index("case").round(2)))


if __name__ == "__main__":
    main()
