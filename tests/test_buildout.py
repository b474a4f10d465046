"""The build-out (issue 11): land use, lots and buildings filled into grown districts, year after year.

Real towns are expanded (the pipeline's district), all streets are marked
built, blocks recomputed, and a few years run with synthetic traffic (by
highway class). The checks are the issue's: every building in its lot, every
lot in its block and on a street, nothing overlapping or on a street centre
line, positive heights, ≥ 50 buildings, the town's own buildings untouched,
shares near the goals, footprints like the town's; demolition under a new
street and healing; substitution dating; the outputs.
"""
from __future__ import annotations

import functools
import json
import math
from dataclasses import replace

import numpy as np
import osmium
import pytest
import shapely
from lxml import etree

from osm_expand.blocks import blocks
from osm_expand.engine.buildout.calibration import CalibrationOptions, find_centres, tag_number, town_units
from osm_expand.engine.buildout.report import ReportOptions
from osm_expand.engine.buildout.year import (
    BuildoutOptions,
    BuildoutYear,
    buildout_report,
    buildout_year,
    start_buildout,
    town_people,
)
from osm_expand.engine.history import load_history
from osm_expand.errors import InputError
from osm_expand.export import write_geojson, write_osm, write_urbanenvironment
from osm_expand.export.preview import write_preview
from osm_expand.export.urban import validate
from osm_expand.ingest import load
from osm_expand.model import Building, Lot, Origin, Status
from osm_expand.model.highways import rank
from osm_expand.model.segments import street_width
from osm_expand.pipeline import ExpandOptions, expand
from tests.conftest import FIXTURES

TOWNS = ["krems.osm.gz", "andorra.osm.pbf"]
#: Daily traffic by highway rank (motorway … tertiary), residential streets and the rest: a town's spread.
TRAFFIC = {0: 20000.0, 1: 15000.0, 2: 8000.0, 3: 4000.0, 4: 2000.0}
YEARS = 4


def synthetic_traffic(city) -> dict[int, float]:
    return {s.id: TRAFFIC.get(int(rank(s.highway)), 300.0) for s in city.network.streets}


def with_blocks(city, year):
    return city.replace(blocks=tuple(blocks(city.network, year=year)))


@functools.cache
def expanded(name: str):
    """The town as mapped plus its grown district, every street built, blocks recomputed."""
    city = expand(load(FIXTURES / name), ExpandOptions(seed=0, fidelity=False)).city
    net = city.network.replace(streets=tuple(replace(s, status=Status.BUILT) for s in city.network.streets))
    return with_blocks(city.replace(network=net), city.year)


def run(city, history, memory, rng, years, first):
    reports = []
    clock = history.clock(first)
    for step in range(years):
        now = history.values_at(clock.history_year(step))
        city, memory, report = buildout_year(city, memory, history, now, rng, year=clock.calendar_year(step),
                                             traffic=synthetic_traffic(city))
        reports.append(report)
    return city, memory, reports


@functools.cache
def built_out(name: str, seed: int = 7):
    start = expanded(name)
    history = load_history("example")
    rng = np.random.default_rng(seed)
    memory = start_buildout(start, history, rng)
    city, memory, reports = run(start, history, memory, rng, YEARS, start.year)
    return start, city, memory, history, reports


def generated(city) -> list[Building]:
    return [b for b in city.buildings if b.origin == Origin.ENGINE]


# --------------------------------------------------------------------------- geometry of what is built


@pytest.mark.parametrize("name", TOWNS)
def test_every_building_stands_in_its_lot_and_every_lot_in_its_block(name):
    _, city, _, _, _ = built_out(name)
    lots = {lot.id: lot for lot in city.lots}
    by_id = {b.id: b for b in city.blocks}
    assert len(lots) == len(city.lots)
    for b in generated(city):
        assert lots[b.lot].polygon.buffer(1e-6).covers(b.polygon)
    for lot in city.lots:
        assert by_id[lot.block].polygon.buffer(1e-6).covers(lot.polygon)
    polys = [lot.polygon for lot in city.lots]
    left, right = shapely.STRtree(polys).query(polys, predicate="intersects")
    assert all(polys[i].intersection(polys[j]).area < 0.01 for i, j in zip(left, right) if i < j)


@pytest.mark.parametrize("name", TOWNS)
def test_every_lot_touches_the_street_it_faces_and_keeps_off_every_carriageway(name):
    _, city, _, _, _ = built_out(name)
    net = city.network
    street = {s.id: s for s in net.streets}
    lines = np.array([shapely.LineString(net.street_xy(s)) for s in net.streets], dtype=object)
    half = np.array([0.5 * street_width(s) for s in net.streets])
    for lot in city.lots:
        s = street[lot.street]
        gap = lot.polygon.distance(shapely.LineString(net.street_xy(s)))
        assert 0.5 * street_width(s) - 0.05 <= gap <= 0.5 * street_width(s) * 1.01 + 0.3, lot.id
    polys = np.array([lot.polygon for lot in city.lots], dtype=object)
    lot_idx, line_idx = shapely.STRtree(lines).query(polys, predicate="dwithin", distance=half.max())
    gaps = shapely.distance(polys[lot_idx], lines[line_idx])
    assert (gaps >= half[line_idx] - 0.05).all()  # no lot on any street's carriageway


