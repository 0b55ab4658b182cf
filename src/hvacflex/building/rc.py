"""RC network of a building: nodes, capacitances, conductances → continuous-time matrices.

Paper eq. (1) without the VAV term. Nodes are the zone air nodes (first, in zone order) and
the capacitance nodes of every wall (each wall's slices, outside → inside). With ``x`` the node
temperatures [°C] and ``d`` the disturbance vector (order in ``channels.py``)::

    C dx/dt = K x + F d          a_cont = C⁻¹ K  [1/s],   e_cont = C⁻¹ F

``K`` [W/K] is symmetric: off-diagonal entries are the conductances between nodes, the
diagonal is minus the sum of a node's conductances including those to the outdoor air and
the ground (which appear again as the columns of ``F`` for the outdoor- and ground-temperature
channels). Hence ``a_cont`` is Metzler (off-diagonal ≥ 0) and its ZOH discretisation is ≥ 0.

Heat paths:

* wall slices form a chain: far side —[R_far + r₁/2]— node₁ —[(r₁+r₂)/2]— … —[r_k/2 + R_si]—
  zone. The far side is the outdoor air (film 1/h_se), the ground (no film), another zone's
  node (film) or nothing (adiabatic plane of symmetry, e.g. an intermediate floor slab).
  The steady-state U-value is therefore exactly 1/(R_si + Σr + R_se). A massless layer
  (zero density or specific heat) has no node; its resistance joins the link it sits in
  (``Construction.chain``).
* solar absorbed by an exterior opaque surface, α·A·q, lands on the (massless) outer surface
  between the outdoor film and the outermost node; the share R_se/(R_se + r₁/2) flows to the
  node, the rest straight back to the outdoor air (exact elimination of the surface node).
* windows are pure conductances U·A zone–outdoor air; their solar gain SHGC·A·q and the
  zone's internal sensible gain go to the zone air node (as in the paper). A window with
  ``shgc_normal`` has an angle-dependent gain on its own ``window_solar_gain`` channel.

Optional physics for the BESTEST validation (every one off by default, so buildings that do
not ask for it get exactly the network above):

* infiltration: a conductance ρ c_p V·ACH/3600 zone air–outdoor air (``Zone.infiltration_ach``).
* heat released on a massless inside surface (radiative internal gains, transmitted solar)
  splits like the absorbed solar outside: the share R_film/(R_film + r_n/2) reaches the
  innermost node, the rest the zone air (exact elimination of the surface node).
  In a zone with explicit long-wave exchange (``Zone.interior_radiation_w_per_m2k``) every
  face that zone sees — its own walls' inside faces and the far faces of partitions that
  belong to the neighbouring zone — has such a surface node, joined to the zone air by its
  film and to the zone's radiant star by h_r·A.
  Radiative internal gains (``Zone.internal_gain_radiative_fraction``) are spread over all
  opaque surfaces facing the zone (both faces of a partition count for their zones) by area;
  transmitted solar goes to the walls with an ``interior_solar_fraction``, a share
  ``Zone.solar_lost_fraction`` leaves through the windows, the rest goes to the air node.
* sky long-wave exchange: an exterior surface of emissivity ε and tilt β loses
  ε (1 + cos β)/2 · L at its outer surface, L the ``sky_longwave`` channel; it splits like
  absorbed solar (walls) or by U/h_out (windows: the share that reaches the zone air).
* an exterior wall with solar absorptance 0 (the underside of a raised floor) gets no solar
  channel of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.channels import (
    DisturbanceChannel,
    constant_channel,
    ground_temp_channel,
    internal_gain_channel,
    outdoor_temp_channel,
    sky_longwave_channel,
    solar_channel,
    window_solar_gain_channel,
)
from hvacflex.building.identified import GAIN_CHANNEL_PEAK_W, WALL_ORIENTATIONS, IdentifiedRC
from hvacflex.building.model import ADIABATIC, GROUND, OUTSIDE, Building, Wall, Window, Zone

FloatArray = NDArray[np.float64]


def frozen_array(array: ArrayLike) -> FloatArray:
    """A read-only float64 copy of ``array``."""
    out = np.array(array, dtype=np.float64)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class ThermalNetwork:
    """Continuous-time RC network of a building (VAV term excluded).

    Attributes
    ----------
    node_names : (n,) zone names first (zone order), then wall nodes ``<wall>`` or
        ``<wall>_<k>`` (k = 0 outermost) when a wall has several nodes.
    zone_node_index : (m,) index of each zone's air node in the state vector.
    channels : (nd,) disturbance channels in the order of ``channels.py``.
    capacitance_j_per_k : (n,) node capacitances [J/K].
    conductance_w_per_k : (n,n) symmetric matrix K [W/K] (see module docstring).
    input_w : (n,nd) F: heat into each node per unit of each channel [W per channel unit].
    outdoor_conductance_w_per_k, ground_conductance_w_per_k : (n,) each node's conductance to
        the outdoor air / the ground [W/K].
    solar_direct_loss_m2 : (nd,) for each solar channel, the absorbed solar that flows
        straight back to the outdoor air (never reaching a node) per W/m² of irradiance [m²];
        for the sky long-wave channel, minus the part of the sky loss that the outdoor air
        supplies directly [m²].
    a_cont : (n,n) C⁻¹K [1/s].
    e_cont : (n,nd) C⁻¹F [1/s per channel unit, e.g. K/s per °C or per W].
    """

    node_names: tuple[str, ...]
    zone_node_index: NDArray[np.intp]
    channels: tuple[DisturbanceChannel, ...]
    capacitance_j_per_k: FloatArray
    conductance_w_per_k: FloatArray
    input_w: FloatArray
    outdoor_conductance_w_per_k: FloatArray
    ground_conductance_w_per_k: FloatArray
    solar_direct_loss_m2: FloatArray
    a_cont: FloatArray
    e_cont: FloatArray

    @property
    def n_nodes(self) -> int:
        return len(self.node_names)

    @property
    def channel_names(self) -> tuple[str, ...]:
        return tuple(channel.name for channel in self.channels)

    def steady_state_degc(self, d: ArrayLike, zone_heat_w: ArrayLike | None = None) -> FloatArray:
        """Node temperatures at steady state for constant inputs.

        Parameters
        ----------
        d : (nd,) disturbances in channel units.
        zone_heat_w : (m,) extra heat into each zone air node [W] (negative = cooling), e.g.
            the VAV supply air; default none.

        Returns
        -------
        (n,) temperatures [°C] solving K x + F d + P q = 0.
        """
        rhs = self.input_w @ np.asarray(d, dtype=np.float64)
        if zone_heat_w is not None:
            rhs[self.zone_node_index] += np.asarray(zone_heat_w, dtype=np.float64)
        return np.asarray(np.linalg.solve(self.conductance_w_per_k, -rhs), dtype=np.float64)

    def zone_heat_extraction_w(self, d: ArrayLike, zone_temp_degc: ArrayLike) -> FloatArray:
        """Heat to remove from each zone to hold it at a fixed temperature, at steady state.

        Parameters
        ----------
        d : (nd,) constant disturbances.
        zone_temp_degc : (m,) or scalar zone temperatures held [°C].

        Returns
        -------
        (m,) sensible cooling load of each zone [W] (negative: heating needed).
        """
        zones = self.zone_node_index
        walls = np.setdiff1d(np.arange(self.n_nodes), zones)
        k = self.conductance_w_per_k
        forcing = self.input_w @ np.asarray(d, dtype=np.float64)
        t_zone = np.broadcast_to(np.asarray(zone_temp_degc, dtype=np.float64), zones.shape)
        t_wall = np.linalg.solve(
            k[np.ix_(walls, walls)], -(k[np.ix_(walls, zones)] @ t_zone + forcing[walls])
        )
        load: FloatArray = k[np.ix_(zones, walls)] @ t_wall + k[np.ix_(zones, zones)] @ t_zone
        return load + forcing[zones]


def solar_channels_of(b: Building) -> tuple[DisturbanceChannel, ...]:
    """One solar channel per distinct (azimuth, tilt) of exterior walls, then windows, in the
    order of first appearance in the file (walls before windows); exterior walls with solar
    absorptance 0 absorb nothing and add no channel."""
    seen: dict[tuple[float, float], DisturbanceChannel] = {}
    surfaces = [
        (w.azimuth_deg, w.tilt_deg) for w in b.walls if w.is_exterior and w.solar_absorptance > 0
    ]
    surfaces += [(w.azimuth_deg, w.tilt_deg) for w in b.windows if w.shgc_normal is None]
    for azimuth, tilt in surfaces:
        if (azimuth, tilt) not in seen:
            seen[(azimuth, tilt)] = solar_channel(azimuth, tilt)
    return tuple(seen.values())


def disturbance_channels(b: Building) -> tuple[DisturbanceChannel, ...]:
    """The building's disturbance vector: [T_out, solar per orientation, gains per zone,
    ground temperature if a wall touches the ground] (see ``channels.py``); an identified
    building's: :func:`identified_channels`."""
    if b.identified is not None:
        return identified_channels(b.zone_names)
    channels = [outdoor_temp_channel(), *solar_channels_of(b)]
    channels += [internal_gain_channel(name) for name in b.zone_names]
    if any(w.adjacent == GROUND for w in b.walls):
        channels.append(ground_temp_channel())
    if has_sky_exchange(b):
        channels.append(sky_longwave_channel())
    channels += [window_solar_gain_channel(w) for w in b.windows if w.shgc_normal is not None]
    return tuple(channels)


