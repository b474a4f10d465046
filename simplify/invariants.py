"""The properties a simplified network must have, counted.

These are the promises of 004 §4.2 that every later stage relies on: no
junction joins more than two streets, no dead ends, no degenerate streets,
and streets on the same layer meet only at shared junctions.
"""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model import StreetNetwork
from osm_expand.model.topology import street_counts
from simplify.crossings import candidate_pairs, segment_lines, segment_table
from simplify.dead_ends import dead_end_count


def violations(net: StreetNetwork) -> dict[str, int]:
    """Counts of each kind of violation; all zero for a valid simplified network."""
    counts = street_counts(net.streets, len(net.xy))
    degenerate = sum(1 for s in net.streets if len(set(s.nodes)) < 2)
    seg = segment_table(net)
    zero = int((np.hypot(*(net.xy[seg["u"]] - net.xy[seg["v"]]).T) < 1e-9).sum())
    return {
        "degenerate_streets": degenerate,
        "junctions_with_more_than_two_streets": int((counts > 2).sum()),
        "dead_ends": dead_end_count(net, counts),
        "zero_length_segments": zero,
        "crossings_without_junction": _unshared_crossings(net, seg),
    }


def _unshared_crossings(net: StreetNetwork, seg: dict[str, np.ndarray]) -> int:
    """Same-layer segment pairs that touch anywhere except at a node they share."""
    if len(seg["u"]) == 0:
        return 0
    p, q, shares = candidate_pairs(net, seg, 0.0)
    bad = int((~shares).sum())
    # sharing a node is fine unless the two segments also overlap along a line
    both = np.flatnonzero(shares)
    both = both[_maybe_collinear(net.xy, seg, p[both], q[both])]
    if len(both):
        a, b = net.xy[seg["u"]], net.xy[seg["v"]]
        p, q = p[both], q[both]
        inter = shapely.intersection(segment_lines(a[p], b[p]), segment_lines(a[q], b[q]))
        bad += int((shapely.get_type_id(inter) == 1).sum() + (shapely.get_type_id(inter) == 5).sum())
    return bad


def _maybe_collinear(xy: np.ndarray, seg: dict[str, np.ndarray], p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Which pairs sharing a node could overlap along a line: all but those clearly at an angle.

    Two segments from one node meet only there unless they are collinear; a
    cross product a billionth of the lengths' product is far beyond rounding
    error, so only the rest need GEOS's exact answer.
    """
    up, vp, uq, vq = seg["u"][p], seg["v"][p], seg["u"][q], seg["v"][q]
    hub = np.where((up == uq) | (up == vq), up, vp)
    far_p = np.where(up == hub, vp, up)
    far_q = np.where(uq == hub, vq, uq)
    d1, d2 = xy[far_p] - xy[hub], xy[far_q] - xy[hub]
    cross = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return ~(cross > 1e-9 * np.hypot(*d1.T) * np.hypot(*d2.T))


def is_valid(net: StreetNetwork) -> bool:
    return not any(violations(net).values())