@pytest.mark.parametrize("name", TOWNS)
def test_no_generated_building_overlaps_another_or_stands_on_a_street(name):
    _, city, _, _, _ = built_out(name)
    polys = [b.polygon for b in city.buildings]
    outlines = [shapely.oriented_envelope(p) for p in polys]  # the town's as the XML draws them
    ours = [b.origin == Origin.ENGINE for b in city.buildings]
    left, right = shapely.STRtree(outlines).query(outlines, predicate="intersects")
    overlaps = [(i, j) for i, j in zip(left, right)
                if i < j and (ours[i] or ours[j]) and outlines[i].intersection(outlines[j]).area > 0.5]
    assert overlaps == []
    net = city.network
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    mine = np.array([p for p, o in zip(polys, ours) if o], dtype=object)
    assert len(shapely.STRtree(mine).query(lines, predicate="intersects")[0]) == 0


@pytest.mark.parametrize("name", TOWNS)
def test_buildings_are_rectangles_with_positive_heights_of_whole_storeys(name):
    _, city, memory, _, _ = built_out(name)
    new = generated(city)
    # the pipeline's district alone, four years: the issue's ≥ 50 is measured on the 50-year runs
    # of every history (benchmarks/buildout_check.py, docs/buildout.md)
    assert len(new) >= 40
    storey = memory.town.heights.storey_height
    for b in new:
        ring = b.ring[:4]
        sides = np.roll(ring, -1, axis=0) - ring
        lengths = np.hypot(*sides.T)
        cos = np.abs((sides * np.roll(sides, -1, axis=0)).sum(axis=1)) / (lengths * np.roll(lengths, -1))
        assert cos.max() < 1e-6 and lengths.max() <= 2.0 * lengths.min() + 1e-6  # 004's 1:2
        assert b.height > 0 and b.levels >= 1 and b.height == pytest.approx(b.levels * storey)
        assert b.osm_id == 0 and b.land_use and b.year is not None


@pytest.mark.parametrize("name", TOWNS)
def test_the_towns_own_buildings_and_blocks_are_untouched(name):
    start, city, memory, _, _ = built_out(name)
    town = [b for b in start.buildings if b.origin == Origin.SOURCE]
    assert city.buildings[:len(town)] == tuple(town) and all(a is b for a, b in zip(city.buildings, town))
    assert len(city.buildings) == len(town) + len(generated(city))
    assert [b.osm_id for b in city.buildings[:len(town)]] == [b.osm_id for b in town]
    # every lot keeps the clearance from the town's buildings (their rectangles, as the XML draws them)
    clearance = memory.options.town_clearance
    lot_polys = [lot.polygon for lot in city.lots]
    near = shapely.STRtree(memory.town.outlines).query(lot_polys, predicate="dwithin", distance=clearance - 0.01)
    assert not len(near[0])


def test_a_new_block_around_a_town_building_is_built_out_beyond_its_clearance():
    start, city, _, history, _ = built_out("krems.osm.gz")
    block = max((b for b in city.blocks if any(lot.block == b.id for lot in city.lots)),
                key=lambda b: (b.polygon.area, -b.id))
    c = np.asarray(block.polygon.point_on_surface().coords[0])
    ring = c + np.array([[-6.0, -5.0], [6.0, -5.0], [6.0, 5.0], [-6.0, 5.0], [-6.0, -5.0]])
    farm = Building(rings=(ring,), height=6.0, osm_id=-99)  # a farmhouse of the town the district grew around
    mixed = start.replace(buildings=start.buildings + (farm,))
    rng = np.random.default_rng(2)
    memory = start_buildout(mixed, history, rng)
    after, memory, _ = run(mixed, history, memory, rng, 1, start.year)
    assert any(b is farm for b in after.buildings)  # the town's building stays, untouched
    holder = next(b for b in after.blocks if b.polygon.contains(shapely.Point(c)))
    inside = [lot for lot in after.lots if lot.block == holder.id]
    assert inside  # the block is built out
    clearance = memory.options.town_clearance
    outline = shapely.Polygon(ring).minimum_rotated_rectangle
    assert min(lot.polygon.distance(outline) for lot in after.lots) >= clearance - 0.01
    assert not any(b.polygon.distance(outline) < clearance for b in generated(after))


def test_a_lot_state_changed_but_its_lot_keeps_its_measured_streets_and_frontage():
    """``LotState.but`` is ``dataclasses.replace`` for a new type or ``tried``, and the streets and
    frontage measured on the lot come along (the same objects); changing the lot itself is refused."""
    from osm_expand.engine.buildout.lots import NO_STREET
    from osm_expand.engine.buildout.lots import Lot as EngineLot
    from osm_expand.engine.buildout.memory import LotState

    lot = EngineLot(ring=np.array([[0.0, 3.75], [20.0, 3.75], [20.0, 33.75], [0.0, 33.75]]),
                    edge_street=np.array([1, 2, NO_STREET, 1]))
    state = LotState(lot=lot, type=0, year=2000, point=(10.0, 20.0), water=1000.0, green=1000.0)
    fresh = state.but(type=2, tried=(2, (1,)))
    assert "frontage" not in fresh.__dict__ and fresh.frontage == {1: 50.0, 2: 30.0}  # not measured yet: measured
    measured = state.frontage
    kept = state.but(type=1, tried=None)
    assert kept.__dict__["frontage"] is measured and kept.__dict__["streets"] is state.streets
    expected = replace(state, type=1, tried=None)
    for name in ("lot", "type", "year", "point", "water", "green", "tried"):
        assert getattr(kept, name) == getattr(expected, name)
    assert kept.frontage == expected.frontage and kept.streets == expected.streets
    with pytest.raises(ValueError):
        state.but(lot=lot)