def identified_channels(zone_names: tuple[str, ...]) -> tuple[DisturbanceChannel, ...]:
    """An identified building's disturbance vector: [T_out, horizontal solar, solar on the
    walls of :data:`~hvacflex.building.identified.WALL_ORIENTATIONS`, gains per zone,
    constant]."""
    return (
        outdoor_temp_channel(),
        solar_channel(0.0, 0.0),
        *(solar_channel(azimuth, 90.0) for _, azimuth in WALL_ORIENTATIONS),
        *(internal_gain_channel(name) for name in zone_names),
        constant_channel(),
    )


def has_sky_exchange(b: Building) -> bool:
    """True if an exterior wall or a window sets a thermal emissivity (adds ``sky_longwave``)."""
    walls = any(w.is_exterior and w.thermal_emissivity is not None for w in b.walls)
    return walls or any(w.thermal_emissivity is not None for w in b.windows)


def _surface_share_to_node(film_w_per_m2k: float, link_r_m2k_per_w: float) -> float:
    """Share of heat released on a massless surface that flows into the node behind it (the
    rest flows through the film): R_film / (R_film + r), r the surface-to-node resistance."""
    r_film = 1.0 / film_w_per_m2k
    return r_film / (r_film + link_r_m2k_per_w)


def _zone_surfaces(
    b: Building,
    zone: Zone,
    index: dict[str, int],
    surface_node: dict[str, int],
    far_surface_node: dict[str, int],
) -> list[tuple[int, float, float]]:
    """Opaque surfaces facing a zone as (node index, area [m²], share to the node); a wall
    with an explicit (massless) surface node on that face takes all of it there."""
    surfaces = []
    for wall in b.walls:
        _, links = wall.construction.chain()
        nodes = [index[name] for name in _wall_node_names(wall)]
        if wall.zone == zone.name and wall.name in surface_node:
            surfaces.append((surface_node[wall.name], wall.area_m2, 1.0))
        elif wall.zone == zone.name:
            film = wall.construction.inside_film_w_per_m2k
            surfaces.append((nodes[-1], wall.area_m2, _surface_share_to_node(film, links[-1])))
        elif wall.adjacent == zone.name and wall.name in far_surface_node:
            surfaces.append((far_surface_node[wall.name], wall.area_m2, 1.0))
        elif wall.adjacent == zone.name:
            far = wall.construction.outside_film_for(wall.adjacent)
            assert far is not None  # a zone-to-zone face always has a film
            surfaces.append((nodes[0], wall.area_m2, _surface_share_to_node(far, links[0])))
    return surfaces


