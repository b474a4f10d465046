"""The build-out: land use, lots and buildings of a city, year after year (issue 11; 002 §2.2, §4–5; 004 §4.3.3–4).

The year loop calls :func:`start_buildout` once and :func:`buildout_year`
every year after the traffic step (002 §2.2: streets, then traffic, then land
use, lots and buildings). One year:

1. **Demolition.** A lot that a street centre line now crosses (a new street,
   a rebuilding road, a smoothed major road), that lies outside every
   block, that lost every street it fronted, or that has more than
   ``street_overlap`` of its area on a street's carriageway (half the
   street's width either side of its centre line) is demolished with its
   building. A building on a carriageway or crossed by a centre line goes
   alone; its lot keeps its place. Streets the map leaves without a width
   get their class's (:func:`osm_expand.model.segments.street_width`).
2. **Blocks to build out.** Block ids are renumbered whenever the loop
   recomputes blocks, so surviving lots find their block geometrically (a
   point inside the lot). A block is built out when it touches at least one
   street the tool made (grown, join or engine); blocks bounded by the
   town's streets alone are never touched. Its free land is the block minus
   water, land nothing new may take and the land within ``town_clearance``
   of the town's buildings (a district's street that closes a block around
   a few farmhouses builds on the fields, not in their gardens; the town's
   buildings themselves are never touched). A block is subdivided once;
   afterwards only when its outline changed (a street split it) or lots in
   it were demolished: its free land, minus its surviving lots, is
   subdivided again and the area heals. A lot whose streets changed (moved,
   split, widened, gone) faces again the streets its edges lie on.
3. **Types and lots** (002 §4.1, §5.1). A new block's land-use type is the
   one that raises the system value most against the lots around it
   (:func:`~osm_expand.engine.buildout.landuse.choose_types`); a healing block keeps
   the type of its surviving lots. The block is shrunk by half the street
   widths and split recursively by the lot rules of its type's lot class
   (:func:`~osm_expand.engine.buildout.lots.subdivide_blocks`, sizes calibrated on
   the town); lots without street access are discarded and so are lots a
   street centre line crosses or that reach onto a carriageway (a bridge
   over a block, a wider street overlapping the one the block's edge was
   given to). The lots inherit the block's type.
4. **Land-use update** (002 §4.1, Table 3) in the years the history says
   (``YearValues.land_use_update``): over the old town's units and all lots
   (:mod:`osm_expand.engine.buildout.calibration`), with this year's traffic. A lot
   may only take a type whose lot class's ``min_area``..``max_area`` holds
   its area (a house lot does not become an industrial estate; lots of
   every type keep their class's bounds).
5. **Substitution** (002 §5.4): the buildings on lots are replaced with
   probability f₁(age) + f₂(Δprice); a replaced building is demolished and
   its lot builds again this year (step 6), so the replacement carries this
   year.
6. **Buildings** (002 §2.2, §5.2–5.3; 004 §4.3.4): lots without a building
   that front a *built* street and whose type builds get the largest
   rectangle facing the built street with the most traffic, within the
   setbacks of their lot class and sized after the town's footprints
   (:func:`~osm_expand.engine.buildout.footprints.place_buildings`); none may touch a
   carriageway, a building of the town (its minimum rectangle, as the XML
   draws it) or another generated building. A lot where nothing fits is not
   tried again until its type or its built streets change. Floors and
   height come from 002's economy with 004's centre fall-off
   (:func:`~osm_expand.engine.buildout.economy.lot_economy`). The height scale is
   fitted every year on the raw floors of all the generated buildings
   standing (each from the year it was built) and this year's together, so
   that the district as a whole keeps the town's tagged (or default) median
   height and spread, while within it dearer land — a later year, a better
   place — builds taller (002).
7. **People** (002 §3.2, §5.2): each lot's residents, jobs and visitors from
   its building's floor space and its land use
   (:func:`~osm_expand.engine.buildout.economy.occupants`): floor space per resident
   or job per type, visitors per m² of park; ``Lot.people`` is their sum,
   which the traffic step's trip model reads. A lot without a building yet
   counts the floor space its land use expects
   (:func:`~osm_expand.engine.buildout.economy.expected_floor_space`; 002 §4: "the
   number of residents per lot depends on the land use value"): otherwise
   no trip would ever start on a planned street, it would never carry the
   traffic that gets it built (002 §3.2), and its lots would wait forever.

What the town itself teaches (sizes, heights, centres, land-use goals and
the old town's units) is read once by :func:`~osm_expand.engine.buildout.calibration.calibrate_town`.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.blocks import blocks as find_blocks
from osm_expand.engine.buildout.calibration import CalibrationOptions, TownCalibration, calibrate_town, size_bands
from osm_expand.engine.buildout.economy import HeightScale, expected_floor_space, lot_economy, occupants, substitute
from osm_expand.engine.buildout.footprints import place_buildings
from osm_expand.engine.buildout.landuse import assign_types, block_types, choose_types, update_land_use
from osm_expand.engine.buildout.landuse_types import UNASSIGNED, goal_shares
from osm_expand.engine.buildout.lot_values import LotLayout, distance_to, lot_attributes, lot_layout, lot_values
from osm_expand.engine.buildout.lots import NO_STREET, Frontage, LandUse, block_frontage, land_use, subdivide_blocks
from osm_expand.engine.buildout.report import buildout_report  # re-exported
from osm_expand.engine.history import History, YearValues
from osm_expand.errors import InputError
from osm_expand.model import Block, Building, City, Lot, Origin, Status
from osm_expand.model.options import require_positive
from osm_expand.model.segments import street_width

__all__ = ["BuildoutMemory", "BuildoutOptions", "BuildoutYear", "LotState", "buildout_report", "buildout_year",
           "start_buildout", "town_people"]


@dataclass(frozen=True)
class BuildoutOptions:
    """The build-out's own rules (the kernels' rules come from the history)."""

    #: Share of a lot's area on a street's carriageway beyond which the lot is demolished: a road
    #: went through it. Below, a widened street only takes the front garden (buildings stand at
    #: least their front setback back) and buildings on the carriageway go alone.
    street_overlap: float = 0.25
    #: m², a building with more than this on a carriageway is demolished (the referee's overlap tolerance).
    building_overlap: float = 0.5
    #: m², free land smaller than this is not subdivided (below the smallest lot class's ``min_area``, 150 m²).
    min_region: float = 100.0
    #: m, land kept free around the town's buildings (their drawn rectangles) in a block that new
    #: streets bound: a house's garden and its neighbour's side setback (the town's own lots are not
    #: mapped; 10 m is about the depth of a front or back garden of the bundled lot classes).
    town_clearance: float = 10.0
    #: m, grid spacing of the rectangle sweep along a lot's street side (the kernel samples the lot's
    #: vertices exactly; 0.5 m is finer than any setback draw).
    resolution: float = 0.5
    #: Buildings in the expected class shares added to the real counts when the size bands are
    #: restacked each year (:func:`_bands`): a year of a few buildings keeps the expected bands, the
    #: first year's hundred follow their own mix.
    band_prior: float = 20.0

    def __post_init__(self) -> None:
        if not 0 < self.street_overlap <= 1:
            raise InputError(f"buildout street_overlap: must lie in (0, 1], got {self.street_overlap}")
        for key in ("building_overlap", "min_region", "town_clearance"):
            if not getattr(self, key) >= 0:
                raise InputError(f"buildout {key}: must be ≥ 0, got {getattr(self, key)}")
        if not self.band_prior >= 0:
            raise InputError(f"buildout band_prior: must be ≥ 0, got {self.band_prior}")
        require_positive(self, ("resolution",))


@dataclass(frozen=True)
class BuildoutYear:
    """What one year (or, summed, an era) of build-out did."""

    blocks: int = 0  #: blocks subdivided (new, or healing after demolition)
    lots_made: int = 0
    lots_demolished: int = 0
    buildings_built: int = 0  #: new buildings, replacements included
    buildings_demolished: int = 0  #: under a street, or replaced by nothing
    buildings_substituted: int = 0  #: replaced by a new building the same year (002 §5.4)
    land_use_proposed: int = 0  #: proposals of the land-use update (002 Table 3)
    land_use_changes: int = 0  #: lots and town units whose type changed

    def __add__(self, other: BuildoutYear) -> BuildoutYear:
        return BuildoutYear(*(getattr(self, f) + getattr(other, f) for f in self.__dataclass_fields__))

    def to_dict(self) -> dict[str, int]:
        """JSON-ready counts."""
        return {f: int(getattr(self, f)) for f in self.__dataclass_fields__}


@dataclass(frozen=True, eq=False)
class LotState:
    """What the build-out remembers about one lot beyond the city's :class:`~osm_expand.model.Lot`."""

    lot: Lot  #: ring and the street each edge faces (:class:`osm_expand.model.Lot`)
    type: int  #: land-use type index into ``TownCalibration.types``
    year: int  #: year the lot was made
    point: tuple[float, float]  #: a point inside the lot (m): its place for land use and block matching
    water: float  #: m to the nearest water
    green: float  #: m to the nearest green
    tried: tuple | None = None  #: (type, built streets) when a building last did not fit

    @cached_property
    def streets(self) -> tuple[int, ...]:
        """Ids of the streets the lot fronts, ascending."""
        return tuple(self.lot.streets.tolist())

    @cached_property
    def frontage(self) -> dict[int, float]:
        """Metres of the lot's boundary facing each of its streets."""
        return {s: self.lot.frontage_length(s) for s in self.streets}