def test_a_lot_whose_street_changed_faces_the_street_its_edge_lies_on():
    from osm_expand.engine.buildout.lots import NO_STREET
    from osm_expand.engine.buildout.lots import Lot as EngineLot
    from osm_expand.engine.buildout.memory import LotState
    from osm_expand.engine.buildout.streets import _relabel, _Streets

    # a 20 m × 30 m lot behind a 7.5 m street along y = 0 (its front edge 3.75 m from the centre line)
    lot = EngineLot(ring=np.array([[0.0, 3.75], [20.0, 3.75], [20.0, 33.75], [0.0, 33.75]]),
                    edge_street=np.array([1, NO_STREET, NO_STREET, NO_STREET]))
    state = LotState(lot=lot, type=0, year=2000, point=(10.0, 20.0), water=1000.0, green=1000.0)

    def streets(lines: dict[int, list], widths: dict[int, float], changed: set[int]) -> _Streets:
        ids = sorted(lines)
        geoms = np.array([shapely.LineString(lines[i]) for i in ids], dtype=object)
        w = np.array([widths[i] for i in ids])
        return _Streets(ids=np.array(ids), lines=geoms, carriageways=shapely.buffer(geoms, w / 2), widths=w,
                        built=np.ones(len(ids), bool), new=np.ones(len(ids), bool), changed=frozenset(changed))

    along = [(-50.0, 0.0), (70.0, 0.0)]
    assert _relabel(state, streets({1: along}, {1: 7.5}, set())) is state  # nothing changed
    split = _relabel(state, streets({1: [(-50.0, 0.0), (-5.0, 0.0)], 2: [(-5.0, 0.0), (70.0, 0.0)]},
                                    {1: 7.5, 2: 7.5}, {1}))
    assert split.lot.edge_street.tolist() == [2, NO_STREET, NO_STREET, NO_STREET]  # split: the part in front
    widened = _relabel(state, streets({1: along}, {1: 11.0}, {1}))
    assert widened.lot.edge_street.tolist() == [1, NO_STREET, NO_STREET, NO_STREET]
    moved = streets({1: [(-50.0, -60.0), (70.0, -60.0)], 3: [(-3.75, -50.0), (-3.75, 80.0)]}, {1: 7.5, 3: 7.5}, {1})
    assert _relabel(state, moved) is None  # its street moved away; a street along its side gives no access
    renumbered = _relabel(state, streets({4: along}, {4: 7.5}, {1}))
    assert renumbered.lot.streets.tolist() == [4]


@pytest.mark.parametrize("name", TOWNS)
def test_lots_face_streets_the_tool_made_and_carry_types_people_and_years(name):
    start, city, memory, history, _ = built_out(name)
    new_ids = {s.id for s in city.network.streets if s.is_new}
    by_id = {b.id: b for b in city.blocks}
    names = {t.name for t in history.land_use_types}
    for lot in city.lots:
        assert new_ids & set(by_id[lot.block].street_ids)
        assert lot.land_use in names and lot.year == start.year and lot.people >= 0
    with_building = {b.lot for b in generated(city)}
    housed = [lot for lot in city.lots if lot.id in with_building and lot.land_use.startswith("residential")]
    assert housed and all(lot.people > 0 for lot in housed)
    assert {b.land_use for b in city.blocks if b.land_use} <= names
    assert any(b.land_use for b in city.blocks)


@pytest.mark.parametrize("name", TOWNS)
def test_shares_end_near_the_goals_and_footprints_look_like_the_towns(name):
    _, city, memory, history, reports = built_out(name)
    report = buildout_report(city, memory, history)
    json.dumps(report)
    assert report["land_use"]["max_share_deviation"] <= 0.05
    sizes = report["buildings"]["footprint_median_m2"]
    assert abs(sizes["generated"] / sizes["town"] - 1) <= 0.25
    assert report["buildings"]["height_median_m"]["generated"] == pytest.approx(
        report["buildings"]["height_median_m"]["target"], rel=0.25)
    for name_, row in report["lots"]["types"].items():
        if row["count"]:
            low, high = row["bounds_m2"]
            q = row["area_quartiles_m2"]
            assert low <= q[0] <= q[2] <= high * 1.5, name_  # a lot no split could halve stays bigger (rare)
    assert report["lots"]["count"] == len(city.lots) and report["buildings"]["generated"] == len(generated(city))
    total = sum(reports, BuildoutYear())
    assert total.lots_made - total.lots_demolished == len(city.lots)
    assert total.land_use_proposed > 0


def test_the_similarity_check_is_reported_where_the_town_maps_its_land_use():
    _, city, memory, history, _ = built_out("krems.osm.gz")
    sim = buildout_report(city, memory, history)["similarity"]
    assert sim is not None and 0 <= sim["shuffled"] <= 1 and 0 <= sim["simulated"] <= 1
    assert sim["simulated"] > sim["shuffled"]  # the valuations keep more of the real pattern than chance