def _wall_node_names(wall: Wall) -> list[str]:
    count = len(wall.construction.chain()[0])
    return [wall.name] if count == 1 else [f"{wall.name}_{k}" for k in range(count)]


@dataclass
class _Assembly:
    """The network while it is being assembled: node indices and the growing K, F.

    Nodes ``0..n−1`` carry capacitance (zone air, then wall slices); the massless
    inside-surface and radiant-star nodes of zones with explicit interior long-wave exchange
    follow and are eliminated by :func:`_kron_reduce`.
    """

    channels: tuple[DisturbanceChannel, ...]
    channel_index: dict[tuple[str, float | None, float | None, str | None], int]
    names: list[str]
    capacitance: list[float]
    index: dict[str, int]
    radiant: dict[str, Zone]
    surface_node: dict[str, int]
    far_surface_node: dict[str, int]
    star_node: dict[str, int]
    k: FloatArray
    f: FloatArray
    outdoor: FloatArray
    ground: FloatArray
    direct_loss: FloatArray

    @property
    def outdoor_col(self) -> int:
        return self.channel_index[("outdoor_temp", None, None, None)]

    @property
    def ground_col(self) -> int | None:
        return self.channel_index.get(("ground_temp", None, None, None))

    @property
    def sky_col(self) -> int | None:
        return self.channel_index.get(("sky_longwave", None, None, None))

    def couple(self, i: int, j: int, conductance_w_per_k: float) -> None:
        """A conductance between nodes ``i`` and ``j`` [W/K]."""
        self.k[i, j] += conductance_w_per_k
        self.k[j, i] += conductance_w_per_k
        self.k[i, i] -= conductance_w_per_k
        self.k[j, j] -= conductance_w_per_k

    def to_boundary(self, i: int, col: int, conductance_w_per_k: float, store: FloatArray) -> None:
        """A conductance from node ``i`` to the boundary temperature of channel ``col``."""
        self.k[i, i] -= conductance_w_per_k
        self.f[i, col] += conductance_w_per_k
        store[i] += conductance_w_per_k


