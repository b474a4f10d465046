"""Starts and the four proposals made from a Default street: Default, Extend, Shorten, Snap (000 §4.2.6)."""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.patterns.options import PatternOptions, Proposal
from synth.patterns.sets import ORGANIC
from synth.street_graph import StreetGraph

#: Tolerance (m) for "this point is an existing crossing / lies on this segment".
ON_TOLERANCE = 1e-6


# --------------------------------------------------------------------------- starts and proposals

class StartPoints(Protocol):
    """Starts given as arrays, e.g. :class:`osm_expand.engine.growth.nuclei.Candidates`."""

    # Read-only members (properties), so that frozen dataclasses such as Candidates match.
    @property
    def node(self) -> NDArray[np.int64]:
        """(S,) node id, or -1 for a point on a segment."""

    @property
    def segment(self) -> NDArray[np.int64]:
        """(S,) segment id for a point on a segment, else -1."""

    @property
    def xy(self) -> NDArray[np.float64]:
        """(S, 2) position (m)."""


@dataclass(frozen=True)
class Start:
    """Where a street starts: an existing crossing, or a point on a segment (split when a street is built)."""

    node: int = -1
    segment: int = -1
    xy: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def at_node(cls, graph: StreetGraph, node: int) -> Start:
        """The crossing ``node``."""
        x, y = graph.xy[node]
        return cls(node=int(node), xy=(float(x), float(y)))

    @classmethod
    def on_segment(cls, segment: int, point: ArrayLike) -> Start:
        """A point (m) on ``segment``."""
        x, y = np.asarray(point, dtype=np.float64)
        return cls(segment=int(segment), xy=(float(x), float(y)))


@dataclass(frozen=True)
class StreetProposal:
    """A proposed street from a start: which method made it and where it ends.

    ``end_node`` ≥ 0: it ends at that crossing. ``end_segment`` ≥ 0: it ends
    at ``end_xy`` on that segment, which is split there. Both -1: it ends at
    a new crossing at ``end_xy``.
    """

    kind: Proposal
    end_xy: tuple[float, float]
    end_node: int = -1
    end_segment: int = -1


@dataclass
class GrowthStep:
    """What one :func:`grow_streets` call added to the graph (all ids are the graph's).

    Attributes
    ----------
    new_nodes : ndarray of int, shape (K,)
        Every node added: new street ends and split points, in order of creation.
    new_segments : ndarray of int, shape (M,)
        The new streets (not the halves of split segments), in order of creation.
    proposal : ndarray of str, shape (M,)
        The :class:`Proposal` that made each new street.
    start_index : ndarray of int, shape (M,)
        Index into ``starts`` of the start each new street grew from.
    bridges : ndarray of int, shape (B,)
        The new streets that are bridges (a subset of ``new_segments``).
    split_segment, split_node, split_new_segment : ndarray of int, shape (P,)
        Each split: the segment that was split (keeps its id, now ends at the
        split node), the node added, and the segment appended for the far half.
        Splits of major roads are among them: the engine must split the road too.
    failed_xy : ndarray, shape (F, 2)
        Starts on segments from which nothing could grow (m). The engine
        should keep them out of next year's candidates
        (``candidate_points(..., exclude_points=...)``); failed crossings are
        marked in ``graph.spawned`` instead.
    grown : ndarray of bool, shape (S,)
        Per start: did at least one street grow from it?
    start_node : ndarray of int, shape (S,)
        Per start: its crossing (after a split), or -1 if the start could not
        be used (on a segment with no street grown, or gone).
    """

    new_nodes: NDArray[np.int64]
    new_segments: NDArray[np.int64]
    proposal: NDArray[np.str_]
    start_index: NDArray[np.int64]
    bridges: NDArray[np.int64]
    split_segment: NDArray[np.int64]
    split_node: NDArray[np.int64]
    split_new_segment: NDArray[np.int64]
    failed_xy: NDArray[np.float64]
    grown: NDArray[np.bool_]
    start_node: NDArray[np.int64]


@dataclass
class _Log:
    nodes: list[int] = field(default_factory=list)
    segments: list[int] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    starts: list[int] = field(default_factory=list)
    bridges: list[int] = field(default_factory=list)
    splits: list[tuple[int, int, int]] = field(default_factory=list)
    failed: list[tuple[float, float]] = field(default_factory=list)