def test_a_report_not_judged_leaves_the_similarity_out_and_the_rest_the_same():
    _, city, memory, history, _ = built_out("krems.osm.gz")
    judged = buildout_report(city, memory, history)
    counted = buildout_report(city, memory, history, options=ReportOptions(similarity=False))
    assert judged["similarity"] is not None and counted["similarity"] is None
    assert {k: v for k, v in judged.items() if k != "similarity"} == {k: v for k, v in counted.items()
                                                                       if k != "similarity"}


# --------------------------------------------------------------------------- the years


def insert_node(net, street_index: int, point: np.ndarray):
    """The network with ``point`` inserted into street ``street_index`` on its nearest segment; its node index."""
    s = net.streets[street_index]
    xy = net.street_xy(s)
    line = shapely.LineString(xy)
    at = line.project(shapely.Point(point))
    cum = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    k = int(np.clip(np.searchsorted(cum, at) - 1, 0, len(xy) - 2))
    new = len(net.xy)
    nodes = s.nodes[:k + 1] + (new,) + s.nodes[k + 1:]
    streets = list(net.streets)
    streets[street_index] = replace(s, nodes=nodes)
    return net.replace(xy=np.vstack([net.xy, point]), node_ids=np.append(net.node_ids, 0),
                       streets=tuple(streets)), new


def street_across(city, lot: Lot):
    """A new engine street across ``lot``'s block through the lot, joined to the block's streets at both ends."""
    net = city.network
    block = next(b for b in city.blocks if b.id == lot.block)
    centre = np.asarray(lot.polygon.centroid.coords[0])
    axis = np.asarray(block.polygon.centroid.coords[0]) - centre
    axis = np.array([-axis[1], axis[0]]) / max(np.hypot(*axis), 1e-9)  # across the block, through the lot
    far = 10 * math.sqrt(block.polygon.area)
    cut = shapely.LineString([centre - far * axis, centre + far * axis]).intersection(block.polygon.exterior)
    pts = sorted((np.asarray(p.coords[0]) for p in shapely.get_parts(cut)), key=lambda p: float((p - centre) @ axis))
    a, b = pts[0], pts[-1]
    index = {s.id: k for k, s in enumerate(net.streets)}
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    ends = []
    for p in (a, b):
        k = min((index[i] for i in set(block.street_ids) if i in index), key=lambda k: lines[k].distance(shapely.Point(p)))
        net, node = insert_node(net, k, p)
        ends.append(net.xy[node])
    net = net.with_new_streets([np.array(ends)], [{"origin": Origin.ENGINE, "year": city.year + 10,
                                                   "highway": "residential", "status": Status.BUILT}])
    return city.replace(network=net), shapely.LineString(ends)


@pytest.mark.parametrize("name", TOWNS)
def test_a_street_across_built_lots_demolishes_them_and_the_land_heals(name):
    start, city, memory, history, _ = built_out(name)
    built = sorted((lot for lot in city.lots if lot.id in {b.lot for b in generated(city)}),
                   key=lambda lot: (-next(b for b in city.blocks if b.id == lot.block).polygon.area, lot.id))
    # the biggest block whose crossing street stays inside it (in a bent block it would cross the
    # neighbours' streets without junctions, and no longer be a street across one block)
    for target in built:
        cut, line = street_across(city, target)
        if next(b for b in city.blocks if b.id == target.block).polygon.buffer(1.0).covers(line):
            break
    cut = with_blocks(cut, city.year + 10)
    assert len(cut.blocks) > len(city.blocks)  # the new street splits the block
    rng = np.random.default_rng(3)
    now = history.values_at(history.clock(start.year).history_year(YEARS))
    after, _, report = buildout_year(cut, memory, history, now, rng, year=start.year + 10,
                                     traffic=synthetic_traffic(cut))
    crossed = {lot.id for lot in city.lots if lot.polygon.intersects(line)}
    assert target.id in crossed and report.lots_demolished >= len(crossed)
    assert not crossed & {lot.id for lot in after.lots}
    assert not crossed & {b.lot for b in generated(after)}
    assert report.lots_made > 0 and report.blocks >= 2  # both halves heal
    assert all(lot.year == start.year + 10 for lot in after.lots if lot.id >= memory.next_lot)
    assert not any(lot.polygon.intersects(line) for lot in after.lots)
    assert not any(b.polygon.intersects(line) for b in generated(after))
    untouched = {lot.id for lot in city.lots} - crossed
    assert untouched <= {lot.id for lot in after.lots} | {lot.id for lot in city.lots if lot.block == target.block}


def test_substituted_buildings_carry_the_year_they_are_built():
    start, city, memory, history, _ = built_out("krems.osm.gz")
    eager = replace(history.options.economy, age_weight=1.0, age_bounds=(0.0, 1.0))  # every aged building goes
    history = replace(history, options=replace(history.options, economy=eager))
    year = start.year + 30
    now = history.values_at(history.clock(start.year).history_year(YEARS))
    after, _, report = buildout_year(city, memory, history, now, np.random.default_rng(5), year=year,
                                     traffic=synthetic_traffic(city))
    assert report.buildings_substituted > 0
    before = {b.lot: b for b in generated(city)}
    renewed = [b for b in generated(after) if b.lot in before and b is not before[b.lot]]
    assert len(renewed) == report.buildings_substituted and all(b.year == year for b in renewed)
    kept = [b for b in generated(after) if b.lot in before and b is before[b.lot]]
    assert all(b.year < year for b in kept)


