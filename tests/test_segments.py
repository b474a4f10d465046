"""The segment table (:class:`osm_expand.model.segments.SegmentTable`): what every engine stage reads of the
streets, segment by segment."""
from __future__ import annotations

import dataclasses

import numpy as np

from osm_expand.ingest import load
from osm_expand.model import Origin, Status
from osm_expand.model.segments import SegmentTable, is_major, street_width
from tests.conftest import FIXTURES

FIELDS = ("uv", "street", "length", "width", "major", "built", "bridge", "year", "street_id", "first")


def _table_street_by_street(city) -> dict[str, np.ndarray]:
    """The table as :meth:`SegmentTable._build` made it before issue 22's session 40: an array per street and a
    pass over the streets per field."""
    streets = city.network.streets
    sizes = np.array([len(s.nodes) - 1 for s in streets], dtype=np.int64)
    nodes = [np.asarray(s.nodes, dtype=np.int64) for s in streets]
    uv = (np.column_stack([np.concatenate([n[:-1] for n in nodes]), np.concatenate([n[1:] for n in nodes])])
          if streets else np.zeros((0, 2), dtype=np.int64))
    def per(values, dtype):
        return np.repeat(np.asarray(values, dtype=dtype), sizes)
    xy = city.network.xy
    return dict(uv=uv, street=np.repeat(np.arange(len(streets)), sizes),
                length=np.hypot(*(xy[uv[:, 1]] - xy[uv[:, 0]]).T),
                width=per([street_width(s) for s in streets], float), major=per([is_major(s) for s in streets], bool),
                built=per([s.status == Status.BUILT for s in streets], bool),
                bridge=per([s.bridge for s in streets], bool),
                year=per([s.year if s.year is not None and s.is_new else -1 for s in streets], np.int64),
                street_id=per([s.id for s in streets], np.int64),
                first=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64))


def test_the_table_is_the_one_made_street_by_street():
    """Krems as mapped, with new streets (an engine road bridged and dated, a planned street, a one-node
    street) and with none: every field the same values, dtype and shape as the street-by-street table."""
    city = load(FIXTURES / "krems.osm.gz", context=False)
    net = city.network
    a, b = net.xy[net.streets[0].nodes[0]], net.xy[net.streets[1].nodes[-1]]
    grown = net.with_new_streets(
        [np.array([a, a + [40.0, 5.0], a + [80.0, 0.0]]), np.array([b, b + [0.0, 60.0]])],
        [{"highway": "primary", "origin": Origin.ENGINE, "year": 2031, "bridge": True, "status": Status.BUILT},
         {"highway": "residential", "origin": Origin.GROWN, "year": 2030, "status": Status.PLANNED}])
    lone = dataclasses.replace(grown.streets[-1], nodes=(0,), id=grown.next_street_id())
    for network in (net, grown, grown.replace(streets=(*grown.streets, lone)), net.replace(streets=())):
        town = city.replace(network=network)
        made, reference = SegmentTable._build(town), _table_street_by_street(town)
        for name in FIELDS:
            got, want = getattr(made, name), reference[name]
            assert got.dtype == want.dtype and got.shape == want.shape and np.array_equal(got, want), name
    assert SegmentTable._build(city.replace(network=grown)).year.max() == 2031


def test_the_segment_keys_are_the_ones_made_street_by_street():
    """:meth:`StreetNetwork._segment_keys` (from :func:`~osm_expand.model.network.segment_nodes`' flat array)
    equals the keys of each street's segments gathered street by street, on Krems as mapped and with new
    streets (one running back along a segment it shares, one of a single node), and with no streets."""
    from osm_expand.model.network import pair_keys

    net = load(FIXTURES / "krems.osm.gz", context=False).network
    a = net.xy[net.streets[0].nodes[0]]
    grown = net.with_new_streets([np.array([a, a + [50.0, 0.0], a, a + [0.0, 30.0]])], [{"highway": "residential"}])
    lone = dataclasses.replace(grown.streets[-1], nodes=(3,), id=grown.next_street_id())
    for network in (net, grown, grown.replace(streets=(*grown.streets, lone)), net.replace(streets=())):
        runs = [np.asarray(s.nodes, dtype=np.int64) for s in network.streets if len(s.nodes) >= 2]
        u = np.concatenate([r[:-1] for r in runs]) if runs else np.zeros(0, np.int64)
        v = np.concatenate([r[1:] for r in runs]) if runs else np.zeros(0, np.int64)
        want = np.unique(pair_keys(u, v))
        got = network.replace()._segment_keys()  # a fresh network: its keys made, not handed on
        assert got.dtype == want.dtype and np.array_equal(got, want)