class _Context:
    """What the rules need to know about a start: position, incident directions, neighbours, excluded segments."""

    def __init__(self, graph: StreetGraph, start: Start):
        self.xy = np.asarray(start.xy, dtype=np.float64)
        self.node = start.node
        self.segment = start.segment
        if start.node >= 0:
            segs = graph.incident(start.node)
            self.excluded = segs
            self.neighbours = graph.neighbours(start.node)
            self.degree = len(segs)
            first = min(segs, key=lambda s: (graph.created[s], s)) if segs else -1
            if first >= 0:
                u, v = (int(x) for x in graph.edges[first])
                self.first_dir = _direction(graph.xy[v if u == start.node else u] - self.xy)
            else:
                self.first_dir = None
            self.bridge_tried = bool(graph.bridge_tried[start.node])
        else:
            u, v = (int(x) for x in graph.edges[start.segment])
            self.excluded = [start.segment]
            self.neighbours = [u, v]
            self.degree = 2
            self.first_dir = _direction(graph.xy[u] - self.xy)
            self.bridge_tried = False
        nb = np.asarray(self.neighbours, dtype=np.int64)
        self.incident_dirs = _angles(graph.xy[nb] - self.xy) if len(nb) else []


def _direction(v: NDArray[np.float64]) -> float | None:
    return math.atan2(v[1], v[0]) if (v[0] or v[1]) else None


def _angles(v: NDArray[np.float64]) -> list[float]:
    """Directions (rad) of the rows of ``v`` (a handful: the streets at one crossing)."""
    return [math.atan2(y, x) for x, y in v.tolist()]


def _min_angle_between(theta: float, dirs: list[float]) -> float:
    """Smallest absolute difference (rad) between ``theta`` and the directions ``dirs``."""
    two_pi = 2 * math.pi
    return min((abs((d - theta + math.pi) % two_pi - math.pi) for d in dirs), default=math.pi)


def _resolve(graph: StreetGraph, start: Start) -> Start | None:
    """The start as it is now: a segment start whose segment was split since is found again by position."""
    if start.node >= 0:
        return start if start.node < graph.n_nodes else None
    p = np.asarray(start.xy, dtype=np.float64)
    near, _ = graph.nodes_within(p, ON_TOLERANCE)
    if len(near):
        return Start.at_node(graph, int(near[0]))
    seg = start.segment
    if not 0 <= seg < graph.n_segments or graph.segment_at(p) != seg:
        seg = graph.segment_at(p)
    return None if seg < 0 else Start.on_segment(seg, p)


def propose(graph: StreetGraph, start: Start, *, angle: float, length: float,
            options: PatternOptions = ORGANIC) -> list[StreetProposal]:
    """The proposals for a Default street of world angle ``angle`` and ``length`` (000 §4.2.6).

    Parameters
    ----------
    graph : StreetGraph
    start : Start
    angle : float
        World-space direction (radians, counter-clockwise from east) of the Default street.
    length : float
        Its length (m).
    options : PatternOptions
        Which proposals are on, the snap radius and the look-ahead.

    Returns
    -------
    list of StreetProposal
        In evaluation order Snap, Shorten, Extend, Default; only enabled
        methods that apply (Snap needs a crossing near the end, Shorten and
        Extend an intersection). :func:`grow_streets` makes them lazily and
        skips Shorten, Extend and Default when their direction already
        breaks rule b at the start; this function lists them all.
    """
    ctx = _Context(graph, start)
    cand = _Candidates.gather(graph, ctx.xy, ctx.xy + length * np.array([math.cos(angle), math.sin(angle)]), options)
    return list(_propose(graph, ctx, cand, angle, length, options, prune=False))


@dataclass
class _Candidates:
    """Segments and crossings near an attempt, gathered once for all its proposals.

    Crossings are the ends of the gathered segments: a node without any
    street is not a crossing.
    """

    ids: NDArray[np.int64]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    uv: NDArray[np.int64]
    nodes: NDArray[np.int64]
    node_xy: NDArray[np.float64]
    lo: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    hi: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))

    @classmethod
    def gather(cls, graph: StreetGraph, p: NDArray[np.float64], e: NDArray[np.float64],
               options: PatternOptions) -> _Candidates:
        """Segments that any proposal from p with Default end e can meet or come near."""
        look = p + options.look_ahead * (e - p)
        margin = options.snap_radius_m + max(options.min_cs_distance_m, options.min_cc_distance_m) + 1.0
        ids = graph.segments_in_box(np.minimum(p, look) - margin, np.maximum(p, look) + margin)
        uv = graph.edges[ids]
        nodes = np.unique(uv)
        xy = graph.xy
        a, b = xy[uv[:, 0]], xy[uv[:, 1]]
        return cls(ids, a, b, uv, nodes, xy[nodes], np.minimum(a, b), np.maximum(a, b))

    def nearest_node(self, q: NDArray[np.float64], radius: float, exclude: int) -> int:
        """The crossing nearest to q within radius (lowest id on ties), not ``exclude``; -1 if none."""
        d = np.hypot(self.node_xy[:, 0] - q[0], self.node_xy[:, 1] - q[1])
        d[self.nodes == exclude] = np.inf
        k = int(np.argmin(d)) if len(d) else -1
        return int(self.nodes[k]) if k >= 0 and d[k] <= radius else -1

    def any_node_within(self, q: NDArray[np.float64], radius: float) -> bool:
        if radius <= 0 or len(self.nodes) == 0:
            return False
        return bool((np.hypot(self.node_xy[:, 0] - q[0], self.node_xy[:, 1] - q[1]) < radius).any())

    def keep(self, excluded: list[int]) -> NDArray[np.bool_]:
        """Mask of the candidate segments not in ``excluded`` (a short list)."""
        keep = np.ones(len(self.ids), dtype=bool)
        for s in excluded:
            keep &= self.ids != s
        return keep


