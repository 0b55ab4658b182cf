"""Who delivered what of a fleet's activated offers, per building and period (issue 62).

python scripts/fleet_delivery_table.py --run runs/f200 [--short 20]

``--run`` is a `hvacflex fleet simulate` folder (or a `bench_fleet_scale.py --out` one). For
every building share an activation dispatched (``offers.csv``) it reads the building's RC
plant (``buildings.parquet``): the baseline B (pre-event: the metered power of the period
before), the power the plant drew curtailed (the meter) and the power it would have drawn
served (the plant's counterfactual ``power_served_kw``). Delivered = min(share, B − metered)
= min(share, (B − served) + (served − metered)): the load's change into the period and the
shed the curtailment took off the meter. Prints, per activated period, the shares, the
deliveries, the shortfall, the plant's shed and the load's change (Σ over buildings [kW]);
then the building-periods that fell short, worst first.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.constants import TIMEZONE


def delivery_table(run: Path) -> pd.DataFrame:
    """One row per dispatched building share: ``time``, ``building``, ``dispatched_kw``,
    ``delivered_kw``, ``short_kw``, ``baseline_kw``, ``metered_kw``, ``served_kw``,
    ``plant_shed_kw`` (served − metered), ``load_change_kw`` (B − served: < 0 where the
    load rose into the period)."""
    offers = pd.read_csv(run / "offers.csv")
    offers["time"] = pd.to_datetime(offers["time"], utc=True).dt.tz_convert(TIMEZONE)
    buildings = pd.read_parquet(run / "buildings.parquet").reset_index()
    when = buildings.columns[0]
    buildings[when] = pd.to_datetime(buildings[when], utc=True).dt.tz_convert(TIMEZONE)
    buildings = buildings.sort_values(["building", when])
    buildings["baseline_kw"] = buildings.groupby("building")["power_kw"].shift(1)
    plant = buildings.rename(
        columns={when: "time", "power_kw": "metered_kw", "power_served_kw": "served_kw"}
    )[["time", "building", "baseline_kw", "metered_kw", "served_kw"]]
    rows = offers[offers["dispatched_kw"] > 0].merge(plant, on=["time", "building"])
    rows["short_kw"] = rows["dispatched_kw"] - rows["delivered_kw"]
    rows["plant_shed_kw"] = rows["served_kw"] - rows["metered_kw"]
    rows["load_change_kw"] = rows["baseline_kw"] - rows["served_kw"]
    columns = ["time", "building", "dispatched_kw", "delivered_kw", "short_kw", "baseline_kw"]
    return rows[[*columns, "metered_kw", "served_kw", "plant_shed_kw", "load_change_kw"]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, required=True)
    parser.add_argument("--short", type=int, default=20, help="building-periods listed")
    args = parser.parse_args()
    table = delivery_table(args.run)
    if table.empty:
        print("no activation was dispatched")
        return
    pd.set_option("display.width", 200)
    sums = ["dispatched_kw", "delivered_kw", "short_kw", "plant_shed_kw", "load_change_kw"]
    per_period = table.groupby("time")[sums].sum()
    per_period["buildings_short"] = table.groupby("time")["short_kw"].apply(
        lambda s: int((s > 1e-6).sum())
    )
    print(per_period.round(2).to_string())
    short = table[table["short_kw"] > 1e-6]
    ratio = table["delivered_kw"].sum() / table["dispatched_kw"].sum()
    rose = int((short["load_change_kw"] < 0).sum())
    print(
        f"delivery ratio {ratio:.4f}; {len(short)} of {len(table)} building shares short "
        f"by {short['short_kw'].sum():.2f} kW in all, the load rising into the period in "
        f"{rose} of them; the plant's shed / the shares {np.sum(table['plant_shed_kw']):.2f} "
        f"/ {table['dispatched_kw'].sum():.2f} kW"
    )
    worst = short.sort_values("short_kw", ascending=False).head(args.short)
    print(worst.round({name: 3 for name in worst.columns[2:]}).to_string(index=False))


if __name__ == "__main__":
    main()