class _Memo:
    """Geometry the build-out would otherwise rebuild every year: a cache, never a source of results.

    ``footprints``: a generated building's polygon and area by the building
    object's id (checked against the object); ``streets``: each street's
    centre line and carriageway by id, with the nodes and width they were
    made from.
    """

    def __init__(self) -> None:
        self.footprints: dict[int, tuple[Building, shapely.Polygon, float]] = {}
        self.streets: dict[int, tuple[tuple[int, ...], float, shapely.Geometry, shapely.Geometry]] = {}

    def footprint(self, b: Building) -> tuple[shapely.Polygon, float]:
        hit = self.footprints.get(id(b))
        if hit is None or hit[0] is not b:
            poly = b.polygon
            hit = (b, poly, float(poly.area))
            self.footprints[id(b)] = hit
        return hit[1], hit[2]

    def keep_footprints(self, buildings: Sequence[Building]) -> None:
        alive = {id(b) for b in buildings}
        self.footprints = {k: v for k, v in self.footprints.items() if k in alive}


@dataclass(frozen=True, eq=False)
class BuildoutMemory:
    """What the build-out carries from year to year (not part of the city).

    ``layout``/``layout_ids``/``layout_lut``: the land-use layout of last
    year's units (the town units, then lots by id) and their types, for the
    types of this year's new blocks.
    """

    town: TownCalibration
    options: BuildoutOptions
    calibration: CalibrationOptions
    town_types: NDArray[np.int64]  #: (U,) simulated land-use type of each town unit
    lots: Mapping[int, LotState]  #: by lot id
    done: frozenset[tuple[int, int, int]]  #: keys of blocks built out (area, centroid, rounded to metres)
    no_build: NDArray[np.object_]  #: water and unbuildable land, in parts
    no_build_tree: shapely.STRtree
    outline_tree: shapely.STRtree  #: over ``town.outlines``
    next_lot: int = 0
    scale: HeightScale | None = None  #: last year's height scale (the substitution compares with it)
    raw: Mapping[int, float] = field(default_factory=dict)  #: raw floors of each standing building, by lot id
    layout: LotLayout | None = None
    layout_ids: tuple[int, ...] = ()
    layout_lut: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    signature: int | None = None  #: hash of last year's streets (ids, nodes, widths)
    memo: _Memo = field(default_factory=_Memo, repr=False)  #: geometry cache (no effect on results)


# ============================================================================ start


