"""The example model of 004 §3.1 / §4.3.2: what the random walk learns from.

Every junction keeps two records, one per street through it: the street's
Gravelius level and the mean and variance of the distance between its
consecutive junctions and of its signed turning angle between consecutive
junction-to-junction chords. A junction has room for two streets, i.e. four
segments; what is not used are its free connection slots.

Beyond the thesis (its §6.2 says what it lost): each street's tortuosity
(arc length over chord between junctions), so grown streets can take real
shapes again, and the dead ends simplification removed, per level.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from osm_expand.model import StreetNetwork
from osm_expand.model.topology import MAX_DEGREE, junction_mask, junction_stops, lengths
from simplify.dead_ends import DeadEnd
from simplify.hierarchy import with_levels

#: Floors for the Gaussians so a street with few junctions is not infinitely picky.
MIN_LENGTH_STD = 0.15  # as a share of the mean spacing
MIN_ANGLE_STD = 8.0  # degrees


@dataclass(frozen=True)
class StreetStats:
    level: int
    spacing: np.ndarray  # chord lengths between consecutive junctions (m)
    turning: np.ndarray  # signed turning angles between consecutive chords (degrees)
    tortuosity: np.ndarray  # arc length / chord length per junction-to-junction piece


@dataclass(frozen=True)
class Example:
    network: StreetNetwork  # with each street's hierarchy set
    junctions: np.ndarray  # (J,) node indices into network.xy
    street: np.ndarray  # (J, 2) the two streets through each junction (-1: none)
    level: np.ndarray  # (J, 2)
    length_mean: np.ndarray  # (J, 2)
    length_std: np.ndarray  # (J, 2)
    angle_mean: np.ndarray  # (J, 2)
    angle_std: np.ndarray  # (J, 2)
    degree: np.ndarray  # (J,) segments meeting at the junction (2, 3 or 4 in a simplified network)
    record_cap: np.ndarray  # (J, 2) segments each street has there: 2 passing, 1 ending, 0 none
    streets: list[StreetStats] = field(default_factory=list)
    dead_ends_per_level: dict[int, dict[str, float]] = field(default_factory=dict)

    @property
    def xy(self) -> np.ndarray:
        return self.network.xy[self.junctions]

    @property
    def spacing(self) -> float:
        """The town's typical junction spacing (m): the median of its records' mean spacing; 100 without any."""
        finite = self.length_mean[np.isfinite(self.length_mean)]
        return float(np.median(finite)) if len(finite) else 100.0

    @property
    def slots(self) -> np.ndarray:
        """Free connection slots: a junction takes two streets, four segments."""
        return np.maximum(MAX_DEGREE - self.degree, 0)


def street_stats(net: StreetNetwork, junction: np.ndarray, k: int) -> StreetStats:
    street = net.streets[k]
    pos = junction_stops(street, junction)
    pts = net.xy[[street.nodes[p] for p in pos]]
    chords = np.diff(pts, axis=0)
    spacing = np.hypot(*chords.T) if len(chords) else np.zeros(0)
    heading = np.degrees(np.arctan2(chords[:, 1], chords[:, 0])) if len(chords) else np.zeros(0)
    turning = (np.diff(heading) + 180.0) % 360.0 - 180.0
    arcs = np.array([lengths(net.xy, street.nodes[a:b + 1]) for a, b in zip(pos, pos[1:])])
    tortuosity = np.divide(arcs, spacing, out=np.ones_like(arcs), where=spacing > 0)
    return StreetStats(level=street.hierarchy, spacing=spacing, turning=turning, tortuosity=tortuosity)


def _summaries(stats: list[StreetStats]) -> np.ndarray:
    """Per street: spacing mean/std and turning mean/std, falling back to the level's pooled values."""
    levels = sorted({s.level for s in stats})
    pooled = {}
    for lv in levels:
        sp = np.concatenate([s.spacing for s in stats if s.level == lv] or [np.zeros(0)])
        tu = np.concatenate([s.turning for s in stats if s.level == lv] or [np.zeros(0)])
        pooled[lv] = (sp.std() if len(sp) > 1 else 0.0, tu.std() if len(tu) > 1 else MIN_ANGLE_STD)
    out = np.zeros((len(stats), 4))
    for k, s in enumerate(stats):
        mean_len = s.spacing.mean() if len(s.spacing) else 0.0
        std_len = s.spacing.std() if len(s.spacing) > 2 else pooled[s.level][0]
        mean_ang = s.turning.mean() if len(s.turning) else 0.0
        std_ang = s.turning.std() if len(s.turning) > 2 else pooled[s.level][1]
        out[k] = (mean_len, max(std_len, MIN_LENGTH_STD * mean_len), mean_ang, max(std_ang, MIN_ANGLE_STD))
    return out


