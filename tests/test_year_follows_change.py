"""Issue 22, each year costs what changed: the traffic step and B visit what the year changed, with the
results of visiting everything (on Krems' default run, every year)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely

from osm_expand.engine.roads.built_up import BuiltUpOptions
from osm_expand.model import Status


def _every_street(city, table, traffic, pending, year, options):
    """``simulation._streets_follow_traffic`` as it was at main aeba056 (this copy frozen from it): every street
    visited, one by one."""
    from osm_expand.engine.traffic.trips import update_status, update_widths

    streets = list(city.network.streets)
    n = len(streets)
    per_street = table.per_street(traffic, n, "max")
    built = np.array([s.status == Status.BUILT for s in streets])
    built_year = np.array([s.year if s.year is not None else -1 for s in streets], dtype=np.int64)
    now_built, now_year = update_status(built, per_street, built_year, year=year, options=options)
    width = table.per_street(table.width, n, "max")
    major = table.per_street(table.major.astype(float), n, "max") > 0
    since = np.array([pending.get(s.id, -1) for s in streets], dtype=np.int64)
    old_year = np.where(now_built & ~built, now_year, np.minimum(built_year, year - 1))
    new_width, since = update_widths(width, per_street, now_built, old_year, since, year=year, major=major,
                                     options=options)
    widened = 0
    for k, s in enumerate(streets):
        if now_built[k] and not built[k]:
            streets[k] = replace(s, status=Status.BUILT)
        if s.is_new and abs(new_width[k] - width[k]) > 0.01 or (not s.is_new and new_width[k] > width[k] + 0.01):
            streets[k] = replace(streets[k], width=float(new_width[k]))
            widened += 1
    pending = {s.id: int(v) for s, v in zip(streets, since) if v >= 0}
    return tuple(streets), int((now_built & ~built).sum()), widened, pending


def _overlaid_verdicts(blocks, water, opts: BuiltUpOptions) -> dict:
    """Each block's built-up verdict with its water share from the overlay of every block with the water."""
    polys = np.array([b for b in blocks if b is not None and not b.is_empty], dtype=object)
    area = shapely.area(polys)
    ok = (area <= opts.terrain_block_area) & (
        shapely.area(shapely.intersection(polys, water)) <= opts.water_block_share * area)
    return dict(zip(shapely.to_wkb(shapely.normalize(polys)).tolist(), ok.tolist()))