def _propose(graph: StreetGraph, ctx: _Context, cand: _Candidates, angle: float, length: float,
             options: PatternOptions, *, prune: bool = True) -> Iterator[StreetProposal]:
    """Yield the proposals in evaluation order, lazily: the intersections are computed only if Snap fails.

    With ``prune``, Shorten, Extend and Default are not made when their
    common direction already breaks rule b at the start (they would be
    rejected; the result is the same, only faster).
    """
    p = ctx.xy
    d = np.array([math.cos(angle), math.sin(angle)])
    e = p + length * d
    if options.snap_enabled:
        n = cand.nearest_node(e, options.snap_radius_m, ctx.node)
        if n >= 0:
            yield StreetProposal(Proposal.SNAP, _tuple(graph.xy[n]), end_node=n)
    if prune and _min_angle_between(angle, ctx.incident_dirs) < math.radians(options.min_angle_deg):
        return  # Shorten, Extend and Default share this direction: rule b fails them all at the start
    if options.shorten_enabled or options.extend_enabled:
        t, k = _ray_hits(p, d, options.look_ahead * length, cand, ctx.excluded)
        if options.shorten_enabled and len(t) and t[0] <= length:
            yield _hit_proposal(graph, Proposal.SHORTEN, p + t[0] * d, cand, k[0])
        if options.extend_enabled:
            beyond = np.flatnonzero(t > length)
            if len(beyond):
                yield _hit_proposal(graph, Proposal.EXTEND, p + t[beyond[0]] * d, cand, k[beyond[0]])
    if options.default_enabled:
        yield StreetProposal(Proposal.DEFAULT, _tuple(e))


def _tuple(p: NDArray[np.float64]) -> tuple[float, float]:
    return float(p[0]), float(p[1])


def _ray_hits(p: NDArray[np.float64], d: NDArray[np.float64], reach: float, cand: _Candidates,
              excluded: list[int]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Distances (m) along p + t·d, 0 < t ≤ reach, where non-excluded candidates are met, sorted; and their rows."""
    if len(cand.ids) == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    s = cand.b - cand.a
    w = cand.a - p
    den = d[0] * s[:, 1] - d[1] * s[:, 0]
    ok = np.abs(den) > 1e-12
    den = np.where(ok, den, 1.0)
    t = (w[:, 0] * s[:, 1] - w[:, 1] * s[:, 0]) / den
    u = (w[:, 0] * d[1] - w[:, 1] * d[0]) / den
    tol_u = ON_TOLERANCE / np.maximum(np.hypot(s[:, 0], s[:, 1]), 1e-12)
    ok &= (t > ON_TOLERANCE) & (t <= reach + ON_TOLERANCE) & (u >= -tol_u) & (u <= 1 + tol_u)
    ok &= cand.keep(excluded)
    rows = np.flatnonzero(ok)
    if len(rows) > 1:
        rows = rows[np.lexsort((cand.ids[rows], t[rows]))]
    return t[rows], rows


def _hit_proposal(graph: StreetGraph, kind: Proposal, point: NDArray[np.float64], cand: _Candidates,
                  row: int) -> StreetProposal:
    """A proposal ending where the ray met candidate ``row``: at its end crossing if the hit is there."""
    for end in (0, 1):
        node = int(cand.uv[row, end])
        if np.hypot(*(graph.xy[node] - point)) <= ON_TOLERANCE:
            return StreetProposal(kind, _tuple(graph.xy[node]), end_node=node)
    return StreetProposal(kind, _tuple(point), end_segment=int(cand.ids[row]))