def test_lots_on_planned_streets_wait_for_their_street_to_be_built():
    city = expanded("krems.osm.gz")
    net = city.network
    planned = net.replace(streets=tuple(replace(s, status=Status.PLANNED) if s.is_new else s for s in net.streets))
    city = city.replace(network=planned)
    history = load_history("example")
    rng = np.random.default_rng(1)
    memory = start_buildout(city, history, rng)
    now = history.values_at(history.clock(city.year).history_year(0))
    after, memory, report = buildout_year(city, memory, history, now, rng, year=city.year,
                                          traffic=synthetic_traffic(city))
    built = {s.id for s in after.network.streets if s.status == Status.BUILT}
    fronts = {}
    for lot in after.lots:
        state = memory.lots[lot.id]
        fronts[lot.id] = set(state.lot.streets.tolist())
    assert report.lots_made > 0
    for b in generated(after):
        assert fronts[b.lot] & built  # only lots on a built street have buildings
    assert any(not (f & built) for f in fronts.values())  # and lots on planned streets exist, empty
    # they count the people their land use expects: the trips that get their planned street built
    waiting = [lot for lot in after.lots if not (fronts[lot.id] & built) and lot.land_use.startswith("residential")]
    assert waiting and all(lot.people > 0 for lot in waiting)


def test_same_seed_same_build_out():
    a = built_out("krems.osm.gz", seed=11)[1]
    b = built_out.__wrapped__("krems.osm.gz", seed=11)[1]
    assert [lot.polygon.wkb for lot in a.lots] == [lot.polygon.wkb for lot in b.lots]
    assert [(b_.ring.tobytes(), b_.height) for b_ in generated(a)] == [(c.ring.tobytes(), c.height)
                                                                       for c in generated(b)]


def test_year_reports_add_up_and_are_json_ready():
    a = BuildoutYear(blocks=1, lots_made=5, buildings_built=3)
    b = BuildoutYear(lots_made=2, buildings_substituted=1, land_use_changes=4)
    total = a + b
    assert total.lots_made == 7 and total.buildings_built == 3 and total.land_use_changes == 4
    assert json.loads(json.dumps(total.to_dict()))["buildings_substituted"] == 1
    assert sum([a, b], BuildoutYear()) == total


def test_bad_options_and_a_second_start_raise_input_errors():
    with pytest.raises(InputError, match="street_overlap"):
        BuildoutOptions(street_overlap=0.0)
    with pytest.raises(InputError, match="town_clearance"):
        BuildoutOptions(town_clearance=-1.0)
    with pytest.raises(InputError, match="town_cell"):
        CalibrationOptions(town_cell=-1.0)
    _, city, _, history, _ = built_out("krems.osm.gz")
    with pytest.raises(InputError, match="already has"):
        start_buildout(city, history, np.random.default_rng(0))


def test_the_old_town_has_people_for_the_trip_model():
    _, _, memory, history, _ = built_out("krems.osm.gz")
    xy, people = town_people(memory, history)
    assert xy.shape == (len(memory.town.unit_xy), 2) and (people >= 0).all()
    assert 5_000 < people.sum() < 200_000  # Krems has about 24,000 inhabitants plus its jobs


# --------------------------------------------------------------------------- calibration


def test_tag_numbers_read_the_leading_number():
    assert tag_number({"height": "12.5 m"}, "height") == 12.5
    assert tag_number({"height": "7,5"}, "height") == 7.5
    assert math.isnan(tag_number({"height": "high"}, "height"))
    assert math.isnan(tag_number((), "building:levels"))


def test_town_units_gather_buildings_into_cells():
    xy, area, member = town_units(np.array([[1.0, 1.0], [3.0, 1.0], [50.0, 1.0], [51.0, 2.0]]),
                                  np.array([100.0, 300.0, 50.0, 2000.0]), cell=40.0, coverage=0.25)
    assert member.tolist() == [0, 0, 1, 1]
    assert xy[0].tolist() == [2.5, 1.0]  # footprint-weighted
    assert area.tolist() == [1600.0, 1600.0]  # 400 / 0.25 = 1,600 = the cell; 2,050 / 0.25 capped


def test_centres_are_density_peaks_far_enough_apart():
    rng = np.random.default_rng(0)
    old = rng.normal([0, 0], 100, (400, 2))
    village = rng.normal([3000, 0], 100, (250, 2))
    hamlet = rng.normal([3400, 300], 50, (20, 2))
    pts = np.vstack([old, village, hamlet])
    centres = find_centres(pts, np.ones(len(pts)))
    assert len(centres) == 2
    assert np.hypot(*centres[0]) < 60 and np.hypot(*(centres[1] - [3000, 0])) < 60
    one = find_centres(pts, np.ones(len(pts)), options=CalibrationOptions(max_centres=1))
    assert len(one) == 1
    with pytest.raises(InputError):
        find_centres(np.zeros((0, 2)), np.zeros(0))


