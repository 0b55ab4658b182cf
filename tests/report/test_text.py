"""The report's sentences follow the numbers: fabricated KPIs flip every claim."""

from __future__ import annotations

import pandas as pd
import pytest

from hvacflex.report import text
from hvacflex.reproduce_report import (
    Plan,
    comfort_sentences,
    ppp_sentence,
    revenue_sentences,
    scenario_sentences,
)


def _kpis(net_cost: float, peak: float, revenue: float = 0.0) -> dict[str, float]:
    return {
        "net_cost_sgd": net_cost,
        "energy_cost_sgd": net_cost + revenue,
        "reserve_revenue_sgd": revenue,
        "peak_power_kw": peak,
    }


def test_cost_sentence_takes_its_sign_and_size_from_the_data() -> None:
    more = text.robustness_cost(nominal_cost_sgd=100.0, robust_cost_sgd=103.0)
    assert "3.0 % more than (a) NMPC" in more and "as in the paper" in more
    less = text.robustness_cost(nominal_cost_sgd=100.0, robust_cost_sgd=95.0)
    assert "5.0 % less than (a) NMPC" in less and "unlike the paper" in less
    same = text.cost_comparison("x", 100.0, "y", 100.0)
    assert "the same as" in same


def test_peak_sentence_says_lowers_only_when_the_peak_is_lower() -> None:
    assert "lowers the peak" in text.peak_comparison("(c)", 30.0, "(b)", 40.0)
    assert "25.0 %" in text.peak_comparison("(c)", 30.0, "(b)", 40.0)
    assert "raises the peak" in text.peak_comparison("(c)", 44.0, "(b)", 40.0)
    assert "does not lower" in text.peak_comparison("(c)", 40.0, "(b)", 40.0)


def test_scenario_sentences_flip_with_the_results() -> None:
    paper_like = " ".join(
        scenario_sentences({"a": _kpis(100, 40), "b": _kpis(110, 41), "c": _kpis(115, 35)})
    )
    assert "(b) RMPC costs 10.0 % more than (a) NMPC" in paper_like
    assert "(c) RMPC + PPP lowers the peak" in paper_like
    contrary = " ".join(
        scenario_sentences({"a": _kpis(100, 40), "b": _kpis(90, 41), "c": _kpis(95, 45)})
    )
    assert "(b) RMPC costs 10.0 % less than (a) NMPC" in contrary
    assert "(c) RMPC + PPP raises the peak" in contrary
    assert "lowers the peak" not in contrary


def test_zero_reserve_revenue_is_stated_with_its_reason() -> None:
    sentences = scenario_sentences(
        {"a": _kpis(100, 40, revenue=1.2), "b": _kpis(110, 41), "c": _kpis(111, 38)}
    )
    assert any("(a) NMPC earns 1.20 SGD of reserve revenue, 1.19 %" in s for s in sentences)
    (zero,) = [s for s in sentences if "no reserve revenue" in s]
    assert zero.startswith("(b) RMPC and (c) RMPC + PPP earn no reserve revenue: none of them")
    # the product presets plan for IL events of up to D periods, not for the whole horizon
    assert "called for up to 4 periods at any time in the horizon" in zero
    assert "whole horizon" not in zero
    assert "every forecast error" in zero  # (b) and (c) are robust
    paid = scenario_sentences({"b": _kpis(110, 41, revenue=0.5)})
    assert not any("no reserve revenue" in s for s in paid)
    nominal = text.no_reserve(["(a) NMPC"], offered=True, robust=False)
    assert nominal.startswith("(a) NMPC earns no reserve revenue: it offered")
    assert "forecast error" not in nominal
    assert "curtailed for the whole horizon" in nominal  # the paper's model (event_steps None)
    event = text.no_reserve(["(a) NMPC"], offered=True, robust=False, event_steps=3)
    assert "called for up to 3 periods" in event and "whole horizon" not in event
    disabled = text.no_reserve(["x"], offered=False, robust=False)
    assert "its configuration offers no reserve" in disabled and "horizon" not in disabled


@pytest.mark.parametrize(
    ("nominal", "robust", "expected"),
    [
        (3.8, 0.0, "the nominal MPC runs over the band and the robust one does not"),
        (0.0, 0.0, "both the nominal and the robust MPC keep the band"),
        (3.8, 2.0, "both the nominal and the robust MPC run over the band"),
        (0.0, 2.0, "contrary to the paper's finding"),
    ],
)
def test_comfort_sentence_follows_the_discomfort(
    nominal: float, robust: float, expected: str
) -> None:
    joined = " ".join(comfort_sentences({}, {"nmpc": nominal, "rmpc": robust}, Plan.quick()))
    assert expected in joined
    if expected.startswith("the nominal"):
        assert "the paper's finding" in joined
    else:
        assert "— the paper's finding" not in joined


def test_default_box_comfort_explanation_only_when_nominal_keeps_the_band() -> None:
    kept = " ".join(comfort_sentences({"a": 0.0, "b": 0.0}, {}, Plan.quick()))
    assert "(a) NMPC keeps the comfort band" in kept and "hidden margin" in kept
    over = " ".join(comfort_sentences({"a": 1.5, "b": 0.0}, {}, Plan.quick()))
    assert "(a) NMPC runs over the comfort band by 1.50 K·h" in over
    assert "hidden margin" not in over


def test_ppp_sentence_follows_the_sweep() -> None:
    lower = pd.DataFrame(
        {
            "peak_price_sgd_per_kw": [30.0, 0.5],
            "peak_power_kw": [30.0, 40.0],
            "total_cost_sgd": [110.0, 100.0],
        }
    )
    sentence = ppp_sentence(lower)
    assert "from 0.5 to 30 SGD/kW lowers the peak by 25.0 %" in sentence
    assert "× 1.100" in sentence
    flat = lower.assign(peak_power_kw=[40.0, 40.0])
    assert "does not lower the peak" in ppp_sentence(flat)


def test_revenue_trend_is_set_against_the_papers_rise() -> None:
    rise = text.revenue_trend("the event model", 10.0, 11.0, 12.5)
    assert "rises by 10.0 % in (b) and rises by 25.0 % in (c)" in rise
    assert rise.endswith("— as in the paper.")
    assert "((a) 10.00, (b) 11.00, (c) 12.50 SGD over the run)" in rise
    fall = text.revenue_trend("m", 10.0, 9.0, 10.0)
    assert "falls by 10.0 % in (b) and stays the same in (c)" in fall
    assert "unlike the paper, where it rises in both ((b) +1.7 %, (c) +12 %)" in fall
    from_zero = text.revenue_trend("m", 0.0, 2.0, 0.0)
    assert "rises from nothing in (b) and stays at zero in (c)" in from_zero
    assert "unlike the paper" in from_zero
    none = text.revenue_trend("m", 0.0, 0.0, 0.0)
    assert none.startswith("Under m no scenario earns reserve revenue")


def test_revenue_sentences_name_each_complete_model() -> None:
    sentences = revenue_sentences(
        {
            "event": {"a": 10.0, "b": 12.0, "c": 13.0},
            "whole-horizon": {"a": 0.0, "b": 0.0, "c": 0.0},
            "partial": {"a": 1.0, "b": 2.0},
        }
    )
    assert len(sentences) == 2
    assert sentences[0].startswith("Under the event model (D = 4")
    assert "as in the paper" in sentences[0]
    assert sentences[1].startswith("Under the paper's whole-horizon model no scenario earns")