def start_buildout(city: City, history: History, rng: np.random.Generator, *,
                   options: BuildoutOptions | None = None,
                   calibration: CalibrationOptions | None = None) -> BuildoutMemory:
    """Calibrate the build-out from the town and give the old town's units their initial land use.

    Parameters
    ----------
    city : City
        The town as mapped plus the grown district, before the first year
        (no lots yet).
    history : History
        Land-use types, lot, building and economy options.
    rng : numpy.random.Generator
        Orders the old town's untagged units when they get their type.
    options : BuildoutOptions, optional
    calibration : CalibrationOptions, optional

    Returns
    -------
    BuildoutMemory
        Town units take the type of the mapped land use they lie in
        (:func:`~osm_expand.engine.buildout.landuse_osm.types_from_polygons`); the others
        the type that raises the system value most
        (:func:`~osm_expand.engine.buildout.landuse.assign_types`).

    Raises
    ------
    InputError
        The city already has lots (the build-out starts once).
    """
    if city.lots:
        raise InputError(f"start_buildout: the city already has {len(city.lots)} lots; "
                         "start the build-out once, before the first year")
    opts = options or BuildoutOptions()
    calibration = calibration or CalibrationOptions()
    town = calibrate_town(city, history, options=calibration)
    lu_opts = history.options.land_use
    lut = town.unit_real.copy()
    layout = None
    if len(lut):
        attrs = lot_attributes(town.unit_xy, centres=town.centres, extent=town.extent, water_distance=town.unit_water,
                               green_distance=town.unit_green, traffic=None, options=lu_opts)
        layout = lot_layout(town.unit_xy, town.unit_area, attrs, options=lu_opts)
        lut = assign_types(layout, lut, types=town.types, rng=rng, options=lu_opts)
    taken = city.land.taken.tolist() if city.land is not None else []  # frontage not shown empty
    parts = [g for geom in (*town.water, town.unbuildable, *taken) if geom is not None
             for g in shapely.get_parts(geom).tolist() if not g.is_empty and g.area > 0]
    no_build = np.array(parts, dtype=object)
    return BuildoutMemory(town=town, options=opts, calibration=calibration, town_types=lut, lots={}, done=frozenset(),
                          no_build=no_build, no_build_tree=shapely.STRtree(no_build),
                          outline_tree=shapely.STRtree(town.outlines), layout=layout, layout_lut=lut.copy())


# ============================================================================ the streets this year


@dataclass(frozen=True, eq=False)
class _Streets:
    """The city's streets as arrays (S,): id, centre line, carriageway, width, built, made by the tool."""

    ids: NDArray[np.int64]
    lines: NDArray[np.object_]
    carriageways: NDArray[np.object_]
    widths: NDArray[np.float64]
    built: NDArray[np.bool_]
    new: NDArray[np.bool_]
    #: ids of streets whose nodes or width changed since last year, or that are gone
    changed: frozenset[int] = frozenset()
    #: (S,) bool: streets new since last year, or whose nodes or width changed (all on the first year)
    recent: NDArray[np.bool_] | None = None
    #: the trees over ``lines`` and ``carriageways``, built in ``__post_init__``
    line_tree: shapely.STRtree = field(init=False, repr=False)
    carriageway_tree: shapely.STRtree = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "line_tree", shapely.STRtree(self.lines))
        object.__setattr__(self, "carriageway_tree", shapely.STRtree(self.carriageways))

    def only_recent(self) -> _Streets:
        """The streets that are new or changed since last year: the only ones that can have come to lie
        over a lot or building, since lots and buildings are made clear of every street there is."""
        if self.recent is None or self.recent.all():
            return self
        keep = self.recent
        return _Streets(ids=self.ids[keep], lines=self.lines[keep], carriageways=self.carriageways[keep],
                        widths=self.widths[keep], built=self.built[keep], new=self.new[keep],
                        changed=self.changed, recent=None)

    @property
    def built_ids(self) -> frozenset[int]:
        return frozenset(self.ids[self.built].tolist())


def _streets(city: City, memo: _Memo) -> tuple[_Streets, int]:
    """The streets as arrays, and a hash of their geometry (ids, nodes, widths)."""
    net = city.network
    streets = [s for s in net.streets if len(s.nodes) >= 2]
    widths = np.array([street_width(s) for s in streets], dtype=np.float64)
    lines = np.empty(len(streets), dtype=object)
    carriageways = np.empty(len(streets), dtype=object)
    fresh = []
    changed = set(memo.streets) - {s.id for s in streets}
    first = not memo.streets
    for k, (s, w) in enumerate(zip(streets, widths.tolist())):
        hit = memo.streets.get(s.id)
        if hit is not None and hit[0] == s.nodes and hit[1] == w:
            lines[k], carriageways[k] = hit[2], hit[3]
        else:
            fresh.append(k)
            if hit is not None:
                changed.add(s.id)
    recent = np.ones(len(streets), dtype=bool) if first else np.isin(np.arange(len(streets)), fresh)
    if fresh:
        sizes = np.array([len(streets[k].nodes) for k in fresh], dtype=np.int64)
        coords = net.xy[np.concatenate([np.asarray(streets[k].nodes, dtype=np.intp) for k in fresh])]
        made = shapely.linestrings(coords, indices=np.repeat(np.arange(len(fresh)), sizes))
        lines[fresh] = made
        carriageways[fresh] = shapely.buffer(made, 0.5 * widths[fresh], quad_segs=4)
    memo.streets = {s.id: (s.nodes, w, lines[k], carriageways[k])
                    for k, (s, w) in enumerate(zip(streets, widths.tolist()))}
    signature = hash(tuple((s.id, s.nodes, w) for s, w in zip(streets, widths.tolist())))
    table = _Streets(ids=np.array([s.id for s in streets], dtype=np.int64), lines=lines, carriageways=carriageways,
                     widths=widths, built=np.array([s.status == Status.BUILT for s in streets], dtype=bool),
                     new=np.array([s.is_new for s in streets], dtype=bool), changed=frozenset(changed),
                     recent=recent)
    return table, signature


# ============================================================================ demolition


def _on_streets(polys: NDArray[np.object_], streets: _Streets
                ) -> tuple[NDArray[np.bool_], NDArray[np.intp], NDArray[np.float64]]:
    """Which of ``polys`` a centre line crosses, (N,) bool, and each (polygon, carriageway) pair that
    meets: the polygon's index and the m² they share. One pass over the streets' two trees for both
    kinds of thing a widened or new street may take (lots and buildings)."""
    crossed = np.zeros(len(polys), dtype=bool)
    if not len(polys) or not len(streets.lines):
        return crossed, np.zeros(0, dtype=np.intp), np.zeros(0)
    idx, _ = streets.line_tree.query(polys, predicate="intersects")
    crossed[idx] = True
    idx, cw = streets.carriageway_tree.query(polys, predicate="intersects")
    on = shapely.area(shapely.intersection(polys[idx], streets.carriageways[cw])) if len(idx) else np.zeros(0)
    return crossed, idx, on


