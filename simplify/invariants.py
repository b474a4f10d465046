"""The properties a simplified network must have, counted.

These are the promises of 004 §4.2 that every later stage relies on: no
junction joins more than two streets, no dead ends, no degenerate streets,
and streets on the same layer meet only at shared junctions.
"""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model import StreetNetwork
from simplify.crossings import segment_table
from simplify.topology import street_counts


def violations(net: StreetNetwork) -> dict[str, int]:
    """Counts of each kind of violation; all zero for a valid simplified network."""
    counts = street_counts(net.streets, len(net.xy))
    degenerate = sum(1 for s in net.streets if len(set(s.nodes)) < 2)
    open_ends = np.array([(s.nodes[0], s.nodes[-1]) for s in net.streets if not s.is_closed],
                         dtype=np.int64).reshape(-1, 2)
    seg = segment_table(net)
    zero = int((np.hypot(*(net.xy[seg["u"]] - net.xy[seg["v"]]).T) < 1e-9).sum())
    return {
        "degenerate_streets": degenerate,
        "junctions_with_more_than_two_streets": int((counts > 2).sum()),
        "dead_ends": int((counts[open_ends.ravel()] < 2).sum()),
        "zero_length_segments": zero,
        "crossings_without_junction": _unshared_crossings(net, seg),
    }


def _unshared_crossings(net: StreetNetwork, seg: dict[str, np.ndarray]) -> int:
    """Same-layer segment pairs that touch anywhere except at a node they share."""
    if len(seg["u"]) == 0:
        return 0
    a, b = net.xy[seg["u"]], net.xy[seg["v"]]
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    p, q = shapely.STRtree(lines).query(lines, predicate="intersects")
    keep = (p < q) & (seg["layer"][p] == seg["layer"][q])
    p, q = p[keep], q[keep]
    up, vp, uq, vq = seg["u"][p], seg["v"][p], seg["u"][q], seg["v"][q]
    shares = (up == uq) | (up == vq) | (vp == uq) | (vp == vq)
    bad = int((~shares).sum())
    # sharing a node is fine unless the two segments also overlap along a line
    both = np.flatnonzero(shares)
    if len(both):
        inter = shapely.intersection(lines[p[both]], lines[q[both]])
        bad += int((shapely.get_type_id(inter) == 1).sum() + (shapely.get_type_id(inter) == 5).sum())
    return bad


def is_valid(net: StreetNetwork) -> bool:
    return not any(violations(net).values())
