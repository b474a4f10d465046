"""Space colonisation street growth (seed 001 ch. 4, after Runions et al. 2007).

A cloud of attraction points (APs) pulls a street network out of the old
town's streets. Distances are multiples of the segment length SL (001 works
in units with SL = 1; the integrator sets SL to the town's junction spacing).

**Seeds.** The old town's streets that touch the region are the initial
segments, primary roads (001 §4.3.3). Every vertex, and points added so that
no piece is longer than ``seed_spacing`` · SL, is a fixed node: never moved,
a target for snapping (a snap between two vertices splits the old street,
reported as a :class:`Join` for the integrator to split the real way). One
point every ``seed_spacing`` SL along each street may grow.

**Phase 1** (001 §3.1, §4.1). APs are scattered in the region (``ap_density``
per SL², kept with the density map's value, dropped where the border map or
``forbidden`` forbids them). Each iteration every live AP influences its
nearest growing node within the radius of influence RoI, unless the line
between them climbs steeper than ``max_steepness_deg`` (001 §4.3.1, checked
per pair); a node grows one SL along the mean of the normalised directions to
its APs; the APs that influenced it and lie within the kill distance KD of
the new node die (001 §3.1's rule). Growth ends when no AP influences any
node. Each proposed segment goes through these steps, **in this order**:

1. *angle snap* (001 §4.1.2): the turn from the parent segment must lie in
   ``[min, max]`` on either side, or within the tolerance range around
   straight ahead (default half the amplitude: [30°, 45°] → [0°, 7.5°]);
   a turn outside snaps to the nearest allowed value;
2. *flow blend* (001 §4.3.2): the flow direction at the proposed node, or
   either perpendicular, whichever is closer to the segment (never against
   the flow: a source keeps roads away, a sink draws them in, 001 §5.2),
   blended with the angle-snapped direction by the influence ratio (both
   normalised);
3. *steepness*: the segment's slope (sampled at ``steepness_samples``
   points) must stay under the maximum;
4. *snap/merge* (001 §4.1.3): a proposal that would cross a segment stops on
   it; otherwise, within the snapping distance of the proposed node, the
   nearest node or segment is the target. A node target merges by hierarchy:
   equal levels meet at the average position, a more important new road
   pulls the existing node onto its own end, a less important one moves to
   the existing node; fixed nodes never move. A segment target is split at
   the point (at its end node when that is within 0.1 SL);
5. *border check*: the segment stays in the region, off forbidden ground,
   crosses no segment, is at least ``min_segment_m`` long and keeps
   ``min_angle`` to the other segments at both of its ends.

A proposal failing a step is dropped; a node failing ``patience`` times in
a row retires for the phase (it no longer captures APs), which is how growth
ends where the APs are out of reach.

**Phase 2** (001 §4.2). First the inter-connection of phase-1 nodes (§4.2.1):
each phase-1 node connects to the strongest of the unconnected nodes closer
than ``interconnect_distance``, force = ((180° − α)/180°) ·
((threshold − |NC|)/threshold) with α the angle to the nearest ideal
direction, never closing a triangle. Then a fresh AP cloud, minus the APs
closer than ``safety_distance`` to a segment (§4.2.2); each AP attracts its
N closest nodes within RoI; phase-1 nodes attract too (§4.2.3), but not nodes
within two hops of them nor along one of the attracted node's segments, and
a branch tip that comes within KD of its attracting node joins it directly
when it is at most one SL away. KD is half of phase 1's unless set. Last,
the extra pruning of §4.2.4.

**Hierarchy** (001 §4.3.3). At each phase's end, a segment that extends a
dead end inherits its level; one that branches off is classified by the
share of all introduced APs consumed by the branch (it and what grew from
it; ``hierarchy_basis``), never above its previous segment's level; phase 1
yields primary (0) or secondary (1), phase 2 at most ``phase2_top_level``,
else tertiary (2). Levels map to highway classes through ``highways``.
During growth, for merging, a new branch counts as its phase's lower level.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, cast

import numpy as np
import shapely
from scipy import sparse
from scipy.spatial import cKDTree

from osm_expand.errors import InputError
from osm_expand.model import closest_on_segments
from synth.colonisation.network import _APs, _Network
from synth.colonisation.options import (
    MIN_ANGLE_FLOOR,
    PRIMARY,
    REFERENCE_AREA_SL2,
    ColonisationOptions,
    HierarchyBasis,
    _Phase,
)
from synth.colonisation.pruning import chain_streets, extra_pruning
from synth.colonisation.result import ColonisationResult, GrownStreet, Join
from synth.colonisation.rules import _angle_between, _first_hit, _snap_turn, connection_force, ideal_directions
from synth.flowfield import FlowField
from synth.infomaps import Raster, forbidden_cells, slopes_within


class _Colonist:
    """The state of one run: network, options, maps, counters."""

    def __init__(self, region: shapely.Geometry, forbidden: shapely.Geometry | None, options: ColonisationOptions,
                 rng: np.random.Generator, density: Raster | None, height: Raster | None, flow: FlowField | None,
                 border: Raster | None):
        self.o = options
        self.sl = options.segment_length
        self.rng = rng
        self.density, self.height, self.flow = density, height, flow
        self.region = region
        self.region_area = float(shapely.area(region))
        self.inside = region.buffer(options.edge_tolerance * self.sl)
        parts = [g for g in (forbidden, None if border is None else forbidden_cells(border))
                 if g is not None and not g.is_empty]
        self.forbidden = shapely.union_all(parts) if parts else None
        for g in (self.region, self.inside, self.forbidden):
            if g is not None:
                shapely.prepare(g)
        self.net = _Network(cell=self.sl)
        self.introduced = 0
        self.reference = 0.0
        self.ap_log: list[tuple[np.ndarray, int, np.ndarray]] = []
        self.report: dict[str, Any] = {"phase1": {}, "phase2": {}}
        self.counts: dict[str, int] = {}
        #: per edge grown: (extends a dead end, previous segment or -1, level at its start node, growth-tree parent)
        self.growth: dict[int, tuple[bool, int, int, int]] = {}
        #: per edge grown: the APs its end node killed (001 §4.3.3's "attraction points consumed")
        self.consumed: dict[int, int] = {}

    # ------------------------------------------------------------------ set-up

    def add_seeds(self, seeds: Sequence[np.ndarray]) -> None:
        """Old streets as fixed primary nodes and edges, with growth points every ``seed_spacing`` SL.

        Every vertex is a node (new streets may end on it); points are added so
        that no piece is longer than the spacing; of all these, only one every
        ``seed_spacing`` SL along each street may grow, so shape points a few
        metres apart do not each start a street.
        """
        net, step = self.net, self.o.seed_spacing * self.sl
        at: dict[tuple[float, float], int] = {}
        grows: set[int] = set()

        def node(p: np.ndarray, ref: tuple[int, int, bool]) -> int:
            key = (float(p[0]), float(p[1]))
            if key not in at:
                at[key] = net.add_node(p, fixed=True, through=True, seed_ref=ref)
            return at[key]

        for s, line in enumerate(seeds):
            pts = np.asarray(line, dtype=float).reshape(-1, 2)
            if len(pts) < 2 or not np.isfinite(pts).all():
                raise InputError(f"seed street {s}: needs at least two finite points, got {len(pts)}")
            prev = node(pts[0], (s, 0, True))
            grows.add(prev)
            since = 0.0  # distance along the street from the last growth point
            for k in range(len(pts) - 1):
                a, b = pts[k], pts[k + 1]
                length = float(np.hypot(*(b - a)))
                if length < 1e-9:
                    continue
                pieces = max(int(np.ceil(length / step - 1e-9)), 1)
                for t in np.arange(1, pieces + 1) / pieces:
                    cur = node(a + t * (b - a), (s, k, False)) if t < 1 else node(b, (s, k + 1, True))
                    self._seed_edge(prev, cur, s, k)
                    since += length / pieces
                    if since >= step - 1e-6 or (t == 1 and k == len(pts) - 2):
                        grows.add(cur)
                        since = 0.0
                    prev = cur
        xy = net.xy[:net.n]
        net.static[:net.n] = ~shapely.contains_xy(self.inside, xy[:, 0], xy[:, 1])  # beyond the edge: no growth
        net.static[np.setdiff1d(np.arange(net.n), np.fromiter(grows, dtype=np.int64, count=len(grows)))] = True

    def _seed_edge(self, u: int, v: int, s: int, k: int) -> None:
        if u != v and v not in self.net.adj[u]:
            self.net.add_edge(u, v, level=PRIMARY, phase=0, seed=(s, k))

    def _count(self, key: str) -> None:
        self.counts[key] = self.counts.get(key, 0) + 1

    def scatter(self, ph: _Phase) -> np.ndarray:
        """Fresh APs for a phase: uniform in the region, kept by the maps (001 §4.3.1, §4.2.2)."""
        o = self.o
        want = int(round(o.ap_density[ph.number - 1] * self.region_area / self.sl ** 2))
        self.reference += o.ap_density[ph.number - 1] * REFERENCE_AREA_SL2
        x0, y0, x1, y1 = self.region.bounds
        pts: list[np.ndarray] = []
        have = 0
        box_share = self.region_area / max((x1 - x0) * (y1 - y0), 1e-12)
        while have < want:
            n = int((want - have) / max(box_share, 1e-3) * 1.1) + 16
            cand = np.column_stack([self.rng.uniform(x0, x1, n), self.rng.uniform(y0, y1, n)])
            cand = cand[shapely.contains_xy(self.region, cand[:, 0], cand[:, 1])]
            pts.append(cand[: want - have])
            have += len(pts[-1])
        xy = np.vstack(pts) if pts else np.zeros((0, 2))
        scattered = len(xy)
        if self.density is not None and len(xy):
            xy = xy[self.rng.random(len(xy)) < np.clip(self.density.sample(xy), 0.0, 1.0)]
        if self.forbidden is not None and len(xy):
            xy = xy[~shapely.intersects_xy(self.forbidden, xy[:, 0], xy[:, 1])]
        kept = len(xy)
        if ph.number == 2 and o.validate_aps and len(xy):
            xy = xy[~self._near_segments(xy, o.safety_distance * self.sl)]
        rep = self.report[f"phase{ph.number}"]
        rep.update(aps_scattered=scattered, aps_on_allowed_ground=kept, aps_used=len(xy))
        self.introduced += len(xy)
        return xy

    def _near_segments(self, xy: np.ndarray, dist: float) -> np.ndarray:
        """Which points lie within ``dist`` of a live segment (001 §4.2.2)."""
        net = self.net
        live = [e for e in range(len(net.eu)) if net.ealive[e]]
        if not live:
            return np.zeros(len(xy), dtype=bool)
        ends = np.stack([net.xy[np.array([net.eu[e] for e in live])], net.xy[np.array([net.ev[e] for e in live])]],
                        axis=1)
        tree = shapely.STRtree(shapely.linestrings(ends))
        hit = tree.query(shapely.points(xy), predicate="dwithin", distance=dist)[0]
        near = np.zeros(len(xy), dtype=bool)
        near[hit] = True
        return near

    # ------------------------------------------------------------------ one phase

    def run_phase(self, ph: _Phase) -> None:
        o, net = self.o, self.net
        scattered = self.scatter(ph)
        self.ap_log.append((scattered, ph.number, np.ones(len(scattered), dtype=bool)))
        node_attr = np.zeros(0, dtype=np.int64)
        if ph.number == 2:
            node_attr = np.array([m for m in range(net.n) if net.phase[m] == 1 and net.adj[m]], dtype=np.int64)
        xy = np.vstack([scattered, net.xy[node_attr]]) if len(node_attr) else scattered
        node = np.concatenate([np.full(len(scattered), -1, dtype=np.int64), node_attr])
        aps = _APs(xy=xy, node=node, alive=np.ones(len(xy), dtype=bool), active=np.zeros(len(xy), dtype=bool),
                   tree=cKDTree(xy if len(xy) else np.zeros((0, 2))))
        attractor_of = {int(m): len(scattered) + i for i, m in enumerate(node_attr.tolist())}
        net.fails[:] = 0
        net.retired[:] = net.static
        roi = o.radius_of_influence * self.sl
        self._activate(aps, net.xy[np.flatnonzero(~net.retired[:net.n])], roi)
        iterations = grown = 0
        for iterations in range(1, o.max_iterations + 1):  # noqa: B007 (read after the loop: the count run)
            pairs = self._influence(aps, ph, roi)
            if pairs is None:
                break
            touched, made, influencers, progress = self._grow_all(pairs, aps, ph)
            grown += len(touched)
            died = self._kill(aps, touched, made, influencers, ph)
            done = [attractor_of[m] for m in touched.tolist() if m in attractor_of]
            if done:  # a node attractor reached by a new segment has done its work
                died |= bool(aps.alive[done].any())
                aps.alive[done] = False
            self._activate(aps, net.xy[touched], roi)
            if not progress and not died:
                break
        self._classify(ph)
        self.ap_log[-1] = (scattered, ph.number, aps.alive[: len(scattered)].copy())
        self.report[f"phase{ph.number}"].update(iterations=iterations, growth_steps=grown,
                                                aps_alive_at_end=int(aps.alive[: len(scattered)].sum()))

    def _activate(self, aps: _APs, at: np.ndarray, roi: float) -> None:
        if len(at) and len(aps.xy):
            hits = aps.tree.query_ball_point(at, roi, return_sorted=False)
            if len(hits):
                flat = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits])
                aps.active[flat] = True

    def _live_nodes(self) -> np.ndarray:
        return np.flatnonzero(~self.net.retired[:self.net.n])

    def _influence(self, aps: _APs, ph: _Phase, roi: float) -> tuple[np.ndarray, np.ndarray] | None:
        """(node, AP) pairs of this iteration: each live AP to its N nearest live nodes within RoI."""
        net = self.net
        live_ap = np.flatnonzero(aps.alive & aps.active)
        nodes = self._live_nodes()
        if not len(live_ap) or not len(nodes):
            return None
        tree = cKDTree(net.xy[nodes])
        regular = live_ap[aps.node[live_ap] < 0]
        by_node = live_ap[aps.node[live_ap] >= 0]
        pair_node, pair_ap = [], []
        for group, extra in ((regular, 0), (by_node, 6)):
            if not len(group):
                continue
            k = min(ph.nodes_per_ap + extra, len(nodes))
            dist, idx = tree.query(aps.xy[group], k=k, distance_upper_bound=roi)
            dist, idx = dist.reshape(len(group), k), idx.reshape(len(group), k)
            ok = np.isfinite(dist)
            if extra:
                ok = self._node_attractor_ok(ok, idx, nodes, aps.node[group], ph)
            rank = np.cumsum(ok, axis=1)
            ok &= rank <= ph.nodes_per_ap
            rows, cols = np.nonzero(ok)
            pair_node.append(nodes[idx[rows, cols]])
            pair_ap.append(group[rows])
        if not pair_node:
            return None
        pn, pa = np.concatenate(pair_node), np.concatenate(pair_ap)
        if self.height is not None and len(pn):
            keep = slopes_within(self.height, net.xy[pn], aps.xy[pa], max_steepness_deg=self.o.max_steepness_deg,
                                 samples=self.o.steepness_samples)
            pn, pa = pn[keep], pa[keep]
        if not len(pn):
            return None
        return pn, pa

    def _node_attractor_ok(self, ok: np.ndarray, idx: np.ndarray, nodes: np.ndarray, attractor: np.ndarray,
                           ph: _Phase) -> np.ndarray:
        """A phase-1 node attracts no node within two hops of it, nor one whose segment to it runs along
        one of that node's segments (closer than the minimum angle): both would fail anyway."""
        net = self.net
        rows, cols = np.nonzero(ok)
        if not len(rows):
            return ok
        a = attractor[rows]
        m = nodes[idx[rows, cols]]
        live = np.flatnonzero(np.asarray(net.ealive, dtype=bool))
        u, v = np.take(net.eu, live), np.take(net.ev, live)
        adj = sparse.csr_matrix((np.ones(2 * len(live)), (np.concatenate([u, v]), np.concatenate([v, u]))),
                                shape=(net.n, net.n))
        reach = adj + adj @ adj
        near = (a == m) | (np.asarray(reach[a, m]).ravel() > 0)
        # segments at m: expand each pair by m's degree
        deg = np.diff(adj.indptr)[m]
        pair = np.repeat(np.arange(len(m)), deg)
        first = np.repeat(adj.indptr[m], deg)
        offset = np.arange(len(pair)) - np.repeat(np.cumsum(deg) - deg, deg)
        nb = adj.indices[first + offset]
        to_a = net.xy[a[pair]] - net.xy[m[pair]]
        to_nb = net.xy[nb] - net.xy[m[pair]]
        ang = _angle_between(np.degrees(np.arctan2(to_a[:, 1], to_a[:, 0])),
                             np.degrees(np.arctan2(to_nb[:, 1], to_nb[:, 0])))
        along = np.bincount(pair[ang < ph.min_angle], minlength=len(m)) > 0
        out = ok.copy()
        out[rows, cols] = ~(near | along)
        return out

    def _grow_all(self, pairs: tuple[np.ndarray, np.ndarray], aps: _APs,
                  ph: _Phase) -> tuple[np.ndarray, np.ndarray, list[np.ndarray], bool]:
        """Grow every influenced node once, in node order.

        Returns the nodes created or reached, the segments made, the APs that
        influenced each of those growths, and whether anything changed (growth
        or a retirement).
        """
        net = self.net
        pn, pa = pairs
        d = aps.xy[pa] - net.xy[pn]
        d /= np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-12)[:, None]
        order = np.argsort(pn, kind="stable")
        pn, pa, d = pn[order], pa[order], d[order]
        nodes, start = np.unique(pn, return_index=True)
        mean = np.add.reduceat(d, start, axis=0) if len(pn) else np.zeros((0, 2))
        directions = self._proposals(nodes, mean, ph)
        by_node = np.split(pa, start[1:])
        touched: list[int] = []
        made: list[int] = []
        growers: list[np.ndarray] = []
        progress = False
        for n, direction, influencers in zip(nodes.tolist(), directions, by_node):
            if direction is None:
                progress |= self._fail(n, "no_direction")
                continue
            reached = self._attempt(n, direction, ph)
            if reached is None:
                progress |= self._fail(n, None)
                continue
            net.fails[n] = 0
            touched.append(reached[0])
            made.append(reached[1])
            growers.append(influencers)
            progress = True
        return np.asarray(touched, dtype=np.int64), np.asarray(made, dtype=np.int64), growers, progress

    def _fail(self, n: int, why: str | None) -> bool:
        """Count a failed attempt; True when the node retires (the live set changed)."""
        if why:
            self._count(f"rejected_{why}")
        net = self.net
        net.fails[n] += 1
        if net.fails[n] >= self.o.patience and not net.retired[n]:
            net.retired[n] = True
            return True
        return False

    def _proposals(self, nodes: np.ndarray, mean: np.ndarray, ph: _Phase) -> list[np.ndarray | None]:
        """Steps 1-2: angle snap, then flow blend, for each growing node's mean AP direction."""
        net = self.net
        out: list[np.ndarray | None] = []
        for n, m in zip(nodes.tolist(), mean):
            norm = float(np.hypot(*m))
            if norm < 1e-9:
                out.append(None)
                continue
            d = self._angle_snap(n, m / norm, ph)
            if self.flow is not None and ph.flow > 0:
                d = self._flow_blend(net.xy[n] + self.sl * d, d, ph)
            out.append(d)
        return out

    def _angle_snap(self, n: int, d: np.ndarray, ph: _Phase) -> np.ndarray:
        """Step 1: the turn from the parent segment into the allowed range (001 §4.1.2)."""
        net = self.net
        if net.through[n] or net.parent[n] < 0:
            inc = net.directions(n)
            if not len(inc):
                return d
            ref = -inc[0]  # along the street; the orientation closer to ``d`` is chosen below
            if ref @ d < 0:
                ref = -ref
        else:
            ref = net.xy[n] - net.xy[net.parent[n]]
            ref = ref / max(float(np.hypot(*ref)), 1e-12)
        rx, ry = float(ref[0]), float(ref[1])
        turn = math.degrees(math.atan2(rx * d[1] - ry * d[0], rx * d[0] + ry * d[1]))
        snapped = math.radians(_snap_turn(turn, ph.lo, ph.hi, ph.tolerance, ph.straight))
        c, s = math.cos(snapped), math.sin(snapped)
        return np.array([c * rx - s * ry, s * rx + c * ry])

    def _flow_blend(self, at: np.ndarray, d: np.ndarray, ph: _Phase) -> np.ndarray:
        """Step 2: the flow direction or its perpendicular nearest to ``d``, blended by the influence (001 §4.3.2).

        The options are along the flow and both perpendiculars, never against
        the flow: 001 §5.2 has a source "prevent any suggested road to grow
        towards it" and sinks "force the network to grow towards them".
        """
        assert self.flow is not None  # called only with a flow field (see the caller)
        f = self.flow.direction(at[None, :])[0]
        if not f.any():
            return d
        options = np.array([f, [-f[1], f[0]], [f[1], -f[0]]])
        snapped = options[int(np.argmax(options @ d))]
        blend = ph.flow * snapped + (1.0 - ph.flow) * d
        norm = float(np.hypot(*blend))
        return blend / norm if norm > 1e-9 else d

    def _start(self, n: int, ph: _Phase) -> tuple[int, tuple[bool, int, int, int]]:
        """A new segment's provisional level and its growth record (see :meth:`_classify`).

        Until the phase ends, an extension has its previous segment's level and
        a branch its phase's lower level; old streets are primary throughout.
        """
        net = self.net
        extends = len(net.adj[n]) == 1 and not net.through[n]
        if extends:
            prev = next(iter(net.adj[n].values()))
        else:
            p = net.parent[n]
            prev = net.adj[n].get(p, -1) if p >= 0 else -1
        creator = net.creator[n]
        tree_parent = creator if creator >= 0 and net.ephase[creator] == ph.number else -1
        level = max(net.elevel[prev], ph.top) if extends else ph.bottom
        return level, (extends, prev, net.node_level(n), tree_parent)

    def _classify(self, ph: _Phase) -> None:
        """001 §4.3.3 at the phase's end: levels of the segments grown in it.

        A branch (a segment leaving a node that is not a dead end) is classified
        by the share of APs it consumed, it and everything grown from it, among
        all APs introduced (``hierarchy_basis``): at or above the phase's
        threshold it takes the phase's upper level, else the lower one, but never
        above its previous segment's level. An extension of a dead end inherits
        its previous segment's level. Split halves keep their segment's level.
        """
        net = self.net
        mine = sorted(e for e in self.growth if net.ephase[e] == ph.number)
        total = {e: self.consumed.get(e, 0) for e in mine}
        for e in reversed(mine):  # children are created after their parents
            parent = self.growth[e][3]
            if parent >= 0:
                total[parent] += total[e]
        denominator = self.introduced if self.o.hierarchy_basis == HierarchyBasis.INTRODUCED else self.reference
        final: dict[int, int] = {}

        def level_of(x: int) -> int:
            return final.get(net.eorigin[x], net.elevel[x])

        for e in mine:
            extends, prev, start_level, _ = self.growth[e]
            if extends and prev >= 0:
                level = level_of(prev)
            else:
                level = ph.top if total[e] / max(denominator, 1.0) >= ph.threshold else ph.bottom
                level = max(level, level_of(prev) if prev >= 0 else start_level)
            final[e] = max(level, ph.top)
        for x in range(len(net.eu)):
            if net.ealive[x] and net.eorigin[x] in final:
                net.elevel[x] = final[net.eorigin[x]]

    def _attempt(self, n: int, d: np.ndarray, ph: _Phase) -> tuple[int, int] | None:
        """Steps 3-5 for one proposal; the node the new segment reaches and the segment, or None."""
        net, o = self.net, self.o
        p = net.xy[n].copy()
        q = p + self.sl * d
        if self.height is not None and not slopes_within(self.height, p[None], q[None],
                                                         max_steepness_deg=o.max_steepness_deg,
                                                         samples=o.steepness_samples)[0]:
            self._count("rejected_steep")
            return None
        level, record = self._start(n, ph)
        kind, target, at = self._snap_target(q, n)
        if kind == "node":
            reached = self._join_node(n, target, q, level, ph)
        elif kind == "split":
            reached = self._join_segment(n, target, at, level, ph)
        elif not shapely.contains_xy(self.region, q[0], q[1]):
            self._count("rejected_outside")
            reached = None
        elif self._segment_ok(p, q, n, -1, ph, target_dirs=np.zeros((0, 2))):
            m = net.add_node(q, parent=n, phase=ph.number, creator=len(net.eu))
            reached = (m, net.add_edge(n, m, level=level, phase=ph.number))
        else:
            reached = None
        if reached is not None:
            self.growth[reached[1]] = record
        return reached

    def _snap_target(self, q: np.ndarray, n: int) -> tuple[str, int, np.ndarray]:
        """Step 4's target: ("node", id) to merge, ("split", edge) at a point on it, or ("free", -1).

        A proposal that would cross a segment stops where it first meets it
        (001 §4.1.3 lists crossing among the cases snapping resolves); else the
        nearest node or segment within the snapping distance of the proposed
        node is taken. A point within ``max(min_segment_m, 0.1 SL)`` of a
        segment's end is that end node, so no split leaves a sliver.
        """
        net, o = self.net, self.o
        p = net.xy[n]
        radius = o.snap_distance * self.sl
        centre = 0.5 * (p + q)
        slots = net.segments_near(centre, 0.5 * self.sl + radius)
        if len(slots):
            ends = net.index.ends[slots]
            slots = slots[(ends[:, 0] != n) & (ends[:, 1] != n)]
        if not len(slots):
            return "free", -1, q
        a, b = net.index.a[slots], net.index.b[slots]
        hit = _first_hit(p, q, a, b)
        if hit is not None:
            k, t_along = hit
        else:
            t_all, _, dist = closest_on_segments(q, a, b)
            k = int(np.argmin(dist))
            if dist[k] > radius:
                return "free", -1, q
            t_along = float(t_all[k])
        u, v = (int(x) for x in net.index.ends[slots[k]])
        length = float(np.hypot(*(b[k] - a[k])))
        margin = max(o.min_segment_m, 0.1 * self.sl)
        along = t_along * length
        if along <= margin:
            return "node", u, q
        if length - along <= margin:
            return "node", v, q
        return "split", net.adj[u][v], a[k] + t_along * (b[k] - a[k])

    def _join_node(self, n: int, m: int, q: np.ndarray, level: int, ph: _Phase) -> tuple[int, int] | None:
        """Merge the proposed node ``q`` with node ``m`` by hierarchy (001 §4.1.3, fig. 77)."""
        net = self.net
        if m == n or m in net.adj[n]:
            self._count("rejected_merge_neighbour")
            return None
        old = net.xy[m].copy()
        mine = net.node_level(m)
        target = old
        if not net.fixed[m]:
            if level == mine:
                target = 0.5 * (old + q)
            elif level < mine:
                target = q
        moved = bool(np.any(target != old)) and self._relocate(m, target, ph)
        p = net.xy[n]
        if not self._segment_ok(p, net.xy[m], n, m, ph, target_dirs=net.directions(m)):
            if moved:
                self._relocate(m, old, ph, check=False)
            return None
        e = net.add_edge(n, m, level=level, phase=ph.number)
        self._count("merged_moved" if moved else "merged")
        return m, e

    def _relocate(self, m: int, to: np.ndarray, ph: _Phase, *, check: bool = True) -> bool:
        """Move node ``m`` with its segments if they stay valid (else leave it); whether it moved."""
        net = self.net
        if check and not shapely.contains_xy(self.region, to[0], to[1]):
            return False
        edges = list(net.adj[m].items())
        if check and len(edges) > 1:  # the node's own segments must not fold onto each other
            d = net.directions(m, at=to)
            cos = d @ d.T - 2.0 * np.eye(len(d))
            if (cos > math.cos(math.radians(MIN_ANGLE_FLOOR))).any():
                return False
        for _, e in edges:
            net.index.remove(net.eslot[e])
        ok = True
        if check:
            for k, _ in edges:
                if not self._segment_ok(net.xy[k], to, k, m, ph, target_dirs=None, angles=False):
                    ok = False
                    break
        if ok:
            net.xy[m] = to
        for _, e in edges:
            u, v = net.eu[e], net.ev[e]
            net.eslot[e] = net.index.add(net.xy[u].copy(), net.xy[v].copy(), u, v)
        return ok

    def _join_segment(self, n: int, e: int, foot: np.ndarray, level: int, ph: _Phase) -> tuple[int, int] | None:
        """Snap onto edge ``e`` at ``foot``, splitting it (001 §4.1.3, fig. 77 left)."""
        net = self.net
        u, v = net.eu[e], net.ev[e]
        if u in net.adj[n] or v in net.adj[n]:  # would close a triangle with a segment n already has
            self._count("rejected_split_triangle")
            return None
        if not shapely.contains_xy(self.inside, foot[0], foot[1]):
            self._count("rejected_outside")
            return None
        d_half = np.array([net.xy[u] - foot, net.xy[v] - foot])
        d_half /= np.maximum(np.hypot(d_half[:, 0], d_half[:, 1]), 1e-12)[:, None]
        net.index.remove(net.eslot[e])  # the split segment would touch the new one at the foot
        if not self._segment_ok(net.xy[n], foot, n, -1, ph, target_dirs=d_half):
            net.eslot[e] = net.index.add(net.xy[u].copy(), net.xy[v].copy(), u, v)
            return None
        net.remove_edge(e)
        fixed = net.eseed[e][0] >= 0
        seed_ref = (net.eseed[e][0], net.eseed[e][1], False) if fixed else None
        s = net.add_node(foot, fixed=fixed, through=True, parent=u, phase=0 if fixed else net.ephase[e],
                         seed_ref=seed_ref)
        for a in (u, v):
            net.add_edge(a, s, level=net.elevel[e], phase=net.ephase[e], seed=net.eseed[e], origin=net.eorigin[e])
        self._count("snapped_to_segment")
        return s, net.add_edge(n, s, level=level, phase=ph.number)

    def _segment_ok(self, a: np.ndarray, b: np.ndarray, u: int, v: int, ph: _Phase,
                    target_dirs: np.ndarray | None, angles: bool = True) -> bool:
        """Step 5, the border check: length, angles at both ends, crossings, region, forbidden ground."""
        net, o = self.net, self.o
        vec = b - a
        length = float(np.hypot(*vec))
        if length < o.min_segment_m:
            self._count("rejected_short")
            return False
        if angles:
            unit = vec / length
            # closer than min_angle means a larger cosine; never below MIN_ANGLE_FLOOR, so no overlap
            limit = math.cos(math.radians(max(ph.min_angle, MIN_ANGLE_FLOOR))) + 1e-12
            at_u = net.directions(u) if u >= 0 else None
            for dirs, heading in ((at_u, unit), (target_dirs, -unit)):
                if dirs is not None and len(dirs) and (dirs @ heading > limit).any():
                    self._count("rejected_angle")
                    return False
        if net.index.crosses(a, b, u, v if v >= 0 else -1):
            self._count("rejected_crossing")
            return False
        line = shapely.LineString([a, b])
        if not shapely.covers(self.inside, line):
            self._count("rejected_outside")
            return False
        if self.forbidden is not None and shapely.intersects(self.forbidden, line):
            self._count("rejected_forbidden")
            return False
        return True

    def _kill(self, aps: _APs, touched: np.ndarray, made: np.ndarray, influencers: list[np.ndarray],
              ph: _Phase) -> bool:
        """The APs that influenced a growth and lie within KD of the node it reached die (001 §3.1).

        They count as consumed by the new segment. Whether any died.
        """
        net = self.net
        died = False
        for t, e, h in zip(touched.tolist(), made.tolist(), influencers):
            h = h[aps.alive[h]]
            h = h[np.hypot(*(aps.xy[h] - net.xy[t]).T) < ph.kill] if len(h) else h
            # a node attractor outlives its own new branches and its neighbours (001 §4.2.3 leaves this open)
            own = np.array([a >= 0 and (a == t or t in net.adj[a]) for a in aps.node[h].tolist()], dtype=bool)
            h = h[~own] if len(h) else h
            if not len(h):
                continue
            if net.creator[t] == e and (aps.node[h] >= 0).any():
                self._arrive(t, e, aps, h[aps.node[h] >= 0], ph)
            aps.alive[h] = False
            self.consumed[e] = self.consumed.get(e, 0) + int((aps.node[h] < 0).sum())
            died = True
        return died

    def _arrive(self, t: int, e: int, aps: _APs, attractors: np.ndarray, ph: _Phase) -> None:
        """A branch tip ``t`` (made by edge ``e``) within KD of phase-1 nodes that attract joins the nearest one.

        001 §4.2.3 makes phase-1 nodes attractors so that branches connect the
        network; killing them at KD, as any AP, would stop each branch short of
        them. So the tip connects straight to the nearest of them no more than
        one SL away (one more growth step) when that segment passes the border
        check and closes no triangle; the segment extends the tip's branch.
        """
        net = self.net
        nodes = aps.node[attractors]
        dist = np.hypot(*(net.xy[nodes] - net.xy[t]).T)
        order = np.argsort(dist, kind="stable")
        order = order[dist[order] <= self.sl]
        for a in nodes[order].tolist():
            if a in net.adj[t] or net.adj[t].keys() & net.adj[a].keys():
                continue
            if self.height is not None and not slopes_within(
                    self.height, net.xy[t][None], net.xy[a][None], max_steepness_deg=self.o.max_steepness_deg,
                    samples=self.o.steepness_samples)[0]:
                continue
            if self._segment_ok(net.xy[t], net.xy[a], t, a, ph, target_dirs=net.directions(a)):
                link = net.add_edge(t, a, level=net.elevel[e], phase=ph.number)
                self.growth[link] = (True, e, net.elevel[e], e)
                self._count("arrived_at_attractor")
                return

    # ------------------------------------------------------------------ phase 2's first step and the end

    def interconnect(self, ph: _Phase) -> None:
        """001 §4.2.1: each phase-1 node connects to its strongest unconnected neighbour, no triangles."""
        net, o = self.net, self.o
        threshold = o.interconnect_distance * self.sl
        nodes = np.array([m for m in range(net.n) if net.adj[m]], dtype=np.int64)
        if not len(nodes) or threshold <= 0:
            return
        tree = cKDTree(net.xy[nodes])
        made = 0
        for n in range(net.n):
            if net.phase[n] != 1 or not net.adj[n]:
                continue
            cand = nodes[np.asarray(tree.query_ball_point(net.xy[n], threshold), dtype=np.int64)]
            cand = np.array([c for c in cand.tolist() if c != n and c not in net.adj[n]
                             and not (net.adj[n].keys() & net.adj[c].keys())], dtype=np.int64)
            if not len(cand):
                continue
            vec = net.xy[cand] - net.xy[n]
            dist = np.hypot(vec[:, 0], vec[:, 1])
            incoming = None
            p = net.parent[n]
            if p >= 0:
                incoming = net.xy[n] - net.xy[p]
                incoming = incoming / max(float(np.hypot(*incoming)), 1e-12)
            ideal = ideal_directions(net.directions(n), incoming)
            heading = np.degrees(np.arctan2(vec[:, 1], vec[:, 0]))
            alpha = (_angle_between(heading[:, None], ideal[None, :]).min(axis=1) if len(ideal)
                     else np.zeros(len(cand)))
            force = connection_force(alpha, dist, threshold)
            for k in np.argsort(-force, kind="stable").tolist():
                c = int(cand[k])
                if force[k] <= 0:
                    break
                if self.height is not None and not slopes_within(
                        self.height, net.xy[n][None], net.xy[c][None], max_steepness_deg=o.max_steepness_deg,
                        samples=o.steepness_samples)[0]:
                    continue
                if self._segment_ok(net.xy[n], net.xy[c], n, c, ph, target_dirs=net.directions(c)):
                    net.add_edge(n, c, level=max(ph.bottom, ph.top), phase=2)
                    made += 1
                    break
        self.report["phase2"]["interconnections"] = made

    def result(self, flow: FlowField | None) -> ColonisationResult:
        net, o = self.net, self.o
        grown = np.array([e for e in range(len(net.eu)) if net.ealive[e] and net.eseed[e][0] < 0], dtype=np.int64)
        if o.prune and len(grown):
            live = np.array([e for e in range(len(net.eu)) if net.ealive[e]], dtype=np.int64)
            pairs = np.column_stack([np.take(net.eu, live), np.take(net.ev, live)])
            length = np.hypot(*(net.xy[pairs[:, 0]] - net.xy[pairs[:, 1]]).T)
            keep = extra_pruning(pairs, deletable=np.array([net.eseed[e][0] < 0 for e in live]),
                                 level=np.take(net.elevel, live), length=length)
            for e in live[~keep].tolist():
                net.remove_edge(e)
            self.report["pruned_edges"] = int((~keep).sum())
            grown = np.array([e for e in range(len(net.eu)) if net.ealive[e] and net.eseed[e][0] < 0],
                             dtype=np.int64)
        xy = net.xy[:net.n].copy()
        edges = np.column_stack([np.take(net.eu, grown), np.take(net.ev, grown)]).reshape(-1, 2).astype(np.int64)
        level = np.asarray(np.take(net.elevel, grown), dtype=np.int64).reshape(-1)
        phase = np.asarray(np.take(net.ephase, grown), dtype=np.int64).reshape(-1)
        degree = np.fromiter((len(a) for a in net.adj), dtype=np.int64, count=net.n)
        chains = chain_streets(edges, xy, level, degree=degree, max_turn_deg=o.street_turn_deg)
        edge_of = {(int(u), int(v)): k for k, (u, v) in enumerate(edges.tolist())}
        streets = []
        for path in chains:
            lv = int(level[edge_of.get((path[0], path[1]), edge_of.get((path[1], path[0]), 0))])
            streets.append(GrownStreet(nodes=tuple(path), xy=xy[path], level=lv, highway=o.highways[lv]))
        joined = sorted({int(m) for m in edges.ravel() if net.fixed[m]})
        seed_of = cast(list[tuple[int, int, bool]], net.seed_ref)  # the joined nodes are fixed: each has one
        joins = tuple(Join(node=m, xy=(float(xy[m, 0]), float(xy[m, 1])), seed=seed_of[m][0],
                           segment=seed_of[m][1], vertex=seed_of[m][2]) for m in joined)
        ap_xy = np.vstack([a for a, _, _ in self.ap_log]) if self.ap_log else np.zeros((0, 2))
        ap_phase = np.concatenate([np.full(len(a), p) for a, p, _ in self.ap_log]) if self.ap_log else np.zeros(0)
        ap_alive = np.concatenate([al for _, _, al in self.ap_log]) if self.ap_log else np.zeros(0, dtype=bool)
        self.report.update(nodes=int((degree > 0).sum()), grown_edges=len(edges), streets=len(streets),
                           joins=len(joins), levels={str(k): int((level == k).sum()) for k in range(3)},
                           events=dict(sorted(self.counts.items())))
        return ColonisationResult(xy=xy, fixed=np.asarray(net.fixed, dtype=bool), edges=edges, edge_level=level,
                                  edge_phase=phase, streets=tuple(streets), joins=joins, attraction_xy=ap_xy,
                                  attraction_phase=ap_phase.astype(np.int64), attraction_alive=ap_alive,
                                  flow=flow, options=o, report=self.report)