def _allocate_nodes(b: Building) -> _Assembly:
    """Name the nodes (zone air, wall slices, then the massless ones) and zero K and F."""
    channels = disturbance_channels(b)
    names: list[str] = list(b.zone_names)
    capacitance: list[float] = [zone.capacitance_j_per_k for zone in b.zones]
    for wall in b.walls:
        names += _wall_node_names(wall)
        capacitance += [c * wall.area_m2 for c in wall.construction.chain()[0]]
    n, nd = len(names), len(channels)
    # massless nodes, eliminated at the end: inside surfaces and radiant star of the zones
    # with explicit interior long-wave exchange
    radiant = {z.name: z for z in b.zones if z.interior_radiation_w_per_m2k is not None}
    surface_node: dict[str, int] = {}
    far_surface_node: dict[str, int] = {}
    star_node: dict[str, int] = {}
    extra = n
    for wall in b.walls:
        if wall.zone in radiant:
            surface_node[wall.name] = extra
            extra += 1
        if wall.adjacent in radiant:
            far_surface_node[wall.name] = extra
            extra += 1
    for name in radiant:
        star_node[name] = extra
        extra += 1
    return _Assembly(
        channels=channels,
        channel_index={
            (c.kind, c.azimuth_deg, c.tilt_deg, c.zone): i for i, c in enumerate(channels)
        },
        names=names,
        capacitance=capacitance,
        index={name: i for i, name in enumerate(names)},
        radiant=radiant,
        surface_node=surface_node,
        far_surface_node=far_surface_node,
        star_node=star_node,
        k=np.zeros((extra, extra)),
        f=np.zeros((extra, nd)),
        outdoor=np.zeros(extra),
        ground=np.zeros(extra),
        direct_loss=np.zeros(nd),
    )


def _add_wall_inside(
    net: _Assembly, wall: Wall, nodes: list[int], links: tuple[float, ...]
) -> None:
    """Innermost node → zone air (through the surface node and the radiant star when the
    zone has explicit long-wave exchange), then the links between the wall's nodes."""
    area = wall.area_m2
    zone_node = net.index[wall.zone]
    if wall.name in net.surface_node:
        surface = net.surface_node[wall.name]
        h_radiant = net.radiant[wall.zone].interior_radiation_w_per_m2k
        assert h_radiant is not None
        net.couple(nodes[-1], surface, area / links[-1])
        net.couple(surface, zone_node, area * wall.construction.inside_film_w_per_m2k)
        net.couple(surface, net.star_node[wall.zone], area * h_radiant)
    else:
        r_inside = links[-1] + 1.0 / wall.construction.inside_film_w_per_m2k
        net.couple(nodes[-1], zone_node, area / r_inside)
    for s in range(len(nodes) - 1):
        net.couple(nodes[s], nodes[s + 1], area / links[s + 1])


