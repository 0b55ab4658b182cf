"""How the peak-power price φ shapes one day of the robust MPC (preset rmpc-ppp).

Each φ is the same scenario with one override, ``controller={"peak_price_sgd_per_kw": φ}``,
validated like a scenario file. A higher φ buys a lower peak with more energy cost; the PPP
charge of the month is φ × the month's peak (here this day's) [SGD] (``ppp_charge_monthly_sgd``;
``ppp_charge_sgd`` is the same prorated to the one day the run covers).

Run from any folder: ``python peak_price.py``.
"""

from __future__ import annotations

import hvacflex

START = "2014-03-03"
"""A Monday in the price data (Singapore time)."""

PEAK_PRICES_SGD_PER_KW = (0.0, 1.5, 4.0)
"""φ values to compare [SGD/kW]; 1.5 is the preset's."""


def main() -> None:
    print(f"{'phi [SGD/kW]':>12} {'peak [kW]':>10} {'energy [SGD]':>13} {'PPP month [SGD]':>16}")
    for phi in PEAK_PRICES_SGD_PER_KW:
        run = hvacflex.simulate(
            "rmpc-ppp",
            f"results/examples/phi_{phi:g}",
            quiet=True,
            start=START,
            days=1,
            controller={"peak_price_sgd_per_kw": phi},
        )
        s = run.summary
        print(
            f"{phi:>12.1f} {s['peak_power_kw']:>10.1f} {s['energy_cost_sgd']:>13.2f} "
            f"{s['ppp_charge_monthly_sgd']:>16.2f}"
        )


if __name__ == "__main__":
    main()