def _lots_hit(polys: NDArray[np.object_], streets: _Streets, overlap: float) -> NDArray[np.bool_]:
    """Lots a centre line crosses, or with more than ``overlap`` of their area on carriageways, (L,) bool."""
    hit, idx, on = _on_streets(polys, streets)
    if len(idx):
        share = np.bincount(idx, weights=on, minlength=len(polys)) / np.maximum(shapely.area(polys), 1e-9)
        hit |= share > overlap
    return hit


def _buildings_hit(polys: NDArray[np.object_], streets: _Streets, overlap: float) -> NDArray[np.bool_]:
    """Buildings (or new lots) crossed by a centre line or with more than ``overlap`` m² on a carriageway, (N,) bool."""
    hit, idx, on = _on_streets(polys, streets)
    hit[idx[on > overlap]] = True
    return hit
    idx, _ = streets.line_tree.query(polys, predicate="intersects")
    hit[idx] = True
    idx, cw = streets.carriageway_tree.query(polys, predicate="intersects")
    if len(idx):
        on = shapely.area(shapely.intersection(polys[idx], streets.carriageways[cw]))
        hit[idx[on > overlap]] = True
    return hit


def _on_carriageway(polys: NDArray[np.object_], streets: _Streets, tolerance: float = 0.05) -> NDArray[np.bool_]:
    """Polygons closer than half its width (less ``tolerance`` m) to some street's centre line, (N,) bool."""
    hit = np.zeros(len(polys), dtype=bool)
    if not len(polys) or not len(streets.lines):
        return hit
    half = 0.5 * streets.widths
    idx, line = streets.line_tree.query(polys, predicate="dwithin", distance=float(half.max()))
    close = shapely.distance(polys[idx], streets.lines[line]) < half[line] - tolerance
    hit[idx[close]] = True
    return hit


def _block_keys(blocks: Sequence[Block]) -> list[tuple[int, int, int]]:
    """Each block's identity across recomputations: area and centroid rounded to whole metres."""
    if not blocks:
        return []
    polys = np.array([b.polygon for b in blocks], dtype=object)
    area = np.rint(shapely.area(polys)).astype(np.int64)
    centre = np.rint(shapely.get_coordinates(shapely.centroid(polys))).astype(np.int64)
    return list(zip(area.tolist(), centre[:, 0].tolist(), centre[:, 1].tolist()))


def _relabel(state: LotState, streets: _Streets, tolerance: float = 1.0) -> LotState | None:
    """The lot with its street-facing edges given again to the streets they lie on, when one of its
    streets changed (moved, was split, widened or is gone); None when it fronts no street any more.

    An edge that faced a street faces the street whose centre line is nearest to its ends and its
    midpoint (the largest of the three distances), if that is at most the street's half width plus
    ``tolerance`` m (a lot's edges lie half the width from the centre line; a widened street comes
    nearer); else it faces none. Edges that faced no street keep facing none.
    """
    if not any(s in streets.changed for s in state.streets):
        return state
    ring, lab = state.lot.ring, state.lot.edge_street.copy()
    front = np.flatnonzero(lab >= 0)
    lab[front] = NO_STREET
    if len(streets.lines):
        a, b = ring[front], ring[(front + 1) % len(ring)]
        half = 0.5 * streets.widths
        mids = shapely.points(0.5 * (a + b))
        edge, cand = streets.line_tree.query(mids, predicate="dwithin", distance=float(half.max()) + tolerance)
        lines = streets.lines[cand]
        worst = np.maximum.reduce([shapely.distance(shapely.points(a[edge]), lines),
                                   shapely.distance(mids[edge], lines),
                                   shapely.distance(shapely.points(b[edge]), lines)])
        ok = worst <= half[cand] + tolerance
        edge, cand, worst = edge[ok], cand[ok], worst[ok]
        order = np.lexsort((cand, worst, edge))  # per edge, the nearest street first
        edge, cand = edge[order], cand[order]
        first = np.ones(len(edge), dtype=bool)
        first[1:] = edge[1:] != edge[:-1]
        lab[front[edge[first]]] = streets.ids[cand[first]]
    if not (lab >= 0).any():
        return None
    return replace(state, lot=Lot(ring=ring, edge_street=lab, block=state.lot.block, land_use=state.lot.land_use),
                   tried=None)


# ============================================================================ the year


@dataclass
class _Year:
    """Working state of one year (mutable, local to :func:`buildout_year`)."""

    city: City
    memory: BuildoutMemory
    history: History
    now: YearValues
    rng: np.random.Generator
    year: int
    traffic: Mapping[int, float]
    streets: _Streets
    blocks: tuple[Block, ...]
    states: dict[int, LotState]
    lot_block: dict[int, int]  #: lot id → index into ``blocks``
    buildings: dict[int, Building]  #: lot id → its generated building
    keys: list[tuple[int, int, int]]  #: each block's key (:func:`_block_keys`)
    report: BuildoutYear = field(default_factory=BuildoutYear)
    substituted: set[int] = field(default_factory=set)  #: lots whose building was replaced this year

    def footprint(self, lot_id: int) -> tuple[shapely.Polygon, float]:
        """The polygon and area (m²) of the generated building on a lot."""
        return self.memory.memo.footprint(self.buildings[lot_id])

    @property
    def town(self) -> TownCalibration:
        return self.memory.town

    def count(self, **changes: int) -> None:
        self.report = self.report + BuildoutYear(**changes)