def test_heights_calibrate_from_tags_not_from_filled_heights():
    _, _, memory, _, _ = built_out("krems.osm.gz")
    heights = memory.town.heights
    assert not heights.from_tags and heights.storey_height == 3.0  # Krems has no height tags


# --------------------------------------------------------------------------- outputs


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    _, city, _, _, _ = built_out("krems.osm.gz")
    folder = tmp_path_factory.mktemp("buildout")
    paths = {k: folder / f"krems.{k}" for k in ("xml", "osm", "geojson")}
    write_urbanenvironment(city, paths["xml"])
    write_osm(city, paths["osm"])
    write_geojson(city, paths["geojson"])
    return city, paths


def test_the_xml_carries_lots_blocks_and_building_attributes_and_validates(outputs):
    city, paths = outputs
    assert validate(paths["xml"]) == []
    root = etree.parse(str(paths["xml"])).getroot()
    assert [c.tag for c in root] == ["streets", "buildings", "lots", "blocks"]
    assert len(root.findall("lots/lot")) == len(city.lots)
    assert len(root.findall("blocks/block")) == len(city.blocks)
    new = [b for b in root.iter("building") if b.get("origin") == "engine"]
    assert len(new) == len(generated(city))
    assert all(b.get(k) for b in new for k in ("landuse", "year", "floors", "lot", "height"))
    assert {st.get("kind") for st in root.iter("street")} == {"major", "minor"}
    assert all(float(st.get("width")) > 0 and st.get("status") for st in root.iter("street"))
    lot = root.find("lots/lot")
    assert lot.get("landuse") and lot.get("year") and len(lot.findall("node")) >= 3
    assert any(b.get("landuse") for b in root.iter("block"))


def test_the_osm_output_tags_generated_buildings_and_lots_and_keeps_the_town_as_mapped(outputs):
    city, paths = outputs
    ways = {w.id: dict(w.tags) for w in osmium.FileProcessor(str(paths["osm"]), osmium.osm.WAY)}
    new = [t for t in ways.values() if t.get("osm_expand:origin") == "engine" and "building" in t]
    assert len(new) == len(generated(city))
    assert {t["building"] for t in new} <= {"house", "apartments", "commercial", "industrial", "yes"}
    assert all(float(t["height"]) > 0 and int(t["building:levels"]) >= 1 for t in new)
    lots = [t for t in ways.values() if "osm_expand:lot" in t and "building" not in t]
    assert len(lots) == len(city.lots) and all("landuse" in t or t.get("leisure") == "park" for t in lots)
    for b in city.buildings[:50]:
        assert {k: v for k, v in ways[b.osm_id].items() if k != "osm_expand:origin"} == dict(b.tags)


def test_the_geojson_has_lot_and_block_polygons(outputs):
    city, paths = outputs
    doc = json.loads(paths["geojson"].read_text(encoding="utf-8"))
    kinds = [f["properties"].get("feature") for f in doc["features"]]
    assert kinds.count("lot") == len(city.lots) and kinds.count("block") == len(city.blocks)
    new = [f for f in doc["features"] if f["id"].startswith("building/") and f["properties"]["origin"] == "engine"]
    assert new and all({"landuse", "lot", "floors", "height", "year"} <= set(f["properties"]) for f in new)


@pytest.mark.parametrize("color_by", ["origin", "landuse", "year"])
def test_the_preview_colours_buildings_by_origin_land_use_or_year(outputs, tmp_path, color_by):
    city, _ = outputs
    out = tmp_path / f"map-{color_by}.png"
    write_preview(city, out, color_by=color_by)
    assert out.stat().st_size > 10_000


def test_the_preview_refuses_an_unknown_colouring(outputs, tmp_path):
    city, _ = outputs
    with pytest.raises(InputError, match="color_by: 'height' is not one of origin, landuse, year"):
        write_preview(city, tmp_path / "x.png", color_by="height")


def test_the_preview_draws_a_window_and_refuses_an_empty_one(outputs, tmp_path):
    city, _ = outputs
    x0, y0, x1, y1 = shapely.union_all([lot.polygon for lot in city.lots]).bounds
    whole, window = tmp_path / "whole.svg", tmp_path / "window.svg"
    write_preview(city, whole, color_by="landuse")
    write_preview(city, window, color_by="landuse", extent=(x0, y0, x1, y1))
    assert window.read_bytes() != whole.read_bytes()
    with pytest.raises(InputError, match="extent must be"):
        write_preview(city, tmp_path / "x.png", extent=(x1, y0, x0, y1))