def build_example(net: StreetNetwork, dead_ends: Sequence[DeadEnd] = ()) -> Example:
    """The example of a simplified network (junctions with two records each)."""
    net = with_levels(net)
    n = len(net.xy)
    junction = junction_mask(net.streets, n)
    stats = [street_stats(net, junction, k) for k in range(len(net.streets))]
    summary = _summaries(stats)
    nodes = np.flatnonzero(junction)
    slot_of = np.full(n, -1)
    slot_of[nodes] = np.arange(len(nodes))
    street = np.full((len(nodes), 2), -1, dtype=np.int64)
    degree = np.zeros(len(nodes), dtype=np.int64)
    cap = np.zeros((len(nodes), 2), dtype=np.int64)
    for k, s in enumerate(net.streets):
        last = len(s.nodes) - 1
        for i, v in enumerate(s.nodes):
            j = slot_of[v]
            if j < 0 or (s.is_closed and i == last):
                continue
            segments = 2 if (0 < i < last or s.is_closed) else 1
            degree[j] += segments  # the real degree, however many streets meet
            col = 0 if street[j, 0] < 0 else 1
            if col == 1 and street[j, 1] >= 0:
                continue  # more than two streets: not a simplified network; records for the first two
            street[j, col] = k
            cap[j, col] = segments
    has = street >= 0
    pick = lambda column: np.where(has, summary[np.maximum(street, 0), column], np.nan)  # noqa: E731
    level = np.where(has, np.array([s.level for s in stats] + [-1])[street], -1)
    return Example(
        network=net, junctions=nodes, street=street, level=level,
        length_mean=pick(0), length_std=pick(1), angle_mean=pick(2), angle_std=pick(3),
        degree=degree, record_cap=cap, streets=stats,
        dead_ends_per_level=_dead_ends_by_level(net, nodes, level, dead_ends),
    )


def _dead_ends_by_level(net: StreetNetwork, nodes: np.ndarray, level: np.ndarray,
                        dead_ends) -> dict[int, dict[str, float]]:
    """Per level: dead ends per junction and their mean length, located at the nearest junction."""
    if not len(nodes) or not dead_ends:
        return {}
    from scipy.spatial import cKDTree

    attached = [d for d in dead_ends if d.attach >= 0 and d.attach < len(net.xy)]
    if not attached:
        return {}
    _, idx = cKDTree(net.xy[nodes]).query(net.xy[[d.attach for d in attached]])
    junction_level = np.where(level[:, 1] >= 0, np.minimum(level[:, 0], level[:, 1]), level[:, 0])
    out: dict[int, dict[str, float]] = {}
    for lv in np.unique(junction_level).tolist():
        here = [d for d, j in zip(attached, idx) if junction_level[j] == lv]
        n_junctions = int((junction_level == lv).sum())
        out[int(lv)] = {"per_junction": len(here) / n_junctions,
                        "mean_length_m": float(np.mean([d.length for d in here])) if here else 0.0}
    return out
