"""Space colonisation as a growth pattern: seed 001's kernel grown from a real town.

:class:`Colonisation` puts :func:`synth.colonisation.colonise` behind the
growth-pattern interface (:class:`synth.growth.GrowthPattern`), beside the
random walk and the example patches: ``pattern.grow(city, region, rng)``
returns new streets that the shared joining step (:mod:`osm_expand.joins`)
joins to the town.

**Units.** The segment length SL is the town's junction spacing
(:attr:`simplify.example.Example.spacing`, or a number of metres given by the
caller); every distance of :class:`~synth.colonisation.ColonisationOptions`
and of :class:`ColonisationPatternOptions` is a multiple of it, so one set of
options fits a town of 60 m blocks and one of 150 m blocks alike. The only
metres are the kernel's own ``min_segment_m`` and the raster cells the user
gives.

**Seeds** (001 §4.3.3: initial segments are primary roads). The town's streets
that reach the kernel's area (the region grown by the kernel's
``edge_tolerance``, so that no town street the kernel does not know lies
where new segments may go) are the kernel's seeds, as mapped (every vertex is
a node new streets may end on). Not seeds:

* streets on another layer, bridges and tunnels: new streets may pass under
  or over them (the exported layer keys differ), never end on them;
* ``never_joined`` classes (motorways, trunk roads and their links) on the
  ground: forbidden ground, 1 m either side, so nothing crosses or joins them.

**A site away from the town.** When no town street reaches the region (a disc
next to the town, across a field), the region gets a *corridor*: the shortest
line from the region to the nearest joinable town street within
``corridor_reach`` SL, buffered to ``corridor_width`` SL, is added to the
region, so growth starts from the town (001 places its initial segments by
hand; a district that starts from nothing is no district of the town). A
corridor rather than a buffer of the whole region: it adds the least land,
and only towards the town. A corridor across water or blocks still fails
(nothing may grow on that ground); the pipeline then tries the next site.
Beyond ``corridor_reach`` the pattern grows nothing.

**Forbidden ground.** :attr:`osm_expand.model.City.occupied` (water, sea,
the town's blocks, unbuildable land, existing buildings with their margin),
the never-joined roads, and the user's border map (cells > 0.5). Land outside
the region is forbidden too unless ``confined`` is False, when the kernel's
region is the site grown by one radius of influence (APs are scattered there
as well).

**Maps** (001 §4.3.1). Without a user density map, density comes from the
town: a Gaussian kernel density of its building centroids and street vertices
(:func:`synth.infomaps.town_density` with :class:`synth.infomaps.InfoMapOptions`;
points outside the map's window are left out). User maps are
:class:`synth.infomaps.Raster` grids: read a ``.npy`` or PGM file with its
georeference by ``Raster(*osm_expand.rasters.read_raster(path,
projection=city.projection))`` (see :mod:`osm_expand.rasters` for the sidecar).
A flow field (001 §4.3.2) is either given whole (``flow``) or as primitives
(``flow_primitives``, metres in the town's projection), summed over the
kernel's region on a grid of ``flow_cell`` SL.

**Streets.** Each of the kernel's streets becomes a :class:`NewStreet` with
its hierarchy level (0 primary, 1 secondary, 2 tertiary: 001 §4.3.3) and a
highway class. With ``town_classes`` the kernel's class per level
(``highways`` option, default secondary/tertiary/residential) is kept when
the town has streets of that class, else it moves down the ladder
primary → secondary → tertiary → unclassified → residential → living_street
to the first class the town has: a village without secondary roads gets a
tertiary main road, and new streets carry the town's own vocabulary. A
kernel street running through a point of a town street is cut there, so
every meeting with the town is a street's end. An end on a town node carries
that node's exact coordinates; an end between two nodes lies exactly on the
town street's segment, so the shared joining step
(:func:`osm_expand.joins.add_streets`) inserts it into the town's way as a
tee.

**Debug** (001 §5.1.2 writes the parameters, APs, the flow field and its
primitives beside the network). ``Growth.debug`` holds, in the town's local
metres (x east, y north; reproject for RFC 7946 GeoJSON):

* ``"features"``: GeoJSON-ready features, each ``properties.layer`` one of
  :data:`DEBUG_LAYERS`: ``attraction_point`` (phase 1 or 2, alive at the end
  of its phase), ``flow_vector`` (a line from a grid cell's centre along the
  unit flow; vx, vy, speed), ``flow_primitive`` (kind, strength,
  direction_deg), ``colonisation_region`` (the kernel's region, Polygon or
  MultiPolygon), ``colonisation_corridor`` (when one was added),
  ``colonisation_join`` (where the kernel's streets meet town streets; vertex
  True on a town node, False a tee) and ``parameters`` (no geometry: the
  kernel's options, this pattern's options, SL, the maps used, the kernel's
  report);
* ``"parameters"``: the ``parameters`` feature's properties again, for a
  JSON report;
* small counts: ``"segment_length_m"``, ``"seed_streets"``,
  ``"kernel_joins"``, ``"corridor"`` (bool), ``"density"`` (``"town"``,
  ``"user"`` or ``"none"``), ``"attraction_points"``.
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

import numpy as np
import shapely
from scipy.spatial import cKDTree

from osm_expand.errors import InputError
from osm_expand.model import City, Origin, highways
from simplify.example import Example
from synth.colonisation import ColonisationOptions, ColonisationResult, colonise
from synth.flowfield import FlowField, FlowPrimitive, flow_field
from synth.growth import Growth, NewStreet
from synth.infomaps import InfoMapOptions, Raster, town_density

__all__ = ["DEBUG_LAYERS", "TOWN_OPTIONS", "Colonisation", "ColonisationPatternOptions", "colonisation_from_config",
           "town_highways"]

#: Layers of ``Growth.debug["features"]`` (``properties.layer``).
DEBUG_LAYERS = ("attraction_point", "flow_vector", "flow_primitive", "colonisation_region", "colonisation_corridor",
                "colonisation_join", "parameters")
#: Classes from most to least important that a kernel class may move down to (see ``town_classes``).
CLASS_LADDER = highways.CLASS_LADDER
#: A town node this close to a kernel node is that node (m): coordinates copied exactly.
SAME_NODE = 1e-6
#: Never-joined roads are forbidden this far either side of their centre line (m).
ROAD_CLEARANCE = 1.0
#: The kernel's options on a town, where they differ from :class:`ColonisationOptions`' defaults:
#: two APs per SL², since the town's density map keeps 30-100 % of them (so a district gets 0.6-2
#: per SL², around 001's denser 1 per SL² of figs. 104b and 108b); with one, a district's first
#: streets zigzag between few, far APs (measured on Campo Grande: staircases at 1, straight roads
#: at 2 and 3; 3 made Krems's district denser than any real part of Krems). Phase 2 at 90° too
#: (001 §5.3's grid): on a real town's irregular seeds 80°-100° leaves crooked blocks.
TOWN_OPTIONS = ColonisationOptions(ap_density=(2.0, 2.0), angle_range_2=(90.0, 90.0))


@dataclass(frozen=True)
class ColonisationPatternOptions:
    """How the kernel is set up on a town; lengths in SL (the town's junction spacing)."""

    #: Land outside the region is forbidden (the issue's default). False: the kernel's region is the
    #: site grown by one radius of influence, APs included.
    confined: bool = True
    #: A site no town street reaches gets a corridor this wide to the nearest town street, SL: four SL
    #: hold two of the kernel's growth points (``seed_spacing`` 2 SL) on the town street it reaches.
    corridor_width: float = 4.0
    #: ... if that street is at most this far, SL (about twice a district's radius; farther, nothing grows).
    corridor_reach: float = 20.0
    #: Give new streets the town's own highway classes (module docstring); False keeps the kernel's.
    town_classes: bool = True
    #: Town streets of these classes are never joined nor crossed at grade (forbidden ground).
    never_joined: tuple[str, ...] = ("motorway", "motorway_link", "trunk_link")
    #: Derive the density map from the town's buildings and streets when the user gives none (001 §4.3.1).
    density_from_town: bool = True
    #: Cell of a flow field built from ``flow_primitives``, SL: half an SL, as the density map's cell.
    flow_cell: float = 0.5
    #: Debug features: every this-many-th flow grid cell in each direction.
    flow_step: int = 1

    def __post_init__(self) -> None:
        def bad(key: str, why: str) -> InputError:
            return InputError(f"colonisation pattern option {key}: {why}")

        for key in ("corridor_width", "corridor_reach", "flow_cell"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise bad(key, f"must be a positive number of segment lengths, got {v!r}")
        if not (isinstance(self.flow_step, int) and self.flow_step >= 1):
            raise bad("flow_step", f"must be an integer >= 1, got {self.flow_step!r}")
        if isinstance(self.never_joined, str) or not all(isinstance(v, str) for v in self.never_joined):
            raise bad("never_joined", f"must be a list of highway classes, got {self.never_joined!r}")


@dataclass(frozen=True)
class _Setup:
    """The kernel's inputs derived from the city and the region."""

    region: shapely.Geometry  # where the kernel grows (region, corridor, spill)
    corridor: shapely.Geometry | None
    seeds: list[np.ndarray]  # town street polylines, metres
    forbidden: shapely.Geometry


@dataclass(frozen=True)
class Colonisation:
    """Seed 001's space colonisation behind the growth-pattern interface (module docstring).

    Parameters
    ----------
    town : Example or float
        The town's example (its junction spacing is SL) or SL itself in metres.
    options : ColonisationOptions
        The kernel's options (default :data:`TOWN_OPTIONS`); ``segment_length`` is replaced by SL.
    pattern : ColonisationPatternOptions
        Seeds, corridor, classes, maps.
    density, height, border : Raster, optional
        User maps in the town's metres: density in [0, 1] (larger denser),
        height in metres, border (> 0.5 forbidden).
    flow : FlowField, optional
        A flow field in the town's metres.
    flow_primitives : tuple of FlowPrimitive
        Or primitives, summed on a grid over the kernel's region (ignored when ``flow`` is given).
    """

    town: Example | float
    options: ColonisationOptions = TOWN_OPTIONS
    pattern: ColonisationPatternOptions = field(default_factory=ColonisationPatternOptions)
    density: Raster | None = None
    height: Raster | None = None
    border: Raster | None = None
    flow: FlowField | None = None
    flow_primitives: tuple[FlowPrimitive, ...] = ()
    name: str = "colonisation"

    @property
    def segment_length(self) -> float:
        """SL in metres: the town's junction spacing."""
        sl = float(self.town.spacing if isinstance(self.town, Example) else self.town)
        if not (np.isfinite(sl) and sl > 0):
            raise InputError(f"colonisation: the segment length must be a positive number of metres, got {sl}")
        return sl

    def grow(self, city: City, region: shapely.Geometry, rng: np.random.Generator) -> Growth:
        """Streets grown by space colonisation in ``region`` from the town's streets.

        Parameters
        ----------
        city : City
            The town (with its blocks and unbuildable land: :func:`osm_expand.pipeline.prepare`).
        region : shapely Polygon or MultiPolygon
            Where to grow, metres.
        rng : numpy.random.Generator
            The only randomness (AP clouds, density sampling).

        Returns
        -------
        Growth
            Streets that touch nothing forbidden and cross no street except
            at a shared node; ``footprint`` the kernel's region less what is
            occupied; ``debug`` as in the module docstring.
        """
        sl = self.segment_length
        opts = replace(self.options, segment_length=sl)
        setup = _setup(city, region, opts, self.pattern)
        footprint = shapely.make_valid(shapely.difference(setup.region, city.occupied_within(setup.region)))
        density, source = self._density(city, setup.region, sl)
        flow = self.flow
        if flow is None and self.flow_primitives:
            flow = flow_field(self.flow_primitives, bounds=setup.region.bounds, cell=self.pattern.flow_cell * sl)
        base = {"segment_length_m": round(sl, 3), "seed_streets": len(setup.seeds),
                "corridor": setup.corridor is not None, "density": source}
        if not setup.seeds or footprint.is_empty:
            return Growth(streets=(), footprint=footprint,
                          debug={**base, "kernel_joins": 0, "attraction_points": 0, "features": [],
                                 "parameters": {}})
        result = colonise(setup.region, seeds=setup.seeds, forbidden=setup.forbidden, options=opts, rng=rng,
                          density=density, height=self.height, flow=flow, border=self.border)
        highways = town_highways(city, opts.highways) if self.pattern.town_classes else opts.highways
        streets = _new_streets(result, setup.seeds, highways)
        params = self._parameters(result, base)
        features = _debug_features(result, setup, params, self.pattern.flow_step)
        return Growth(streets=streets, footprint=footprint,
                      debug={**base, "kernel_joins": len(result.joins),
                             "attraction_points": int(len(result.attraction_xy)), "features": features,
                             "parameters": params})

    def _density(self, city: City, region: shapely.Geometry, sl: float) -> tuple[Raster | None, str]:
        """The user's density map, or the town's (buildings and street vertices), or none."""
        if self.density is not None:
            return self.density, "user"
        if not self.pattern.density_from_town:
            return None, "none"
        maps = InfoMapOptions()
        pad = maps.margin * sl
        x0, y0, x1, y1 = region.bounds
        points = _town_points(city)
        inside = ((points[:, 0] >= x0 - pad) & (points[:, 0] <= x1 + pad)
                  & (points[:, 1] >= y0 - pad) & (points[:, 1] <= y1 + pad))
        return town_density(points[inside], bounds=(x0, y0, x1, y1), segment_length=sl, options=maps), "town"

    def _parameters(self, result: ColonisationResult, base: dict[str, Any]) -> dict[str, Any]:
        return {"pattern": self.name, **base, "options": result.options.to_dict(),
                "pattern_options": {k: (list(v) if isinstance(v, tuple) else v)
                                    for k, v in asdict(self.pattern).items()},
                "maps": {"height": self.height is not None, "border": self.border is not None,
                         "flow": result.flow is not None},
                "report": result.report}


def _across_frontage(city: City, region: shapely.Geometry) -> shapely.Geometry:
    """The region and the town's presumed frontage beside it (out to the frontage depth, none of the
    rest occupied): the roads grow from the town's streets, which the frontage keeps a depth away from
    the free land; its attraction points stay on the free land (the footprint)."""
    land = city.land
    if land is None or not len(land.taken):
        return region
    depth = max(land.frontage_depth.values(), default=0.0) + 1.0
    wide = shapely.buffer(region, depth)
    grown = shapely.make_valid(shapely.difference(wide, city.occupied_within(wide, taken=False)))
    parts = [p for p in shapely.get_parts(grown) if p.intersects(region)]
    return shapely.union_all([region, *parts]) if parts else region


def _setup(city: City, region: shapely.Geometry, opts: ColonisationOptions,
           pattern: ColonisationPatternOptions) -> _Setup:
    """Region (with a corridor or spill), seeds and forbidden ground for the kernel."""
    sl = opts.segment_length
    region = shapely.make_valid(region)
    if not pattern.confined:
        region = shapely.buffer(region, opts.radius_of_influence * sl)
    region = _across_frontage(city, region)
    net = city.network
    town = [k for k, s in enumerate(net.streets) if s.origin == Origin.SOURCE]
    lines = net.street_lines()[np.asarray(town, dtype=np.intp)]
    ground = np.array([net.streets[k].layer_key == (0, False, False) for k in town], dtype=bool)
    barred = np.array([net.streets[k].highway in pattern.never_joined for k in town], dtype=bool)
    joinable = ground & ~barred
    reach = opts.edge_tolerance * sl + 1.0
    tree = shapely.STRtree(lines) if len(lines) else None
    corridor = None
    if tree is not None and not _reaching(tree, region, reach, joinable).size:
        corridor = _corridor(region, lines[joinable], pattern, sl)
        if corridor is not None:
            region = shapely.union(region, corridor)
    hits = _reaching(tree, region, reach, None) if tree is not None else np.zeros(0, dtype=np.int64)
    seeds = [shapely.get_coordinates(lines[k]) for k in hits.tolist() if joinable[k]]
    roads = [lines[k] for k in hits.tolist() if ground[k] and barred[k]]
    # its roads grow out of the town's streets: they may pass the town's presumed frontage (its attraction
    # points lie only on free land, the footprint), else they could never leave the streets they start on
    forbidden = city.occupied_within(region, taken=False)
    if roads:  # the union costs a second on a large town: only when there is something to add
        forbidden = shapely.union_all([forbidden, *shapely.buffer(np.array(roads, dtype=object), ROAD_CLEARANCE)])
    return _Setup(region=region, corridor=corridor, seeds=seeds, forbidden=forbidden)


def _reaching(tree: shapely.STRtree, region: shapely.Geometry, reach: float,
              among: np.ndarray | None) -> np.ndarray:
    """Sorted indices of the tree's lines within ``reach`` metres of ``region`` (only ``among`` if given)."""
    hits = np.unique(tree.query(region, predicate="dwithin", distance=reach))
    return hits[among[hits]] if among is not None else hits


def _corridor(region: shapely.Geometry, lines: np.ndarray, pattern: ColonisationPatternOptions,
              sl: float) -> shapely.Geometry | None:
    """A strip from the region to the nearest of ``lines`` within ``corridor_reach`` SL, or None."""
    if not len(lines):
        return None
    tree = shapely.STRtree(lines)
    near = tree.query_nearest(region, max_distance=pattern.corridor_reach * sl, all_matches=False)
    if not len(near):
        return None
    bridge = shapely.shortest_line(region, lines[int(near[0])])
    return shapely.buffer(bridge, 0.5 * pattern.corridor_width * sl)


def _town_points(city: City) -> np.ndarray:
    """Building centroids and the town's street vertices, (N, 2) metres."""
    net = city.network
    used = [np.asarray(s.nodes, dtype=np.int64) for s in net.streets if s.origin == Origin.SOURCE]
    vertices = net.xy[np.unique(np.concatenate(used))] if used else np.zeros((0, 2))
    centres = np.array([b.ring[:-1].mean(axis=0) for b in city.buildings]).reshape(-1, 2)
    return np.vstack([vertices, centres])


def town_highways(city: City, kernel: tuple[str, str, str]) -> tuple[str, str, str]:
    """The highway class per kernel level in the town's own vocabulary.

    Parameters
    ----------
    city : City
        The town; only its mapped streets count.
    kernel : (str, str, str)
        The kernel's classes for levels 0, 1, 2.

    Returns
    -------
    (str, str, str)
        Each kernel class if the town has it, else the first class below it
        on :data:`CLASS_LADDER` that the town has, else the kernel's class.

    Examples
    --------
    A town of tertiary and residential streets keeps ``tertiary`` and
    ``residential`` and gets ``tertiary`` for its main roads:
    ``("secondary", "tertiary", "residential") → ("tertiary", "tertiary", "residential")``.
    """
    have = {s.highway for s in city.network.streets if s.origin == Origin.SOURCE}
    out = []
    for cls in kernel:
        pick = cls
        if cls not in have and cls in CLASS_LADDER:
            pick = next((c for c in CLASS_LADDER[CLASS_LADDER.index(cls):] if c in have), cls)
        out.append(pick)
    # one pick per class of the three-class kernel: three, as annotated
    return tuple(out)  # type: ignore[return-value]


def _new_streets(result: ColonisationResult, seeds: list[np.ndarray],
                 highways: tuple[str, ...]) -> tuple[NewStreet, ...]:
    """The kernel's streets, cut at every town-street point and with exact ends on the town."""
    exact = _exact_points(result, seeds)
    out = []
    for street in result.streets:
        nodes = np.asarray(street.nodes, dtype=np.int64)
        xy = result.xy[nodes].copy()
        fixed = result.fixed[nodes]
        for i in np.flatnonzero(fixed).tolist():
            xy[i] = exact[int(nodes[i])]
        cuts = [0, *np.flatnonzero(fixed[1:-1]) + 1, len(nodes) - 1]
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b > a:
                out.append(NewStreet(xy=xy[a:b + 1], hierarchy=int(street.level), highway=highways[street.level]))
    return tuple(out)


def _exact_points(result: ColonisationResult, seeds: list[np.ndarray]) -> dict[int, np.ndarray]:
    """Per kernel node on a town street: the town node's coordinates, or its foot on the town segment."""
    out: dict[int, np.ndarray] = {}
    if not result.joins:
        return out
    town_xy = np.unique(np.vstack(seeds), axis=0)
    tree = cKDTree(town_xy)
    for j in result.joins:
        p = np.array(j.xy)
        d, k = tree.query(p)
        if d <= SAME_NODE:
            out[j.node] = town_xy[k].copy()
            continue
        line = seeds[j.seed]
        a, b = line[j.segment], line[min(j.segment + 1, len(line) - 1)]
        ab = b - a
        t = float(np.clip(np.dot(p - a, ab) / max(float(np.dot(ab, ab)), 1e-300), 0.0, 1.0))
        out[j.node] = a + t * ab
    return out


def _debug_features(result: ColonisationResult, setup: _Setup, params: dict[str, Any],
                    flow_step: int) -> list[dict[str, Any]]:
    """The kernel's debug features with this pattern's region, corridor, joins and parameters."""
    feats = [f for f in result.debug_features(flow_step=flow_step) if f["properties"]["layer"] != "parameters"]
    feats.append(_feature(setup.region, layer="colonisation_region"))
    if setup.corridor is not None:
        feats.append(_feature(setup.corridor, layer="colonisation_corridor"))
    for j in result.joins:
        feats.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [j.xy[0], j.xy[1]]},
                      "properties": {"layer": "colonisation_join", "vertex": bool(j.vertex)}})
    feats.append({"type": "Feature", "geometry": None, "properties": {"layer": "parameters", **params}})
    return feats


