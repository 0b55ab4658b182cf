"""The identified-model file (``model.toml``) that ``hvacflex identify fit`` writes.

TOML, one table per zone with its fitted parameters (:data:`hvacflex.identify.greybox.
ZONE_PARAMETERS`, units in the names), one per coupling and the power model; read back
and validated by :func:`load_identified_model` (pydantic, unknown keys refused). Zone names
are lower-case identifiers made from the data's names (:func:`identifier`); each zone keeps
its data/IDF name in ``energyplus_zone`` (matched case-insensitively by the EnergyPlus plant).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from hvacflex.errors import ConfigError
from hvacflex.identify.greybox import ZONE_PARAMETERS, GreyBoxParameters
from hvacflex.tomlio import read_toml

MODEL_KIND = "identified-rc"
"""The ``kind`` key of an identified-model file."""


def identifier(name: str) -> str:
    """A zone name as a lower-case identifier: ``"SPACE1-1"`` → ``"space1_1"``."""
    text = re.sub(r"[^a-z0-9_]+", "_", name.lower()).strip("_")
    return text if text[:1].isalpha() else f"zone_{text}"


@dataclass(frozen=True)
class PowerModel:
    """HVAC electricity [kW] ≈ ``base_kw + kw_per_kw_cooling · ΣQ + kw_per_k_outdoor · To``
    (period means; Q delivered sensible cooling [kW], To outdoor temperature [°C])."""

    base_kw: float
    kw_per_kw_cooling: float
    kw_per_k_outdoor: float


@dataclass(frozen=True)
class IdentifiedModel:
    """A fitted model as the file holds it.

    Attributes
    ----------
    name : a title; zones : (m,) lower-case identifiers; energyplus_zones : (m,) the data's
    names; parameters : the grey-box parameters; power : the power model or None (no meter in
    the data); provenance : where it came from (data file, train and test days); boundaries :
    (nb,) the data's unconditioned zones whose measured temperatures are inputs.
    """

    name: str
    zones: tuple[str, ...]
    energyplus_zones: tuple[str, ...]
    parameters: GreyBoxParameters
    power: PowerModel | None
    provenance: dict[str, str]
    boundaries: tuple[str, ...] = ()


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class _ZoneSpec(_Spec):
    name: Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$")]
    energyplus_zone: Annotated[str, Field(min_length=1)]
    c_air_kj_per_k: Annotated[float, Field(gt=0)]
    c_mass_kj_per_k: Annotated[float, Field(gt=0)]
    ua_out_kw_per_k: Annotated[float, Field(ge=0)]
    ua_air_mass_kw_per_k: Annotated[float, Field(gt=0)]
    ua_mass_out_kw_per_k: Annotated[float, Field(ge=0)]
    solar_air_m2: Annotated[float, Field(ge=0)]
    solar_mass_m2: Annotated[float, Field(ge=0)]
    occupied_gain_kw: Annotated[float, Field(ge=0)]
    base_gain_kw: float


class _CouplingSpec(_Spec):
    zones: Annotated[list[str], Field(min_length=2, max_length=2)]
    ua_kw_per_k: Annotated[float, Field(ge=0)]


class _BoundarySpec(_Spec):
    zone: str
    boundary: Annotated[str, Field(min_length=1)]
    ua_kw_per_k: Annotated[float, Field(ge=0)]


class _PowerSpec(_Spec):
    base_kw: float
    kw_per_kw_cooling: float
    kw_per_k_outdoor: float


class _FileSpec(_Spec):
    kind: str = Field(pattern=f"^{MODEL_KIND}$")
    name: str
    provenance: dict[str, str] = {}
    zones: Annotated[list[_ZoneSpec], Field(min_length=1)]
    couplings: list[_CouplingSpec] = []
    boundaries: list[str] = []
    boundary_couplings: list[_BoundarySpec] = []
    power_model: _PowerSpec | None = None


def _toml_value(value: object) -> str:
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(float(value))  # type: ignore[arg-type]


def _table(lines: list[str], header: str, items: dict[str, object]) -> None:
    lines += ["", header] + [f"{key} = {_toml_value(value)}" for key, value in items.items()]


def write_identified_model(model: IdentifiedModel, path: str | Path) -> Path:
    """Write ``model`` as TOML (module docstring); returns the path."""
    path = Path(path)
    lines = [f"kind = {_toml_value(MODEL_KIND)}", f"name = {_toml_value(model.name)}"]
    lines.append(f"boundaries = {_toml_value(list(model.boundaries))}")
    _table(lines, "[provenance]", dict(model.provenance))
    names = [n for n, _ in ZONE_PARAMETERS]
    for i, zone in enumerate(model.zones):
        values = dict(zip(names, model.parameters.zone[i].tolist(), strict=True))
        items: dict[str, object] = {"name": zone, "energyplus_zone": model.energyplus_zones[i]}
        _table(lines, "[[zones]]", {**items, **values})
    for (i, j), ua in zip(
        model.parameters.couplings, model.parameters.coupling_ua_kw_per_k, strict=True
    ):
        _table(
            lines,
            "[[couplings]]",
            {"zones": [model.zones[i], model.zones[j]], "ua_kw_per_k": float(ua)},
        )
    for (i, b), ua in zip(
        model.parameters.boundary_couplings, model.parameters.boundary_ua_kw_per_k, strict=True
    ):
        _table(
            lines,
            "[[boundary_couplings]]",
            {"zone": model.zones[i], "boundary": model.boundaries[b], "ua_kw_per_k": float(ua)},
        )
    if model.power is not None:
        _table(lines, "[power_model]", dict(vars(model.power)))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def load_identified_model(path: str | Path) -> IdentifiedModel:
    """Read and validate an identified-model file.

    Raises
    ------
    ConfigError
        naming the file, the field and the value for anything invalid.
    """
    data = read_toml(path, what="identified model")
    try:
        spec = _FileSpec.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        raise ConfigError(
            first["msg"],
            source=path,
            field=".".join(str(p) for p in first["loc"]),
            value=first.get("input"),
            hint="write the file with hvacflex identify fit",
        ) from None
    zones = tuple(z.name for z in spec.zones)
    pairs = []
    for c in spec.couplings:
        for zone in c.zones:
            if zone not in zones:
                raise ConfigError(
                    "unknown zone",
                    source=path,
                    field="couplings.zones",
                    value=zone,
                    hint=f"zones are {list(zones)}",
                )
        pairs.append((zones.index(c.zones[0]), zones.index(c.zones[1])))
    edges = []
    for e in spec.boundary_couplings:
        if e.zone not in zones or e.boundary not in spec.boundaries:
            raise ConfigError(
                "unknown zone or boundary",
                source=path,
                field="boundary_couplings",
                value=f"{e.zone}-{e.boundary}",
                hint=f"zones are {list(zones)}, boundaries {spec.boundaries}",
            )
        edges.append((zones.index(e.zone), spec.boundaries.index(e.boundary)))
    names = [n for n, _ in ZONE_PARAMETERS]
    parameters = GreyBoxParameters(
        zone=np.array([[getattr(z, n) for n in names] for z in spec.zones], dtype=np.float64),
        couplings=np.array(pairs, dtype=np.int64).reshape(-1, 2),
        coupling_ua_kw_per_k=np.array([c.ua_kw_per_k for c in spec.couplings], dtype=np.float64),
        boundaries=len(spec.boundaries),
        boundary_couplings=np.array(edges, dtype=np.int64).reshape(-1, 2),
        boundary_ua_kw_per_k=np.array(
            [e.ua_kw_per_k for e in spec.boundary_couplings], dtype=np.float64
        ),
    )
    power = None if spec.power_model is None else PowerModel(**spec.power_model.model_dump())
    return IdentifiedModel(
        name=spec.name,
        zones=zones,
        energyplus_zones=tuple(z.energyplus_zone for z in spec.zones),
        parameters=parameters,
        power=power,
        provenance=dict(spec.provenance),
        boundaries=tuple(spec.boundaries),
    )