def buildout_year(city: City, memory: BuildoutMemory, history: History, now: YearValues,
                  rng: np.random.Generator, *, year: int,
                  traffic: Mapping[int, float]) -> tuple[City, BuildoutMemory, BuildoutYear]:
    """One year of land use, lots and buildings (module docstring, steps 1–7).

    Parameters
    ----------
    city : City
        This year's city: streets (with status and width), current blocks
        (recomputed by the loop after streets changed; computed here when
        empty), last year's lots and buildings.
    memory : BuildoutMemory
        From :func:`start_buildout` or last year's call.
    history : History
        Types' economies, lot and building options, kernel options.
    now : YearValues
        This year's values (``avgprice``, ``land_use_update``).
    rng : numpy.random.Generator
        All randomness of the year (splits, setbacks, margins, noise, updates, substitution).
    year : int
        The calendar year stamped on what is built.
    traffic : mapping of int to float
        Street id → its traffic this year (daily volume; streets missing count 0).

    Returns
    -------
    city : City
        With ``lots``, the generated buildings after the town's own (those
        unchanged and in their order) and ``blocks`` carrying the land use of
        their lots.
    memory : BuildoutMemory
    report : BuildoutYear
    """
    blocks = city.blocks or tuple(find_blocks(city.network, year=year))
    streets, signature = _streets(city, memory.memo)
    unchanged = signature == memory.signature
    memory = replace(memory, signature=signature)
    ids = {int(lot.id) for lot in city.lots}
    states = {k: s for k, s in memory.lots.items() if k in ids}
    buildings = {int(b.lot): b for b in city.buildings
                 if b.origin == Origin.ENGINE and b.lot is not None and int(b.lot) in states}
    work = _Year(city=city, memory=memory, history=history, now=now, rng=rng, year=int(year), traffic=traffic,
                 streets=streets, blocks=tuple(blocks), states=states, lot_block={}, buildings=buildings,
                 keys=_block_keys(blocks))
    healing = _demolish(work, check=not unchanged)
    new_ids = _build_out_blocks(work, healing)
    units = _land_use(work)
    _substitute(work, units)
    _build(work, units)
    return _result(work, units, new_ids)


def _demolish(work: _Year, *, check: bool = True) -> set[int]:
    """Step 1 and the block matching of step 2; returns the indices of blocks that lost lots.

    With ``check`` False (the streets are last year's) nothing can have come
    under a street since, and only the block matching runs.
    """
    streets, states = work.streets, work.states
    order = sorted(states)
    polys = np.array([states[k].lot.polygon for k in order], dtype=object)
    recent = streets.only_recent() if check else streets
    crossed = _lots_hit(polys, recent, work.memory.options.street_overlap) if check \
        else np.zeros(len(order), dtype=bool)
    block_polys = np.array([b.polygon for b in work.blocks], dtype=object)
    points = shapely.points(np.array([states[k].point for k in order]).reshape(-1, 2))
    within = np.full(len(order), -1, dtype=np.int64)
    if len(order) and len(block_polys):
        pt, blk = shapely.STRtree(block_polys).query(points, predicate="within")
        within[pt] = blk
    healing: set[int] = set()
    gone = 0
    for k, lot_id, hit, blk in zip(range(len(order)), order, crossed.tolist(), within.tolist()):
        state = None if hit or blk < 0 else _relabel(states[lot_id], streets)
        if state is None:
            del states[lot_id]
            gone += 1
            if work.buildings.pop(lot_id, None) is not None:
                work.count(buildings_demolished=1)
            if blk >= 0:
                healing.add(blk)
            else:  # outside every block: heal the block its land now lies in, if any
                healing.update(_blocks_under(work, polys[k]))
            continue
        states[lot_id] = state
        work.lot_block[lot_id] = blk
    work.count(lots_demolished=gone)
    if not check:
        return healing
    lots_with = sorted(work.buildings)
    bpolys = np.array([work.footprint(k)[0] for k in lots_with], dtype=object)
    for lot_id, hit in zip(lots_with, _buildings_hit(bpolys, recent, work.memory.options.building_overlap).tolist()):
        if hit:
            del work.buildings[lot_id]
            work.count(buildings_demolished=1)
    return healing


def _blocks_under(work: _Year, poly: shapely.Polygon) -> list[int]:
    polys = [b.polygon for b in work.blocks]
    if not polys:
        return []
    return shapely.STRtree(polys).query(poly, predicate="intersects").tolist()


# ---------------------------------------------------------------------------- step 2–3: new lots


def _buildable(work: _Year) -> NDArray[np.bool_]:
    """Blocks that touch a street the tool made, (B,) bool (:func:`_free_land` keeps the town's buildings' land)."""
    new_ids = set(work.streets.ids[work.streets.new].tolist())
    return np.array([any(i in new_ids for i in b.street_ids) for b in work.blocks], dtype=bool)


def _build_out_blocks(work: _Year, healing: set[int]) -> list[int]:
    """Steps 2–3: subdivide the free land of blocks that need it; returns the new lots' ids."""
    buildable = _buildable(work)
    keys = work.keys
    todo = [k for k in range(len(work.blocks))
            if buildable[k] and (keys[k] not in work.memory.done or k in healing)]
    done = {keys[k] for k in range(len(work.blocks)) if buildable[k] and keys[k] in work.memory.done}
    done.update(keys[k] for k in todo)
    work.memory = replace(work.memory, done=frozenset(done))
    if not todo:
        return []
    by_block: dict[int, list[int]] = {}
    for lot_id, blk in work.lot_block.items():
        by_block.setdefault(blk, []).append(lot_id)
    parts, part_block = [], []
    for k in todo:
        for part in _free_land(work, k, by_block.get(k, [])):
            parts.append(part)
            part_block.append(k)
    if not parts:
        return []
    block_type = _block_types(work, todo, by_block)
    types = work.town.types
    classes = [land_use(t.lot_size_key) for t in types]
    uses = [classes[block_type[k]].value for k in part_block]
    streets = work.streets
    frontage = _with_near_streets(parts, block_frontage(parts, list(streets.lines), streets.ids, streets.widths),
                                  streets)
    made = subdivide_blocks(parts, frontage, uses, options=work.town.lot_options, rng=work.rng)
    if not made:
        work.count(blocks=len(todo))
        return []
    polys = np.array([lot.polygon for lot in made], dtype=object)
    crossed = _on_carriageway(polys, streets)  # bridges over blocks, wider streets over the block's edge
    keep = [i for i in range(len(made)) if not crossed[i] and made[i].polygon.is_valid]
    points = shapely.get_coordinates(shapely.point_on_surface(polys[keep])) if keep else np.zeros((0, 2))
    water = distance_to(points, work.town.water)
    green = distance_to(points, work.town.green)
    new_ids = []
    next_id = work.memory.next_lot
    for j, i in enumerate(keep):
        blk = part_block[made[i].block]
        lot = made[i]
        work.states[next_id] = LotState(lot=replace(lot, block=work.blocks[blk].id), type=int(block_type[blk]),
                                        year=work.year, point=(float(points[j, 0]), float(points[j, 1])),
                                        water=float(water[j]), green=float(green[j]))
        work.lot_block[next_id] = blk
        new_ids.append(next_id)
        next_id += 1
    work.memory = replace(work.memory, next_lot=next_id)
    work.count(blocks=len(todo), lots_made=len(new_ids))
    return new_ids