def _add_wall_far_side(
    net: _Assembly, wall: Wall, nodes: list[int], links: tuple[float, ...]
) -> None:
    """Outermost node → outdoor air (with absorbed solar and sky long-wave on the outer
    surface), the ground, or the neighbouring zone; nothing for an adiabatic face."""
    area = wall.area_m2
    film = wall.construction.outside_film_for(wall.adjacent)
    r_far = 0.0 if film is None else 1.0 / film
    r_outer_half = links[0]
    conductance = area / (r_far + r_outer_half)
    if wall.adjacent == OUTSIDE:
        net.to_boundary(nodes[0], net.outdoor_col, conductance, net.outdoor)
        share_to_node = r_far / (r_far + r_outer_half)
        if wall.solar_absorptance > 0:
            col = net.channel_index[("solar", wall.azimuth_deg, wall.tilt_deg, None)]
            absorbed_m2 = wall.solar_absorptance * area
            net.f[nodes[0], col] += absorbed_m2 * share_to_node
            net.direct_loss[col] += absorbed_m2 * (1.0 - share_to_node)
        if wall.thermal_emissivity is not None:
            sky_col = net.sky_col
            assert sky_col is not None
            emitting_m2 = wall.thermal_emissivity * wall.sky_view_factor * area
            net.f[nodes[0], sky_col] -= emitting_m2 * share_to_node
            net.direct_loss[sky_col] -= emitting_m2 * (1.0 - share_to_node)
    elif wall.adjacent == GROUND:
        ground_col = net.ground_col
        assert ground_col is not None
        net.to_boundary(nodes[0], ground_col, conductance, net.ground)
    elif wall.name in net.far_surface_node:
        # the partition's face in a zone with explicit long-wave exchange: a massless surface
        # node between the outermost slice, that zone's air (film) and its radiant star
        assert film is not None  # a zone-to-zone face always has a film
        h_radiant = net.radiant[wall.adjacent].interior_radiation_w_per_m2k
        assert h_radiant is not None
        surface = net.far_surface_node[wall.name]
        net.couple(nodes[0], surface, area / r_outer_half)
        net.couple(surface, net.index[wall.adjacent], area * film)
        net.couple(surface, net.star_node[wall.adjacent], area * h_radiant)
    elif wall.adjacent != ADIABATIC:
        net.couple(nodes[0], net.index[wall.adjacent], conductance)


def _add_walls(net: _Assembly, b: Building) -> None:
    for wall in b.walls:
        _, links = wall.construction.chain()
        nodes = [net.index[name] for name in _wall_node_names(wall)]
        _add_wall_inside(net, wall, nodes, links)
        _add_wall_far_side(net, wall, nodes, links)


def _add_transmitted_solar(
    net: _Assembly, b: Building, window: Window, col: int, transmitted_m2: float
) -> None:
    """A window's transmitted solar: shares to the walls' inside surfaces, the share lost
    back out, the rest to the zone air."""
    zone_node = net.index[window.zone]
    to_air = 1.0 - b.zones[b.zone_index(window.zone)].solar_lost_fraction
    for wall in b.walls:
        if wall.zone != window.zone or wall.interior_solar_fraction is None:
            continue
        if wall.name in net.surface_node:
            inner, share = net.surface_node[wall.name], 1.0
        else:
            inner = net.index[_wall_node_names(wall)[-1]]
            share = _surface_share_to_node(
                wall.construction.inside_film_w_per_m2k, wall.construction.chain()[1][-1]
            )
        net.f[inner, col] += transmitted_m2 * wall.interior_solar_fraction * share
        net.f[zone_node, col] += transmitted_m2 * wall.interior_solar_fraction * (1.0 - share)
        to_air -= wall.interior_solar_fraction
    net.f[zone_node, col] += transmitted_m2 * max(to_air, 0.0)


