"""BESTEST runs: ideal loads exact on the bound, two weeks plausible, the full year (≈ 12 s)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.io import load_building
from hvacflex.building.rc import build_network
from hvacflex.report.validation_plots import write_bestest_outputs
from hvacflex.validation import bestest as bt
from hvacflex.validation.ideal_loads import simulate_zone_loads

N_IN_RANGE_ACHIEVED = 14
"""How many of the 14 quantities the full-year run puts inside the reference band."""


@pytest.fixture(scope="module")
def bestest_dir(shared_data_dir: Path) -> Path:
    return shared_data_dir / "bestest"


def test_ideal_loads_hold_the_band_and_free_float_matches_zoh(
    shipped_buildings_dir: Path,
) -> None:
    b = load_building(shipped_buildings_dir / "bestest600.toml")
    net = build_network(b)
    rng = np.random.default_rng(7)
    steps = 300
    d = np.zeros((steps, len(net.channels)))
    d[:, 0] = rng.uniform(-15.0, 35.0, steps)
    d[:, 1:6] = rng.uniform(0.0, 600.0, (steps, 5))
    d[:, 6] = 200.0
    ideal = simulate_zone_loads(
        net, d, 600.0, heating_setpoint_degc=20.0, cooling_setpoint_degc=27.0
    )
    t = ideal.zone_temp_degc[1:, 0]
    assert np.all(t >= 20.0 - 1e-9)
    assert np.all(t <= 27.0 + 1e-9)
    heating, cooling = ideal.heating_w[:, 0], ideal.cooling_w[:, 0]
    assert np.all(heating * cooling == 0.0)
    # where HVAC acts, the zone ends exactly on the violated bound
    np.testing.assert_allclose(t[heating > 0], 20.0, atol=1e-9)
    np.testing.assert_allclose(t[cooling > 0], 27.0, atol=1e-9)
    # free float from the same state: one step equals the matrix exponential by hand
    import scipy.linalg

    x0 = ideal.final_state_degc
    ff = simulate_zone_loads(net, d[:1], 600.0, initial_state_degc=x0)
    n, nd = net.n_nodes, len(net.channels)
    aug = np.zeros((n + nd, n + nd))
    aug[:n, :n], aug[:n, n:] = net.a_cont, net.e_cont
    phi = scipy.linalg.expm(aug * 600.0)
    expected = phi[:n, :n] @ x0 + phi[:n, n:] @ d[0]
    np.testing.assert_allclose(ff.final_state_degc, expected, atol=1e-9)


def test_two_weeks_of_case_600_are_plausible(
    shipped_buildings_dir: Path, bestest_dir: Path
) -> None:
    b = load_building(shipped_buildings_dir / "bestest600.toml")
    d = bt.bestest_disturbances(build_network(b), bestest_dir / bt.EPW_NAME)
    assert d.shape == (17520, len(build_network(b).channels))
    january = d.iloc[: 14 * 48]
    loads = bt.run_case("600", b, january).hourly
    assert len(loads) == 14 * 24
    # cold Denver January: heating every night, at most a few kW, zone within the band
    assert 0.3 < loads["heating_w"].sum() / 1e6 < 1.2  # MWh in two weeks
    assert 1.5e3 < loads["heating_w"].max() < 4.0e3
    assert loads["cooling_w"].max() < 7.0e3
    assert loads["zone_temp_degc"].between(19.9, 27.1).all()
    ff = bt.run_case("600FF", b, january).hourly["zone_temp_degc"]
    assert -25.0 < ff.min() < 10.0
    assert 15.0 < ff.max() < 60.0
    assert (ff > loads["outdoor_temp_degc"] - 1.0).mean() > 0.95  # gains keep it warmer


def test_reference_table_has_the_fourteen_quantities(bestest_dir: Path) -> None:
    ref = bt.load_reference(bestest_dir / bt.REFERENCE_CSV_NAME)
    assert len(ref) == 14
    assert ref.loc["600 annual heating", "ref_min"] == pytest.approx(3.99275)
    assert ref.loc["900FF max temperature", "ref_max"] == pytest.approx(46.0)
    assert (ref["ref_min"] <= ref["ref_max"]).all()


def test_full_year_bestest(shipped_buildings_dir: Path, bestest_dir: Path, tmp_path: Path) -> None:
    result = bt.run_bestest(bestest_dir, shipped_buildings_dir)
    assert result.n_in_range >= N_IN_RANGE_ACHIEVED, bt.table_markdown(result.table)
    paths = write_bestest_outputs(result, tmp_path)
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)


def test_stage_count_is_the_number_of_progress_messages(
    shipped_buildings_dir: Path, bestest_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The progress bar's total (`validate bestest`) equals the stages run_bestest announces."""

    class NoCase:
        def quantities(self) -> dict[str, float]:
            return {}

    monkeypatch.setattr(bt, "bestest_disturbances", lambda *args: None)
    monkeypatch.setattr(bt, "run_case", lambda *args, **kwargs: NoCase())
    monkeypatch.setattr(bt, "comparison_table", lambda values, reference: reference)
    messages: list[str] = []
    bt.run_bestest(bestest_dir, shipped_buildings_dir, progress=messages.append)
    assert len(messages) == bt.stage_count() == 6
    assert messages[0].startswith("weather and solar") and messages[-1] == "case 900FF"