def colonise(region: shapely.Polygon | shapely.MultiPolygon, *, seeds: Sequence[np.ndarray],
             forbidden: shapely.Geometry | None, options: ColonisationOptions, rng: np.random.Generator,
             density: Raster | None = None, height: Raster | None = None, flow: FlowField | None = None,
             border: Raster | None = None) -> ColonisationResult:
    """Grow streets in ``region`` from the old streets by space colonisation (001 ch. 4).

    Parameters
    ----------
    region : shapely Polygon or MultiPolygon
        Where the new streets go, metres in the local projection.
    seeds : sequence of ndarray, each shape (k, 2), k >= 2
        Polylines of the old town's streets touching the region, metres. Their
        nodes are fixed primary nodes; growth starts from them (and from points
        every ``seed_spacing`` SL along them) and new streets may end on them.
    forbidden : shapely geometry, optional
        Water, the old town, parks, …: no AP there, no segment touches it.
    options : ColonisationOptions
        Distances in multiples of ``options.segment_length``.
    rng : numpy.random.Generator
        The only source of randomness (the AP clouds); same state, same result.
    density : Raster, optional
        Density map in [0, 1], larger denser: an AP is kept with this probability.
    height : Raster, optional
        Height map in metres for the steepness checks.
    flow : FlowField, optional
        Flow field steering segments (blended per phase by ``flow_influence``).
    border : Raster, optional
        Border map: cells > 0.5 are forbidden, like ``forbidden``.

    Returns
    -------
    ColonisationResult
        The grown graph, its streets and joins, the APs, and a report. The new
        segments cross no segment (old or new) except at a shared node, are at
        least ``min_segment_m`` long, touch nothing forbidden and stay within
        the region (up to ``edge_tolerance`` SL, where they start on old streets
        along its edge).
    """
    if region is None or region.is_empty or not region.area > 0:
        raise InputError("colonisation region is empty")
    grower = _Colonist(region, forbidden, options, rng, density, height, flow, border)
    grower.add_seeds(seeds)
    grower.run_phase(_Phase.of(options, 1))
    if options.second_phase:
        ph2 = _Phase.of(options, 2)
        if options.interconnect:
            grower.interconnect(ph2)
        grower.run_phase(ph2)
    return grower.result(flow)
