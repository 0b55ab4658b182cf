"""The comfort knee in the closed loop (issue 60): the warm solver carries its columns and
rows from step to step, and a day whose plans leave the band under a priced peak plans
smaller excursions with it than with the linear penalty alone."""

from __future__ import annotations

import json
from pathlib import Path

import hvacflex

CHEAP_COMFORT = {"comfort_penalty_sgd_per_kelvin_hour": 5.0, "peak_price_sgd_per_kw": 10.0}


def test_a_knee_caps_the_planned_excursions_of_a_day(tmp_path: Path) -> None:
    linear = hvacflex.simulate(
        "rmpc-ppp", start="2014-03-03", days=1, out=tmp_path / "linear", quiet=True,
        controller=CHEAP_COMFORT,
    )  # fmt: skip
    kneed = hvacflex.simulate(
        "rmpc-ppp", start="2014-03-03", days=1, out=tmp_path / "knee", quiet=True,
        controller={**CHEAP_COMFORT, "comfort_knee_k": 0.3,
                    "comfort_penalty_beyond_knee_sgd_per_kelvin_hour": 200.0},
    )  # fmt: skip
    assert linear.summary["fallback_count"] == kneed.summary["fallback_count"] == 0
    slack_linear = linear.frame["planned_slack_max_k"].max()
    slack_kneed = kneed.frame["planned_slack_max_k"].max()
    assert slack_linear > 0.5  # cheap comfort: the linear plans leave the band by > 0.5 K …
    assert slack_kneed < 0.4  # … the knee's stay near its 0.3 K
    config = json.loads((kneed.out_dir / "config.json").read_text())
    assert config["controller"]["comfort_knee_k"] == 0.3  # what the run says it ran
