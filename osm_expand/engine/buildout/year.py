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

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from osm_expand.blocks import blocks as find_blocks
from osm_expand.engine.buildout.buildings import _build, _substitute
from osm_expand.engine.buildout.demolition import _demolish
from osm_expand.engine.buildout.economy import expected_floor_space, occupants
from osm_expand.engine.buildout.land_use_step import _land_use
from osm_expand.engine.buildout.landuse import block_types
from osm_expand.engine.buildout.landuse_types import UNASSIGNED
from osm_expand.engine.buildout.memory import (  # re-exported
    BuildoutMemory,
    BuildoutOptions,
    BuildoutYear,
    LotState,
    start_buildout,
    town_people,
)
from osm_expand.engine.buildout.new_lots import _build_out_blocks
from osm_expand.engine.buildout.report import buildout_report  # re-exported
from osm_expand.engine.buildout.streets import _block_keys, _streets
from osm_expand.engine.buildout.work import _Units, _Year
from osm_expand.engine.history import History, YearValues
from osm_expand.model import City, Lot, Origin

__all__ = ["BuildoutMemory", "BuildoutOptions", "BuildoutYear", "LotState", "buildout_report", "buildout_year",
           "start_buildout", "town_people"]


# ============================================================================ the year


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
    streets, signature = _streets(city, memory.memo, memory.signature)
    unchanged = signature == memory.signature
    memory = replace(memory, signature=signature)
    ids = {int(lot.id) for lot in city.lots}
    states = {k: s for k, s in memory.lots.items() if k in ids}
    buildings = {int(b.lot): b for b in city.buildings
                 if b.origin == Origin.ENGINE and b.lot is not None and int(b.lot) in states}
    work = _Year(city=city, memory=memory, history=history, now=now, rng=rng, year=int(year), traffic=traffic,
                 streets=streets, blocks=tuple(blocks), states=states, lot_block={}, buildings=buildings,
                 keys=_block_keys(blocks, memory.memo))
    healing = _demolish(work, check=not unchanged)
    new_ids = _build_out_blocks(work, healing)
    units = _land_use(work)
    _substitute(work, units)
    _build(work, units)
    return _result(work, units, new_ids)


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
    lots = _placed(work, ids, people.tolist())
    blocks = work.blocks
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


def _placed(work: _Year, ids: tuple[int, ...], people: list[float]) -> list[Lot]:
    """The lots as the city holds them this year, in ``ids`` order: last year's object where the state's lot
    and every field the year sets are the same (most lots: a new one per lot per year was O(all lots) a year,
    619,449 of them in Krems' 150 north-american years)."""
    types, built_ids, blocks = work.town.types, work.streets.built_ids, work.blocks
    last = work.memory.memo.placed
    kept: dict[int, tuple[Lot, Lot]] = {}
    out = []
    for k, n in zip(ids, people):
        state = work.states[k]
        block, street = int(blocks[work.lot_block[k]].id), _access(work, state, built_ids)
        name = types[state.type].name
        hit = last.get(k)
        if hit is not None and hit[0] is state.lot:
            lot = hit[1]
            if not (lot.block == block and lot.street == street and lot.land_use == name and lot.people == n
                    and lot.year == state.year):
                lot = state.lot.placed(block=block, street=street, land_use=name, people=n, id=k, year=state.year)
        else:
            lot = state.lot.placed(block=block, street=street, land_use=name, people=n, id=k, year=state.year)
        kept[k] = (state.lot, lot)
        out.append(lot)
    work.memory.memo.placed = kept
    return out


def _access(work: _Year, state: LotState, built: frozenset[int]) -> int:
    """The street a lot faces: built first, then the busiest, then the longest frontage, then the lowest id.

    A lot that fronts one street faces it (most lots: no frontage to measure)."""
    if len(state.streets) == 1:
        return state.streets[0]
    frontage = state.frontage
    return int(max(state.streets, key=lambda s: (s in built, work.traffic.get(s, 0.0), frontage[s], -s)))