def _with_near_streets(parts: Sequence[shapely.Polygon], frontage: list[list[Frontage]],
                       streets: _Streets) -> list[list[Frontage]]:
    """Each part's frontage plus the whole centre line of every street whose carriageway reaches into it.

    :func:`~osm_expand.engine.buildout.lots.block_frontage` gives each boundary edge to
    the one street nearest it, so where two streets run close (a town street
    and a grown one beside it, a wide road meeting at an acute angle) the
    shrink by the frontage alone leaves land on the other one's carriageway,
    and whole lots would be lost to :func:`_on_carriageway`. The shrink takes
    these streets too; a lot edge they leave faces them.
    """
    if not len(parts) or not len(streets.lines):
        return frontage
    half = 0.5 * streets.widths
    polys = np.array(parts, dtype=object)
    part, line = streets.line_tree.query(polys, predicate="dwithin", distance=float(half.max()))
    close = shapely.distance(polys[part], streets.lines[line]) < half[line]
    out = [list(f) for f in frontage]
    for k, j in zip(part[close].tolist(), line[close].tolist()):
        out[k].append(Frontage(line=shapely.get_coordinates(streets.lines[j]), street=int(streets.ids[j]),
                               width=float(streets.widths[j])))
    return out


def _free_land(work: _Year, block: int, lots_in: Sequence[int]) -> list[shapely.Polygon]:
    """A block's land free for new lots, in parts: minus its surviving lots, water, unbuildable land and
    the land within ``town_clearance`` of the town's buildings."""
    geom = work.blocks[block].polygon
    if lots_in:
        geom = shapely.difference(geom, shapely.union_all([work.states[k].lot.polygon for k in lots_in]))
    memory = work.memory
    taken = memory.no_build[memory.no_build_tree.query(geom, predicate="intersects")].tolist()
    clearance = memory.options.town_clearance
    near = memory.outline_tree.query(geom, predicate="dwithin", distance=clearance)
    if len(near):
        taken.extend(shapely.buffer(memory.town.outlines[near], clearance, join_style="mitre").tolist())
    if taken:
        geom = shapely.difference(geom, shapely.union_all(taken))
    geom = shapely.make_valid(geom) if not geom.is_valid else geom
    return [p for p in shapely.get_parts(geom).tolist()
            if p.geom_type == "Polygon" and p.area >= memory.options.min_region]


def _block_types(work: _Year, todo: list[int], by_block: Mapping[int, list[int]]) -> dict[int, int]:
    """The land-use type of each block to subdivide (002 §4.1): its surviving lots', else the best for it."""
    types = work.town.types
    out: dict[int, int] = {}
    fresh = []
    for k in todo:
        lots_in = by_block.get(k, [])
        if lots_in:
            area = np.array([work.states[i].lot.area for i in lots_in])
            lut = np.array([work.states[i].type for i in lots_in], dtype=np.int64)
            out[k] = int(block_types(np.zeros(len(lots_in), dtype=np.int64), area, lut, 1, len(types))[0])
        else:
            fresh.append(k)
    if not fresh:
        return out
    polys = [work.blocks[k].polygon for k in fresh]
    xy = shapely.get_coordinates(shapely.point_on_surface(np.array(polys, dtype=object)))
    area = np.array([p.area for p in polys])
    memory = work.memory
    layout = memory.layout
    if layout is None or layout.n == 0:
        chosen = _by_goals(area, types)
    else:
        traffic = np.array([sum(work.traffic.get(int(i), 0.0) for i in set(work.blocks[k].street_ids) if i >= 0)
                            for k in fresh])
        attrs = _attributes(work, xy, distance_to(xy, work.town.water), distance_to(xy, work.town.green), traffic,
                            reference=_unit_traffic(work))
        chosen = choose_types(layout, memory.layout_lut, xy, area, attrs, types=types,
                              options=work.history.options.land_use)
    out.update({k: int(t) for k, t in zip(fresh, chosen.tolist())})
    return out


def _by_goals(area: NDArray[np.float64], types: Sequence) -> NDArray[np.int64]:
    """Without any lots to compare with: each unit in turn takes the type furthest below its goal."""
    goals = goal_shares(types)
    per = np.zeros(len(goals))
    out = np.empty(len(area), dtype=np.int64)
    for q, a in enumerate(area.tolist()):
        total = per.sum() + a
        t = int(np.argmin(per / total - goals))
        out[q] = t
        per[t] += a
    return out


# ---------------------------------------------------------------------------- step 4: land use


@dataclass(frozen=True, eq=False)
class _Units:
    """This year's land-use units: the town's (first ``n_town``), then the lots in ``ids`` order."""

    ids: tuple[int, ...]
    n_town: int
    area: NDArray[np.float64]
    attrs: NDArray[np.float64]
    lut: NDArray[np.int64]
    luv: NDArray[np.float64]

    def __post_init__(self) -> None:
        object.__setattr__(self, "_rows", {k: self.n_town + j for j, k in enumerate(self.ids)})

    def row(self, lot_id: int) -> int:
        """The unit row of a lot."""
        # set in __post_init__ (a frozen dataclass), so not a declared field
        return self._rows[lot_id]  # type: ignore[attr-defined]


def _lot_traffic(work: _Year, state: LotState) -> float:
    return float(sum(work.traffic.get(s, 0.0) for s in state.streets))


def _unit_traffic(work: _Year) -> NDArray[np.float64]:
    """Traffic of every unit: a town unit's nearest street's, a lot's summed over the streets it fronts (002 §4.3)."""
    town = np.array([work.traffic.get(int(s), 0.0) for s in work.town.unit_street.tolist()])
    lots = np.array([_lot_traffic(work, work.states[k]) for k in sorted(work.states)])
    return np.concatenate([town, lots])