def test_on_krems_each_year_visits_what_changed_and_gets_what_visiting_everything_gave(monkeypatch):
    """Every year of Krems' default run: the streets that follow the traffic are those the loop over
    every street gave (statuses, widths, counts, waiting widths), and B's block verdicts are those
    of the overlay of every block with the Danube, though only the blocks the water touches are
    overlaid (the overlay of all of them was most of B's first year on Campo Grande).

    The traffic half is an oracle check: the old loop (:func:`_every_street`) is run beside the new
    step each year and must give the same; some year widens a street with no status changed, so
    the widening path is compared on its own, not only behind a newly built street."""
    from conftest import FIXTURES, expanded_and_matured

    import osm_expand.engine.roads.built_up as bu
    import osm_expand.engine.roads.major_roads as mr
    import osm_expand.engine.traffic.simulation as sim
    from osm_expand.ingest import load

    follow = sim._streets_follow_traffic
    years, changed = [], [0]
    widened_alone: list[int] = []  # streets widened in the years no street's status changed

    def checked_follow(city, table, traffic, pending, year, options):
        got = follow(city, table, traffic, pending, year, options)
        want = _every_street(city, table, traffic, pending, year, options)
        assert got[0].network.streets == want[0] and got[1:] == want[1:]
        years.append(year)
        changed[0] += got[1] + got[2]
        if got[1] == 0:
            widened_alone.append(got[2])
        return got

    area_of = mr.built_up_area
    overlaid: list[int] = []
    blocks_seen: list[int] = []
    wet: list[int] = []

    def checked_area(blocks, segments, *, water=None, previous=None, options=None):
        got = area_of(blocks, segments, water=water, previous=previous, options=options)
        opts = options or BuiltUpOptions()
        if water is not None and not water.is_empty:
            intersection = shapely.intersection

            def counted(a, b, **kw):
                if isinstance(a, np.ndarray):  # B's overlay of blocks; not a scalar call from elsewhere
                    overlaid.append(len(a))
                return intersection(a, b, **kw)

            with monkeypatch.context() as patch:  # shapely's own function: undone even if B raises
                patch.setattr(bu.shapely, "intersection", counted)
                fresh = area_of(blocks, segments, water=water, options=opts)  # every block measured
            assert fresh.verdicts == _overlaid_verdicts(blocks, water, opts)
            assert got.verdicts == fresh.verdicts
            blocks_seen.append(len(blocks))
            wet.append(int(shapely.intersects(water, np.array(blocks, dtype=object)).sum()))
        return got

    monkeypatch.setattr(sim, "_streets_follow_traffic", checked_follow)
    monkeypatch.setattr(mr, "built_up_area", checked_area)
    expanded_and_matured(load(FIXTURES / "krems.osm.gz"), history="example")
    assert len(years) >= 20 and changed[0] > 0  # every year, and streets were built or widened
    assert max(widened_alone, default=0) > 0  # a street widened in a year with no status change
    assert blocks_seen and wet and min(wet) > 0  # B was made, and the Danube touches some blocks
    # the overlays took only the blocks the water touches, never every block
    assert max(overlaid) <= max(wet) < min(blocks_seen)


def test_points_at_the_edge_of_the_town_are_those_within_reach_of_its_land_polygons():
    """Issue 22: ``minor_streets._at_the_edge`` finds the points near the town's land by a KD-tree of
    the land's vertices first (a point within reach of a vertex is within reach of the land) and
    measures only the others against the polygons: the same points as measuring every point against
    every polygon (the old query, 0.66 s of each of Campo Grande's 189 european calls), on Krems' land,
    for a grid over the map, points on the land's vertices and points a hair either side of ``reach``
    from them, at three reaches."""
    from tests.conftest import FIXTURES

    import osm_expand.engine.growth.minor_streets as ms
    from osm_expand.ingest import load
    from osm_expand.pipeline import prepare

    city = prepare(load(FIXTURES / "krems.osm.gz"))
    assert city.land is not None and len(city.land.town)
    x0, y0, x1, y1 = city.bounds_xy
    grid = np.stack(np.meshgrid(np.arange(x0 - 150, x1 + 150, 23.0), np.arange(y0 - 150, y1 + 150, 23.0)),
                    axis=-1).reshape(-1, 2)
    vertices = shapely.get_coordinates(city.land.town)
    rng = np.random.default_rng(0)
    some = vertices[rng.choice(len(vertices), 2000, replace=False)]
    angle = rng.uniform(0, 2 * np.pi, len(some))
    tree = city.land.town_tree
    asked: list[int] = []

    class Counted:  # the land's tree, counting the points measured against the polygons
        def query(self, points, **kw):
            asked.append(len(np.atleast_1d(points)))
            return tree.query(points, **kw)

    city.land.__dict__["town_tree"] = Counted()  # the cached property's slot
    for reach in (30.0, 99.06143210292755, 250.0):
        ring = [some + (reach + eps) * np.stack([np.cos(angle), np.sin(angle)], axis=1) for eps in (-1e-9, 0.0, 1e-9)]
        xy = np.concatenate([grid, some, *ring])
        want = np.zeros(len(xy), dtype=bool)
        want[tree.query(shapely.points(xy), predicate="dwithin", distance=reach)[0]] = True
        asked.clear()
        got = ms._at_the_edge(city, xy, reach)
        assert np.array_equal(got, want)
        assert 0 < want.sum() < len(xy)
        assert sum(asked) < len(xy) - 0.5 * want.sum()  # the points near a vertex were not measured again
