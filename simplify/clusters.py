"""Pass 6 (004 §4.2.4): fuse clusters of junctions.

Every junction is a disc of ``cluster_radius``; discs that overlap, directly
or through a chain, form a cluster that becomes one junction at its centroid
(dual carriageways, complex junctions, sloppy editing). An STRtree finds the
overlaps and a vectorised connected-components pass groups them, instead of the
thesis's all-pairs distance loop. Shape points within the radius of the new
junction are dropped so approaches run straight into it.
"""
from __future__ import annotations

import numpy as np

from osm_expand.model import Street, StreetNetwork
from osm_expand.model.components import close_pairs, component_labels
from osm_expand.model.topology import append_nodes, junction_mask, replace_nodes, split_self_touching
from simplify.options import SimplifyOptions


def fuse_clusters(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, int]:
    """Returns the network and the number of clusters fused."""
    junction = junction_mask(net.streets, len(net.xy))
    nodes = np.flatnonzero(junction)
    if len(nodes) < 2:
        return net, 0
    pairs = close_pairs(net.xy[nodes], 2 * opts.cluster_radius)
    if len(pairs) == 0:
        return net, 0
    label = component_labels(len(nodes), pairs[:, 0], pairs[:, 1])
    sizes = np.bincount(label)
    multi = np.flatnonzero(sizes > 1)
    centres = np.zeros((len(multi), 2))
    slot = np.full(len(sizes), -1)
    slot[multi] = np.arange(len(multi))
    member = slot[label] >= 0
    np.add.at(centres, slot[label[member]], net.xy[nodes[member]])
    centres /= sizes[multi][:, None]
    xy, ids, first = append_nodes(net, centres)
    remap = {int(m): first + int(slot[label[i]]) for i, m in enumerate(nodes) if member[i]}
    streets = replace_nodes(net.streets, remap)
    new_nodes = set(range(first, first + len(multi)))
    trimmed = (_trim_near(s, xy, junction, new_nodes, opts.cluster_radius) for s in streets)
    # a small ring around the new junction can shrink to nothing: clean and cut again
    streets = tuple(p for s in trimmed for p in split_self_touching(s))
    return net.replace(xy=xy, node_ids=ids, streets=streets), len(multi)


def _trim_near(street: Street, xy: np.ndarray, junction: np.ndarray, centres: set[int], radius: float) -> Street:
    """Drop non-junction shape points within ``radius`` of a fused junction on this street."""
    nodes = street.nodes
    if not any(n in centres for n in nodes):
        return street
    drop = set()
    for i, n in enumerate(nodes):
        if n not in centres:
            continue
        for step in (-1, 1):
            j = i + step
            while 0 < j < len(nodes) - 1 and nodes[j] not in centres and not _is_junction(nodes[j], junction) \
                    and np.hypot(*(xy[nodes[j]] - xy[n])) < radius:
                drop.add(j)
                j += step
    if not drop:
        return street
    return street.with_nodes(tuple(n for i, n in enumerate(nodes) if i not in drop))


def _is_junction(node: int, junction: np.ndarray) -> bool:
    return node < len(junction) and bool(junction[node])