def _attributes(work: _Year, xy: NDArray[np.float64], water: NDArray[np.float64], green: NDArray[np.float64],
                traffic: NDArray[np.float64], *, reference: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """:func:`lot_attributes` with the town's centres and extent; traffic normalised together with ``reference``."""
    town = work.town
    n = len(xy)
    tr = traffic if reference is None else np.concatenate([traffic, reference])
    if reference is not None:
        pad = len(reference)
        xy = np.vstack([xy, np.zeros((pad, 2))])
        water = np.concatenate([water, np.zeros(pad)])
        green = np.concatenate([green, np.zeros(pad)])
    attrs = lot_attributes(xy, centres=town.centres, extent=town.extent, water_distance=water,
                           green_distance=green, traffic=tr, options=work.history.options.land_use)
    return attrs[:n]


def _land_use(work: _Year) -> _Units:
    """Step 4: this year's units, their attributes and layout; the update when the history says so."""
    town, memory = work.town, work.memory
    ids = tuple(sorted(work.states))
    lots = [work.states[k] for k in ids]
    xy = np.vstack([town.unit_xy, np.array([s.point for s in lots]).reshape(-1, 2)])
    area = np.concatenate([town.unit_area, np.array([s.lot.area for s in lots])])
    water = np.concatenate([town.unit_water, np.array([s.water for s in lots])])
    green = np.concatenate([town.unit_green, np.array([s.green for s in lots])])
    attrs = _attributes(work, xy, water, green, _unit_traffic(work))
    lut = np.concatenate([memory.town_types, np.array([s.type for s in lots], dtype=np.int64)])
    lu_opts = work.history.options.land_use
    n_town = len(town.unit_xy)
    if len(lut) == 0:
        return _Units(ids, n_town, area, attrs, lut, np.zeros(0))
    if memory.layout is not None and memory.layout_ids == ids and memory.layout.n == len(lut):
        layout = replace(memory.layout, attributes=attrs)
    else:
        layout = lot_layout(xy, area, attrs, options=lu_opts)
    if work.now.land_use_update and len(lut) >= 2:
        result = update_land_use(layout, lut, types=town.types, rng=work.rng, options=lu_opts,
                                 allowed=_allowed(town, n_town, area[n_town:]))
        work.count(land_use_proposed=result.proposed, land_use_changes=int((result.lut != lut).sum()))
        lut, luv = result.lut, result.luv
    else:
        values = lot_values(layout, lut, types=town.types, options=lu_opts)
        luv = np.where(lut >= 0, values[np.arange(len(lut)), np.maximum(lut, 0)], 0.0)
    for j, k in enumerate(ids):
        t = int(lut[n_town + j])
        if t != work.states[k].type:
            work.states[k] = replace(work.states[k], type=t, tried=None)
    work.memory = replace(memory, town_types=lut[:n_town].copy(), layout=layout, layout_ids=ids,
                          layout_lut=lut.copy())
    return _Units(ids, n_town, area, attrs, lut, luv)


def _allowed(town: TownCalibration, n_town: int, lot_area: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Types each unit may take, (U + L, T): the town's units any; a lot those whose lot class's
    ``min_area``..``max_area`` holds its area, so that every type's lots keep their class's bounds."""
    types = town.types
    low = np.array([town.lot_options[land_use(t.lot_size_key)].min_area for t in types])
    high = np.array([town.lot_options[land_use(t.lot_size_key)].max_area for t in types])
    fits = (lot_area[:, None] >= low[None, :]) & (lot_area[:, None] <= high[None, :])
    return np.vstack([np.ones((n_town, len(types)), dtype=bool), fits])


# ---------------------------------------------------------------------------- step 5–6: buildings


def _economy(work: _Year, units: _Units, envelope: NDArray[np.float64], scale: HeightScale | None,
             reference_raw: NDArray[np.float64] | None = None):
    return lot_economy(units.area, envelope, units.luv, units.lut, units.attrs[:, 0], avgprice=work.now.avgprice,
                       calibration=work.town.heights, scale=scale, reference_raw=reference_raw,
                       economies=work.history.economies, rng=work.rng, options=work.history.options.economy)


def _substitute(work: _Year, units: _Units) -> None:
    """Step 5 (002 §5.4): sample replacements of the buildings on lots; replaced ones are demolished."""
    scale = work.memory.scale
    lots_with = sorted(work.buildings)
    if scale is None or not lots_with:
        return
    rows = np.array([units.row(k) for k in lots_with], dtype=np.intp)
    fp = np.array([work.footprint(k)[1] for k in lots_with])
    envelope = np.zeros(len(units.lut))
    envelope[rows] = fp
    econ = _economy(work, units, envelope, scale)
    built = np.array([work.buildings[k].year if work.buildings[k].year is not None else np.nan for k in lots_with],
                     dtype=np.float64)
    levels = np.array([work.buildings[k].levels or 0.0 for k in lots_with], dtype=np.float64)
    sub = substitute(built, econ.floors[rows] * fp, levels * fp, year=work.year, rng=work.rng,
                     options=work.history.options.economy)
    for k, replaced in zip(lots_with, sub.replaced.tolist()):
        if replaced:
            del work.buildings[k]
            work.states[k] = replace(work.states[k], tried=None)
            work.count(buildings_demolished=1)  # a replacement built below turns this into a substitution
            work.substituted.add(k)


def _build(work: _Year, units: _Units) -> None:
    """Step 6: buildings on lots near built streets, with floors and heights from the economy."""
    town = work.town
    built_ids = work.streets.built_ids
    types = town.types
    classes = [land_use(t.lot_size_key) for t in types]
    cands, keys = [], []
    for k in sorted(work.states):
        if k in work.buildings:
            continue
        state = work.states[k]
        cls = classes[state.type]
        if not town.footprint_options[cls].build:
            continue
        front = tuple(s for s in state.streets if s in built_ids)
        if not front:
            continue
        key = (state.type, front)
        if state.tried == key:
            continue
        cands.append(k)
        keys.append(key)
    if not cands:
        return
    lots = [replace(work.states[k].lot, land_use=classes[work.states[k].type].value) for k in cands]
    footprints = place_buildings(lots, traffic_per_street=work.traffic, built_streets=built_ids,
                                 options=_bands(work, [classes[work.states[k].type] for k in cands], classes),
                                 rng=work.rng, sizes=town.sizes,
                                 obstacles=_obstacles(work, lots), resolution=work.memory.options.resolution)
    placed = {fp.lot: fp for fp in footprints}
    for i, (k, key) in enumerate(zip(cands, keys)):
        if i not in placed:
            work.states[k] = replace(work.states[k], tried=key)
    if not footprints:
        return
    rows = np.array([units.row(cands[fp.lot]) for fp in footprints], dtype=np.intp)
    envelope = np.zeros(len(units.lut))
    envelope[rows] = [fp.rectangle.area for fp in footprints]
    raw = work.memory.raw
    standing = np.array([raw[k] for k in sorted(work.buildings) if k in raw], dtype=np.float64)
    econ = _economy(work, units, envelope, None, reference_raw=standing)  # the scale of the whole stock
    work.memory = replace(work.memory, scale=econ.scale)
    raw = dict(raw)
    for fp, row in zip(footprints, rows.tolist()):
        floors = int(econ.floors[row])
        if floors <= 0:
            continue
        k = cands[fp.lot]
        ring = np.vstack([fp.rectangle.corners, fp.rectangle.corners[:1]])
        work.buildings[k] = Building(rings=(ring,), height=float(econ.height[row]), levels=float(floors),
                                     origin=Origin.ENGINE, year=work.year, land_use=types[work.states[k].type].name,
                                     lot=k)
        raw[k] = float(econ.raw[row])
        if k in work.substituted:
            work.count(buildings_substituted=1, buildings_demolished=-1)
        work.count(buildings_built=1)
    work.memory = replace(work.memory, raw=raw)


def _bands(work: _Year, candidates: Sequence[LandUse], classes: Sequence[LandUse]) -> dict:
    """Footprint options with this year's size bands (:func:`~osm_expand.engine.buildout.calibration.size_bands`).

    The bands are stacked by the buildings standing and about to be built,
    per lot class, plus ``band_prior`` buildings in the expected shares, so
    that the generated buildings together keep the town's footprint
    distribution while a small year's few keep the expected bands.
    """
    town, opts = work.town, work.memory.options
    if not (town.sizes.count and work.memory.calibration.size_bands):
        return dict(town.footprint_options)
    counts = {c: opts.band_prior * v for c, v in town.building_shares.items()}
    index = {t.name: k for k, t in enumerate(town.types)}
    for b in work.buildings.values():
        k = index.get(b.land_use or "")
        if k is not None:
            counts[classes[k]] = counts.get(classes[k], 0.0) + 1.0
    for c in candidates:
        counts[c] = counts.get(c, 0.0) + 1.0
    return size_bands(counts, town.footprint_options, overlap=work.memory.calibration.band_overlap)


def _obstacles(work: _Year, lots: Sequence[Lot]) -> list[shapely.Geometry]:
    """What no new building may touch near these lots: carriageways, the town's buildings (as the XML draws
    them), the generated buildings standing."""
    polys = np.array([lot.polygon for lot in lots], dtype=object)
    streets, memory = work.streets, work.memory
    _, cw = streets.carriageway_tree.query(polys, predicate="intersects")
    out = streets.carriageways[np.unique(cw)].tolist()
    if len(memory.town.outlines):
        _, near = memory.outline_tree.query(polys, predicate="intersects")
        out.extend(memory.town.outlines[np.unique(near)].tolist())
    mine = sorted(work.buildings)
    if mine:
        footprints = np.array([work.footprint(k)[0] for k in mine], dtype=object)
        near = np.unique(shapely.STRtree(footprints).query(polys, predicate="intersects")[1])
        out.extend(footprints[near].tolist())
    return out


# ---------------------------------------------------------------------------- step 7 and the result


def _result(work: _Year, units: _Units, new_ids: list[int]) -> tuple[City, BuildoutMemory, BuildoutYear]:
    """Step 7: people per lot, the city's lots, buildings and blocks; the memory for next year."""
    types = work.town.types
    ids = units.ids
    fs = np.array([(work.buildings[k].levels or 0.0) * work.footprint(k)[1] if k in work.buildings else np.nan
                   for k in ids])
    lot_area = np.array([work.states[k].lot.area for k in ids])
    lut = np.array([work.states[k].type for k in ids], dtype=np.int64)
    if ids:  # a lot without a building counts the people its land use expects there (002 §3.2, §4)
        expected = expected_floor_space(units.area, units.luv, units.lut, work.now.avgprice,
                                        economies=work.history.economies)[units.n_town:]
        fs = np.where(np.isnan(fs), expected, fs)
    people = occupants(fs, lot_area, lut, economies=work.history.economies).people if ids else np.zeros(0)
    built_ids = work.streets.built_ids
    blocks = work.blocks
    lots = []
    for j, k in enumerate(ids):
        state = work.states[k]
        lots.append(state.lot.placed(block=int(blocks[work.lot_block[k]].id), street=_access(work, state, built_ids),
                                     land_use=types[state.type].name, people=float(people[j]), id=k,
                                     year=state.year))
    generated = [work.buildings[k] for k in sorted(work.buildings)]
    kept = [b for b in work.city.buildings
            if not (b.origin == Origin.ENGINE and b.lot is not None and int(b.lot) in work.memory.lots)]
    block_lut = block_types(np.array([work.lot_block[k] for k in ids], dtype=np.int64), lot_area, lut,
                            len(blocks), len(types)) if ids else np.full(len(blocks), UNASSIGNED)
    blocks = tuple(replace(b, land_use=types[int(t)].name) if t >= 0 else b for b, t in zip(blocks, block_lut))
    city = work.city.replace(lots=tuple(lots), buildings=tuple(kept + generated), blocks=blocks)
    work.memory.memo.keep_footprints(generated)
    raw = {k: v for k, v in work.memory.raw.items() if k in work.buildings}  # demolished and replaced ones go
    memory = replace(work.memory, lots=dict(work.states), raw=raw)
    return city, memory, work.report


def _access(work: _Year, state: LotState, built: frozenset[int]) -> int:
    """The street a lot faces: built first, then the busiest, then the longest frontage, then the lowest id."""
    frontage = state.frontage
    return int(max(state.streets, key=lambda s: (s in built, work.traffic.get(s, 0.0), frontage[s], -s)))


# ============================================================================ helpers for the loop


def town_people(memory: BuildoutMemory, history: History) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The old town's people for the trip model: position (U, 2) and people (U,) per town unit.

    Floor space (footprint × storeys from the tags or the town's median
    height) over the floor space per person of the unit's current type
    (:func:`~osm_expand.engine.buildout.economy.occupants`), plus visitors of parks.
    The trip model reads ``Lot.people`` of the generated lots; the old town
    has no lots, so the loop adds these at each unit's nearest street
    (``TownCalibration.unit_street``).
    """
    town = memory.town
    occ = occupants(town.unit_floor_space, town.unit_area, memory.town_types, economies=history.economies)
    return town.unit_xy, occ.people