def test_the_update_proposes_only_allowed_types_and_draws_the_same_numbers():
    from osm_expand.engine.buildout import landuse as lu
    from osm_expand.engine.buildout import landuse_types as lt
    from osm_expand.engine.buildout import lot_values as lv

    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 600, (300, 2))
    area = rng.uniform(400, 1200, 300)
    attrs = lv.lot_attributes(xy, centres=np.array([[300.0, 300.0]]), traffic=rng.uniform(0, 1, 300))
    layout = lv.lot_layout(xy, area, attrs)
    lut = lu.assign_types(layout, np.full(300, lt.UNASSIGNED), types=lt.DEFAULT_TYPES, rng=np.random.default_rng(1))
    allowed = np.ones((300, len(lt.DEFAULT_TYPES)), dtype=bool)
    allowed[:150, :] = False  # the first half may keep what they have and take nothing else
    a = lu.update_land_use(layout, lut, types=lt.DEFAULT_TYPES, rng=np.random.default_rng(2), allowed=allowed)
    assert (a.lut[:150] == lut[:150]).all() and (a.lut[150:] != lut[150:]).any()
    assert a.proposed <= 150
    free = lu.update_land_use(layout, lut, types=lt.DEFAULT_TYPES, rng=np.random.default_rng(2))
    everything = lu.update_land_use(layout, lut, types=lt.DEFAULT_TYPES, rng=np.random.default_rng(2),
                                    allowed=np.ones_like(allowed))
    assert (free.lut == everything.lut).all() and free.proposed == everything.proposed == 300
    with pytest.raises(InputError, match="allowed types"):
        lu.update_land_use(layout, lut, types=lt.DEFAULT_TYPES, rng=rng, allowed=allowed[:10])


def test_changed_lots_keep_the_bounds_of_their_new_type():
    _, city, memory, _, _ = built_out("andorra.osm.pbf")
    types = {t.name: t for t in memory.town.types}
    from osm_expand.engine.buildout.lots import land_use

    for lot in city.lots:
        state = memory.lots[lot.id]
        rule = memory.town.lot_options[land_use(types[lot.land_use].lot_size_key)]
        made_as = land_use(state.lot.land_use)
        if made_as != land_use(types[lot.land_use].lot_size_key):  # its type moved to another lot class
            assert rule.min_area <= lot.polygon.area <= rule.max_area


def test_the_build_outs_yearly_memos_give_what_a_fresh_computation_gives():
    """The block keys, the streets' geometry and the blocks to build out, carried from year to year,
    are those computed afresh, while streets are added, widened, moved and removed."""
    from types import SimpleNamespace

    from osm_expand.engine.buildout.memory import _Memo
    from osm_expand.engine.buildout.new_lots import _buildable
    from osm_expand.engine.buildout.streets import _block_keys, _streets
    from osm_expand.model import City, network_from_lines
    from osm_expand.model.segments import street_width

    def grid(n, step, x0=0.0):
        span = [i * step for i in range(n)]
        return [[(x0 + x, y) for x in span] for y in span] + [[(x0 + x, y) for y in span] for x in span]

    years = [grid(3, 100.0), grid(3, 100.0) + grid(2, 50.0, 400.0), grid(4, 100.0), grid(4, 100.0),
             grid(4, 100.0)[:-1], grid(3, 100.0), grid(3, 100.0)]
    memo = _Memo()
    last = None
    unchanged = []
    for k, lines in enumerate(years):
        net = network_from_lines(lines)
        w = [0, 1, 2, 2, 3, 4, 4][k]  # years 3 and 6 are the years before them again
        widths = [None if (i + w) % 3 else 4.0 + w for i in range(len(net.streets))]  # widened some years
        net = net.replace(streets=tuple(replace(s, width=w, origin=Origin.GROWN if i % 2 else Origin.SOURCE)
                                        for i, (s, w) in enumerate(zip(net.streets, widths))))
        city = City(network=net)
        carried, signature = _streets(city, memo, last and last[0])
        fresh, fresh_signature = _streets(city, _Memo(), last and last[0])
        # the year's streets are last year's exactly when their ids, nodes and widths are
        geometry = tuple((s.id, s.nodes, street_width(s)) for s in net.streets if len(s.nodes) >= 2)
        assert (last is not None and signature == last[0]) == (last is not None and geometry == last[1])
        if last is not None and signature == last[0]:
            unchanged.append(k)
        assert signature == fresh_signature and carried.changed == fresh.changed
        assert np.array_equal(carried.recent, fresh.recent)
        last = (signature, geometry)
        assert np.array_equal(carried.ids, fresh.ids) and np.array_equal(carried.widths, fresh.widths)
        assert all(a.equals_exact(b, 0.0) for a, b in zip(carried.lines, fresh.lines))
        assert all(a.equals_exact(b, 0.0) for a, b in zip(carried.carriageways, fresh.carriageways))
        assert set(memo.streets) == set(fresh.ids.tolist())
        found = blocks(net)
        assert _block_keys(found, memo) == _block_keys(found)
        assert _block_keys(found, memo) == _block_keys(found)  # every polygon known now
        work = SimpleNamespace(blocks=found, streets=fresh)
        new_ids = set(fresh.ids[fresh.new].tolist())
        assert _buildable(work).tolist() == [any(i in new_ids for i in b.street_ids) for b in found]
    assert unchanged == [3, 6]