def _add_windows(net: _Assembly, b: Building) -> None:
    """U·A to the outdoor air, solar gain, and the outer pane's sky long-wave loss."""
    for window in b.windows:
        zone_node = net.index[window.zone]
        net.to_boundary(zone_node, net.outdoor_col, window.ua_w_per_k, net.outdoor)
        if window.shgc_normal is None:
            col = net.channel_index[("solar", window.azimuth_deg, window.tilt_deg, None)]
            transmitted_m2 = window.shgc * window.area_m2
        else:  # the channel already is the gain per m² of window
            col = net.channel_index[("window_solar_gain", None, None, window.name)]
            transmitted_m2 = window.area_m2
        _add_transmitted_solar(net, b, window, col, transmitted_m2)
        if window.thermal_emissivity is not None:
            sky_col = net.sky_col
            assert sky_col is not None
            emitting_m2 = window.thermal_emissivity * window.sky_view_factor * window.area_m2
            to_zone = window.u_value_w_per_m2k / window.outside_film_w_per_m2k
            net.f[zone_node, sky_col] -= emitting_m2 * to_zone
            net.direct_loss[sky_col] -= emitting_m2 * (1.0 - to_zone)


def _add_zone_air(net: _Assembly, b: Building) -> None:
    """Infiltration, and the internal gain split into convective (air) and radiative
    (spread over the zone's surfaces by area)."""
    for zone in b.zones:
        zone_node = net.index[zone.name]
        col = net.channel_index[("internal_gain", None, None, zone.name)]
        if zone.infiltration_ach > 0:
            net.to_boundary(zone_node, net.outdoor_col, zone.infiltration_w_per_k, net.outdoor)
        radiative = zone.internal_gain_radiative_fraction
        surfaces = (
            _zone_surfaces(b, zone, net.index, net.surface_node, net.far_surface_node)
            if radiative > 0
            else []
        )
        if not surfaces:
            net.f[zone_node, col] += 1.0
            continue
        net.f[zone_node, col] += 1.0 - radiative
        total_area = sum(area for _, area, _ in surfaces)
        for node, area, share in surfaces:
            net.f[node, col] += radiative * area / total_area * share
            net.f[zone_node, col] += radiative * area / total_area * (1.0 - share)


