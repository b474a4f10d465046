"""What the build-out carries from year to year (:class:`BuildoutMemory`), how it starts
(:func:`start_buildout`: the town's calibration and its units' first land use), its options and
its yearly report; and the old town's people the trip model reads (:func:`town_people`).

The year itself is :func:`osm_expand.engine.buildout.year.buildout_year`.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.calibration import CalibrationOptions, TownCalibration, calibrate_town
from osm_expand.engine.buildout.economy import HeightScale, occupants
from osm_expand.engine.buildout.landuse import assign_types
from osm_expand.engine.buildout.lot_values import LotLayout, lot_attributes, lot_layout
from osm_expand.engine.history import History
from osm_expand.errors import InputError
from osm_expand.model import Building, City, Lot
from osm_expand.model.memo import replace_keeping
from osm_expand.model.options import require_positive


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


#: One street as the build-out saw it: id, nodes, width (m). A year's streets in order are its signature.
StreetKey = tuple[int, tuple[int, ...], float]


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

    def but(self, **changes: object) -> LotState:
        """``dataclasses.replace(self, **changes)`` for changes that keep the lot (its type, ``tried``): its
        streets and frontage, once measured, come along, as they depend on the lot alone (a lot whose
        type changed measured its frontage again the next time its access was asked: 7,000 times in
        Campo Grande's 30 years)."""
        if "lot" in changes:
            raise ValueError("LotState.but keeps the lot; replace it with dataclasses.replace")
        return replace_keeping(self, ("streets", "frontage"), **changes)


class _Memo:
    """Geometry the build-out would otherwise rebuild every year: a cache, never a source of results.

    ``footprints``: a generated building's polygon and area by the building
    object's id (checked against the object); ``streets``: each street's
    centre line and carriageway by id, with the nodes and width they were
    made from; ``block_keys``: a block polygon's key
    (:func:`~osm_expand.engine.buildout.streets._block_keys`) by the polygon
    object's id (checked against the object: the blocks keep the polygons of
    faces that did not change, so a year computes the keys of its new blocks
    only); ``lot_blocks``: the block polygon each lot's point was found
    within (checked against the lot's point and this year's blocks by object).

    Every memory made from another by ``dataclasses.replace`` shares its memo, so an entry may come
    from a later year than the memory's: each is checked against what it was made from and none
    says what changed since last year (that is ``BuildoutMemory.signature``). ``placed``: the lot each
    lot id was last handed to the city as, with the state's lot it was made from (checked against that
    object and every field the year sets: most lots keep last year's block, street, type and people).
    """

    def __init__(self) -> None:
        self.footprints: dict[int, tuple[Building, shapely.Polygon, float]] = {}
        self.streets: dict[int, tuple[tuple[int, ...], float, shapely.Geometry, shapely.Geometry]] = {}
        self.block_keys: dict[int, tuple[shapely.Polygon, tuple[int, int, int]]] = {}
        #: lot id → (the lot's point, the block polygon it was last found within)
        #: (:func:`~osm_expand.engine.buildout.demolition._lot_blocks`)
        self.lot_blocks: dict[int, tuple[tuple[float, float], shapely.Polygon]] = {}
        #: lot id → (the state's lot, the lot as the city last held it)
        #: (:func:`~osm_expand.engine.buildout.year._placed`)
        self.placed: dict[int, tuple[Lot, Lot]] = {}

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
    #: last year's streets in order: id, nodes, width (m) of each. It decides the year: the same
    #: streets skip the demolition check, and only new or changed ones are tried against the lots.
    signature: tuple[StreetKey, ...] | None = None
    #: geometry cache shared with the memories made from this one; it never decides a result
    #: (each entry is checked against what it was made from)
    memo: _Memo = field(default_factory=_Memo, repr=False)


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
    # every part at once (one by one in Python: 2 s of a 10,000-street town's start), in the same order
    parts = shapely.get_parts(np.array([g for g in (*town.water, town.unbuildable, *taken) if g is not None],
                                       dtype=object))
    no_build = parts[~shapely.is_empty(parts) & (shapely.area(parts) > 0)]
    return BuildoutMemory(town=town, options=opts, calibration=calibration, town_types=lut, lots={}, done=frozenset(),
                          no_build=no_build, no_build_tree=shapely.STRtree(no_build),
                          outline_tree=shapely.STRtree(town.outlines), layout=layout, layout_lut=lut.copy())


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