def test_lots_carried_to_their_blocks_lie_where_a_fresh_lookup_finds_them():
    """The block each lot lies within, carried from last year where its block polygon is still there,
    is the one a lookup over all blocks finds, after a year whose new street splits one block."""
    from types import SimpleNamespace

    from osm_expand.blocks import FaceMemo
    from osm_expand.engine.buildout.demolition import _lot_blocks
    from osm_expand.engine.buildout.memory import _Memo
    from osm_expand.model import network_from_lines

    span = [0.0, 100.0, 200.0, 300.0]
    def column(x):  # the two left columns have a node at y = 150 every year
        return [(x, y) for y in sorted(span + ([150.0] if x < 150 else []))]

    grid = [[(x, y) for x in span] for y in span] + [column(x) for x in span]
    split = grid + [[(0.0, 150.0), (100.0, 150.0)]]  # cuts the block at (0..100, 100..200) in two
    points = {k: (10.0 + 35.0 * (k % 8), 12.0 + 37.0 * (k // 8)) for k in range(64)}
    points[99] = (-50.0, -50.0)  # outside every block
    states = {k: SimpleNamespace(point=p) for k, p in points.items()}
    order = sorted(states)
    memo, faces = _Memo(), FaceMemo()
    carried_years = []
    for lines in (grid, split, split):
        found = blocks(network_from_lines(lines), memo=faces)
        year = SimpleNamespace(memory=SimpleNamespace(memo=memo), blocks=found, states=states)
        fresh = SimpleNamespace(memory=SimpleNamespace(memo=_Memo()), blocks=found, states=states)
        before = dict(memo.lot_blocks)
        within, _ = _lot_blocks(year, order)
        assert within.tolist() == _lot_blocks(fresh, order)[0].tolist()
        carried_years.append(sum(memo.lot_blocks.get(k, (None, None))[1] is p[1] for k, p in before.items()))
        polys = [b.polygon for b in found]
        for lot_id, k in zip(order, within.tolist()):
            assert (k < 0) == (lot_id == 99)
            assert k < 0 or polys[k].contains(shapely.Point(points[lot_id]))
    assert carried_years[0] == 0 and 0 < carried_years[1] < 64 and carried_years[2] == 64


def test_a_year_run_again_from_an_older_memory_sees_what_changed_since_that_memorys_year():
    """Memories made by ``replace`` share one memo. A year run twice from an older memory, after the
    memo saw a street widened and a lot of the same id elsewhere, still finds that street changed
    and that lot in its own block (the memo was filled by a later year than the memory's)."""
    from types import SimpleNamespace

    from osm_expand.engine.buildout.demolition import _lot_blocks
    from osm_expand.engine.buildout.memory import _Memo
    from osm_expand.engine.buildout.streets import _streets
    from osm_expand.model import City, network_from_lines

    net = network_from_lines([[(0.0, 0.0), (100.0, 0.0)], [(100.0, 0.0), (100.0, 100.0)]])
    s0 = City(network=net)
    s1 = City(network=net.replace(streets=tuple(replace(s, width=9.0) if i == 0 else s
                                                for i, s in enumerate(net.streets))))
    memo = _Memo()
    _, sig0 = _streets(s0, memo, None)  # the older memory's year
    for _ in range(2):  # the second run finds the memo filled by the first
        table, sig1 = _streets(s1, memo, sig0)
        assert sig1 != sig0 and table.changed == {net.streets[0].id} and table.recent.tolist() == [True, False]
    assert _streets(s1, memo, sig1)[1] == sig1 and not _streets(s1, memo, sig1)[0].recent.any()

    found = blocks(network_from_lines([[(x, y) for x in (0.0, 100.0, 200.0)] for y in (0.0, 100.0)]
                                      + [[(x, y) for y in (0.0, 100.0)] for x in (0.0, 100.0, 200.0)]))
    for point in ((50.0, 50.0), (150.0, 50.0)):  # lot 7 of one branch, then lot 7 of another
        states = {7: SimpleNamespace(point=point)}
        year = SimpleNamespace(memory=SimpleNamespace(memo=memo), blocks=found, states=states)
        (k,), _ = _lot_blocks(year, [7])
        assert found[k].polygon.contains(shapely.Point(point))


def test_a_lot_nothing_changed_for_is_handed_to_the_city_as_last_years_object():
    """A year hands the city last year's Lot object where the lot and every field the year sets are the
    same (not a new one per lot per year), and its lots equal, field for field, those of the same year
    run with an empty memo (every lot placed anew)."""
    from osm_expand.engine.buildout.memory import _Memo

    start, city, memory, history, _ = built_out("krems.osm.gz")
    clock = history.clock(start.year)

    def year(city, memory, step):
        now = history.values_at(clock.history_year(step))
        return buildout_year(city, memory, history, now, np.random.default_rng(11), year=clock.calendar_year(step),
                             traffic=synthetic_traffic(city))

    city, memory, _ = year(city, replace(memory, memo=_Memo()), YEARS)  # a memo of this branch's years alone
    kept = year(city, memory, YEARS + 1)[0].lots
    fresh = year(city, replace(memory, memo=_Memo()), YEARS + 1)[0].lots
    assert [lot.id for lot in kept] == [lot.id for lot in fresh]
    fields = ("block", "land_use", "street", "people", "id", "year")
    for a, b in zip(kept, fresh):
        assert np.array_equal(a.ring, b.ring) and np.array_equal(a.edge_street, b.edge_street)
        assert [getattr(a, f) for f in fields] == [getattr(b, f) for f in fields]
    before = {lot.id: lot for lot in city.lots}
    same = [lot.id for lot in kept if lot is before.get(lot.id)]
    assert len(same) > len(kept) // 4
    assert not any(lot is before.get(lot.id) for lot in fresh)