def _kron_reduce(net: _Assembly) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(K, F, outdoor, ground) with the massless nodes eliminated exactly (Kron reduction)."""
    n = len(net.names)
    k, f, outdoor, ground = net.k, net.f, net.outdoor, net.ground
    if k.shape[0] > n:
        elim = np.linalg.solve(k[n:, n:], np.hstack([k[n:, :n], f[n:]]))
        f = f[:n] - k[:n, n:] @ elim[:, n:]
        k = k[:n, :n] - k[:n, n:] @ elim[:, :n]
        k = 0.5 * (k + k.T)
        outdoor, ground = outdoor[:n], ground[:n]
    return k, f, outdoor, ground


def build_network(b: Building) -> ThermalNetwork:
    """Assemble the RC network of a building.

    Parameters
    ----------
    b : the building.

    Returns
    -------
    The :class:`ThermalNetwork` (matrices in SI units, see its attributes).
    """
    if b.identified is not None:
        return _identified_network(b.identified, b.zone_names)
    net = _allocate_nodes(b)
    _add_walls(net, b)
    _add_windows(net, b)
    _add_zone_air(net, b)
    k, f, outdoor, ground = _kron_reduce(net)
    cap = np.asarray(net.capacitance)
    return ThermalNetwork(
        node_names=tuple(net.names),
        zone_node_index=np.arange(len(b.zones), dtype=np.intp),
        channels=net.channels,
        capacitance_j_per_k=frozen_array(cap),
        conductance_w_per_k=frozen_array(k),
        input_w=frozen_array(f),
        outdoor_conductance_w_per_k=frozen_array(outdoor),
        ground_conductance_w_per_k=frozen_array(ground),
        solar_direct_loss_m2=frozen_array(net.direct_loss),
        a_cont=frozen_array(k / cap[:, None]),
        e_cont=frozen_array(f / cap[:, None]),
    )


def envelope_ua_w_per_k(b: Building) -> dict[str, float]:
    """Steady-state envelope conductance [W/K]: ``walls`` (exterior opaque), ``ground``,
    ``windows``, ``infiltration`` and ``total`` (film to film, U·A summed; zone–zone walls
    excluded)."""
    walls = sum(w.ua_w_per_k for w in b.walls if w.adjacent == OUTSIDE)
    ground = sum(w.ua_w_per_k for w in b.walls if w.adjacent == GROUND)
    windows = sum(w.ua_w_per_k for w in b.windows)
    infiltration = sum(z.infiltration_w_per_k for z in b.zones)
    return {
        "walls": walls,
        "ground": ground,
        "windows": windows,
        "infiltration": infiltration,
        "total": walls + ground + windows + infiltration,
    }


def _identified_network(rc: IdentifiedRC, zone_names: tuple[str, ...]) -> ThermalNetwork:
    """The network of an identified building (:mod:`hvacflex.building.identified`): nodes
    ``[air (m), <zone>_mass (m), boundary nodes (nb)]``; channels as
    :func:`identified_channels`."""
    m, nb = len(rc.zones), len(rc.boundaries)
    n = 2 * m + nb
    channels = identified_channels(zone_names)
    walls = [i for i, ch in enumerate(channels) if ch.kind == "solar" and ch.tilt_deg == 90.0]
    gains = next(i for i, ch in enumerate(channels) if ch.kind == "internal_gain")
    kw = 1000.0  # kW (kJ/K) → W (J/K)
    cap = np.zeros(n)
    k = np.zeros((n, n))
    f = np.zeros((n, len(channels)))
    outdoor = np.zeros(n)

    def couple(i: int, j: int, ua_kw_per_k: float) -> None:
        k[i, j] += ua_kw_per_k * kw
        k[j, i] += ua_kw_per_k * kw

    gain_per_w = kw / GAIN_CHANNEL_PEAK_W  # W into the node per W of the channel, per kW
    for i, zone in enumerate(rc.zones):
        cap[i], cap[m + i] = zone.c_air_kj_per_k * kw, zone.c_mass_kj_per_k * kw
        couple(i, m + i, zone.ua_air_mass_kw_per_k)
        outdoor[i], outdoor[m + i] = zone.ua_out_kw_per_k * kw, zone.ua_mass_out_kw_per_k * kw
        f[i, 1], f[m + i, 1] = zone.solar_air_m2, zone.solar_mass_m2
        f[i, walls] = zone.wall_solar_m2()
        f[i, gains + i] = zone.occupied_gain_kw * gain_per_w
        f[i, -1] = zone.base_gain_kw * kw
    index = {name: i for i, name in enumerate(zone_names)}
    for coupling in rc.couplings:
        couple(index[coupling.zone_a], index[coupling.zone_b], coupling.ua_kw_per_k)
    for j, node in enumerate(rc.boundaries):
        b = 2 * m + j
        cap[b], outdoor[b], f[b, 1] = node.c_kj_per_k * kw, node.ua_out_kw_per_k * kw, node.solar_m2
        for zone_name, ua in node.ua_zone_kw_per_k:
            couple(index[zone_name], b, ua)
        # the boundary's gain follows the schedule of the zones' gains (any one: the same)
        f[b, gains] = node.occupied_gain_kw * gain_per_w
    f[:, 0] = outdoor
    k -= np.diag(k.sum(axis=1) + outdoor)
    names = (*zone_names, *(f"{z}_mass" for z in zone_names), *(b.name for b in rc.boundaries))
    return ThermalNetwork(
        node_names=tuple(names),
        zone_node_index=np.arange(m, dtype=np.intp),
        channels=channels,
        capacitance_j_per_k=frozen_array(cap),
        conductance_w_per_k=frozen_array(k),
        input_w=frozen_array(f),
        outdoor_conductance_w_per_k=frozen_array(outdoor),
        ground_conductance_w_per_k=frozen_array(np.zeros(n)),
        solar_direct_loss_m2=frozen_array(np.zeros(len(channels))),
        a_cont=frozen_array(k / cap[:, None]),
        e_cont=frozen_array(f / cap[:, None]),
    )