def _feature(geom: shapely.Geometry, **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": json.loads(shapely.to_geojson(geom)), "properties": properties}


def colonisation_from_config(town: Example | float, config: Mapping[str, Any], *, density: Raster | None = None,
                             height: Raster | None = None, border: Raster | None = None) -> Colonisation:
    """A :class:`Colonisation` from plain values, as a history's era gives them (TOML).

    Parameters
    ----------
    town : Example or float
        The town's example, or SL in metres.
    config : mapping
        Keys of :class:`~synth.colonisation.ColonisationOptions` (but not
        ``segment_length``; unset keys are :data:`TOWN_OPTIONS`') and of :class:`ColonisationPatternOptions`; lists
        become tuples. ``flow`` is a list of primitive tables (``kind``, ``x``,
        ``y``, ``strength``, ``direction_deg``; metres in the town's projection).
    density, height, border : Raster, optional
        Maps already read (:func:`osm_expand.rasters.read_raster`).

    Returns
    -------
    Colonisation

    Raises
    ------
    InputError
        An unknown key (the message lists the valid ones) or a bad value.
    """
    kernel_keys = {f.name for f in fields(ColonisationOptions)} - {"segment_length"}
    pattern_keys = {f.name for f in fields(ColonisationPatternOptions)}
    valid = sorted(kernel_keys | pattern_keys | {"flow"})
    unknown = sorted(set(config) - set(valid))
    if unknown:
        raise InputError(f"colonisation: unknown key {unknown[0]!r}; valid keys are {', '.join(valid)}")

    def plain(v: Any) -> Any:
        return tuple(v) if isinstance(v, list) else v

    kernel = replace(TOWN_OPTIONS, **{k: plain(v) for k, v in config.items() if k in kernel_keys})
    pattern = ColonisationPatternOptions(**{k: plain(v) for k, v in config.items() if k in pattern_keys})
    prims = config.get("flow", [])
    if not isinstance(prims, (list, tuple)) or not all(isinstance(p, Mapping) for p in prims):
        raise InputError("colonisation: flow must be a list of tables with kind, x, y, strength, direction_deg")
    known = {f.name for f in fields(FlowPrimitive)}
    for p in prims:
        extra = sorted(set(p) - known)
        if extra:
            raise InputError(f"colonisation: flow primitive key {extra[0]!r} is not one of {', '.join(sorted(known))}")
    return Colonisation(town=town, options=kernel, pattern=pattern, density=density, height=height, border=border,
                        flow_primitives=tuple(FlowPrimitive(**p) for p in prims))
