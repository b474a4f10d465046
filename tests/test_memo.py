"""The model's identity cache (:class:`osm_expand.model.memo.IdentityMemo`): a value is made once for
the very same objects, never for equal ones, and only the most recently used few are kept."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from osm_expand.model.city import _block_index, _land_parts
from osm_expand.model.memo import EachMemo, IdentityMemo


def test_made_once_for_the_same_objects_and_again_for_equal_ones():
    memo = IdentityMemo(kept=2)
    made = []
    a, b = tuple([1, 2]), tuple([1, 2])  # equal, two objects
    assert a == b and a is not b
    for source in (a, a, b, a):
        memo.get((source,), "tag", lambda s=source: made.append(s) or len(made))
    assert len(made) == 2  # a once, b once
    assert memo.get((a,), "other", lambda: "x") == "x"  # another tag is another value
    three = tuple([3])
    memo.get((three,), None, lambda: 0)
    assert len(memo) == 2  # the least recently used went: (a, "tag") and (b, "tag"), not the last two
    assert memo.get((a,), "other", lambda: "made again") == "x"
    assert memo.get((three,), None, lambda: "made again") == 0
    assert memo.get((a,), "tag", lambda: "made again") == "made again"


def test_the_city_caches_give_the_same_object_for_the_same_tuples():
    polygons = tuple(shapely.box(i, 0, i + 1, 1) for i in range(3))
    water = (shapely.box(0, 0, 1, 1), shapely.box(0.5, 0, 2, 1))
    parts, tree = _land_parts(water, (), None)
    assert _land_parts(water, (), None)[0] is parts  # asked again: not made again
    assert np.isclose(shapely.area(parts).sum(), 2.0)
    assert _land_parts(tuple(water), (), None)[0] is parts  # tuple() of a tuple is the same object
    assert _land_parts(tuple(list(water)), (), None)[0] is not parts  # an equal tuple is another object

    class Block:
        def __init__(self, polygon):
            self.polygon = polygon
    blocks = tuple(Block(p) for p in polygons)
    first = _block_index(blocks)
    assert _block_index(blocks) is first
    assert not first[0].flags.writeable


def test_the_content_memo_makes_once_for_inputs_of_the_very_same_coordinates():
    """:class:`ContentMemo`: new objects of the same coordinates (a town rebuilt the same around a site) find
    the value; a coordinate moved by the last bit, another order, or another plain value do not."""
    from osm_expand.model.memo import ContentMemo

    memo = ContentMemo(kept=3)
    made: list[int] = []

    def union(geoms):
        made.append(len(geoms))
        return shapely.union_all(geoms)

    a = [shapely.box(0, 0, 2, 2), shapely.box(1, 1, 3, 3)]
    same = [shapely.from_wkb(shapely.to_wkb(g)) for g in a]  # other objects, the same coordinates
    first = memo.get(ContentMemo.key(a, 1.0), union, a)
    assert memo.get(ContentMemo.key(same, 1.0), union, same) is first and len(made) == 1
    nudged = [shapely.box(0, 0, 2, np.nextafter(2.0, 3.0)), a[1]]
    for key in (ContentMemo.key(nudged, 1.0), ContentMemo.key(a[::-1], 1.0), ContentMemo.key(a, 2.0),
                ContentMemo.key(a, np.array([1.0])), ContentMemo.key(a[:1], a[1:])):
        assert key != ContentMemo.key(a, 1.0)
    memo.get(ContentMemo.key(nudged), union, nudged)
    assert len(made) == 2
    with pytest.raises(TypeError):
        ContentMemo.key({"a": 1})


def test_the_content_key_tells_empty_and_numeric_arrays_from_geometries():
    """Finding 6 of session 31: a numeric array is hashed with its dtype and shape before its elements
    are tested, so an empty one is not an empty sequence of geometries; a 0-d object array is refused."""
    from osm_expand.model.memo import ContentMemo

    empty = ContentMemo.key([])
    assert ContentMemo.key(np.empty((0, 3))) != empty
    assert ContentMemo.key(np.empty((0, 3))) != ContentMemo.key(np.empty((0, 2)))
    assert ContentMemo.key(np.empty(0, dtype=object)) == empty == ContentMemo.key(())  # no geometries
    assert ContentMemo.key(np.array(1.0)) != ContentMemo.key(np.array([1.0]))  # 0-d numeric: its shape counts
    with pytest.raises(TypeError):
        ContentMemo.key(np.array(shapely.Point(0, 0), dtype=object))  # 0-d object array
    with pytest.raises(TypeError):
        ContentMemo.key(np.empty((2, 2), dtype=object))


def test_a_town_rebuilt_the_same_around_a_site_finds_its_occupied_land_and_region_made(monkeypatch):
    """The year loop makes new blocks and buildings every year; where they are the same around a site that
    is tried again, :meth:`City.occupied_within` and the region's free land are not made again, and are the
    very geometry (the same bytes) they were. The town is rebuilt from its geometries' WKB (blocks,
    buildings, street lines): new objects, found by their coordinates only."""
    from dataclasses import replace

    import osm_expand.model.city as city_module
    import osm_expand.sites as sites_module
    from osm_expand.ingest import load
    from osm_expand.pipeline import prepare
    from osm_expand.sites import Site, district_region
    from tests.conftest import FIXTURES

    def again_(g):
        return shapely.from_wkb(shapely.to_wkb(g))

    city_module._OCCUPIED.clear()  # module-global: other tests may have filled them
    sites_module._CLEARED.clear()
    made: list[str] = []
    for module, name in ((city_module, "_union_prepared"), (sites_module, "_cleared")):
        op = getattr(module, name)
        monkeypatch.setattr(module, name, lambda *a, op=op, name=name: made.append(name) or op(*a))
    city = prepare(load(FIXTURES / "krems.osm.gz"))
    site = Site(centre=np.array([2344.1, 109.7]), area=650_000.0,
                region=shapely.Point(2344.1, 109.7).buffer(455.0), score=1.0)
    region = district_region(city, site)
    assert {"_union_prepared", "_cleared"} <= set(made)  # made the first time
    made.clear()
    blocks = tuple(replace(b, polygon=again_(b.polygon)) for b in city.blocks)
    buildings = []
    for b in city.buildings:
        p = again_(b.polygon)
        buildings.append(replace(b, rings=(shapely.get_coordinates(p.exterior),
                                           *(shapely.get_coordinates(r) for r in p.interiors))))
    network = replace(city.network)
    lines = np.array([again_(g) for g in city.network.street_lines()], dtype=object)
    lines.flags.writeable = False
    network.__dict__["_street_lines"] = lines  # where StreetNetwork.street_lines keeps them
    again = city.replace(blocks=blocks, buildings=tuple(buildings), network=network)
    assert again.blocks[0].polygon is not city.blocks[0].polygon
    assert again.buildings[0].polygon is not city.buildings[0].polygon
    assert again.network.street_lines()[0] is not city.network.street_lines()[0]
    assert district_region(again, site).wkb == region.wkb
    assert made == []


def test_each_memo_makes_a_value_once_per_very_same_object_and_lets_old_ones_go():
    """Each key's value is made once while its objects are asked for; an equal but new object is made again,
    to the same bits (a GEOS operation is a pure function of its input); unasked keys go after two spans."""
    polys = [shapely.Point(x, 0).buffer(3.0) for x in range(6)]
    memo, made = EachMemo(span=2), []

    def shrink(keys):
        def make(missing):
            made.extend(missing)
            return shapely.buffer(np.array([keys[i][0] for i in missing], dtype=object), -1.0).tolist()
        return memo.get(keys, make)

    first = shrink([(p,) for p in polys])
    assert made == list(range(6))
    again = shrink([(p,) for p in polys[:4]] + [(shapely.Point(9, 0).buffer(3.0),)])
    assert made == list(range(6)) + [4] and all(a is b for a, b in zip(again[:4], first[:4]))
    copy = shapely.from_wkb(shapely.to_wkb(polys[0]))
    (remade,) = shrink([(copy,)])
    assert remade is not first[0] and shapely.to_wkb(remade) == shapely.to_wkb(first[0])
    for _ in range(4):
        shrink([(copy,)])
    assert len(memo) == 1  # only what the last spans asked for is kept
