"""The model's identity cache (:class:`osm_expand.model.memo.IdentityMemo`): a value is made once for
the very same objects, never for equal ones, and only the most recently used few are kept."""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model.city import _block_index, _land_parts
from osm_expand.model.memo import IdentityMemo


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
