"""The random walk of 004 §3.1 (after Aliaga et al. 2008): connect a junction cloud into streets.

Each junction carries up to two *records*, one per street that went through
it in the example: the street's Gravelius level, the mean and spread of its
junction spacing and turning angle, and how many segments it had there (two
when it passed through, one where it ended). Streets are drawn level by
level, 0 first. A walk starts at a free record, preferably where a street
ended, and steps to the most probable target:

    P = exp(-½ ((L - μ_L)/σ_L)²) · exp(-½ ((θ - μ_θ)/σ_θ)²)

with L the step length and θ the turn from the previous step (no angle term
on a walk's first step), times a *consistency* factor beyond the thesis: a
Gaussian of how far the target record's stored statistics are from the
walking street's, so a walk keeps to junctions that came from a street like
itself (on by default).

P is zero when the target has no free record of the walk's level, the step
would cross a segment already drawn or an obstacle, pass a junction closer
than the snapping distance without stopping there (002's snapping rule), or
P falls below ``threshold``. Joining the loose end of a drawn piece of the
same street also weighs the turn this makes there. The walk takes the *maximum*, as the thesis does (its figure
1), because sampling lowers both recall and precision. A record ending a
street takes one segment, so walks stop where the example's streets stopped;
a walk reaching a record whose earlier walk ended there joins it and stops.

Within a level, steps are laid down most confident first: passes over every
record with free room at thresholds 0.9, 0.6, 0.3, 0.1 and finally
``threshold``, so an ambiguous choice is made only after the clear ones have
claimed their junctions. Records are visited street ends first, clearest
first step first; the seed breaks near-ties, which is what makes two runs
differ. Streets are read off at the end as chains of linked records.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.spatial import cKDTree

from osm_expand.model import closest_on_segments
from synth.segment_index import SegmentIndex

#: The level of a border junction's record: a target for walks of every level.
ANY_LEVEL = -2


@dataclass(frozen=True)
class WalkOptions:
    #: Transitions less probable than this are never taken (004 §3.1 gives no number).
    threshold: float = 0.01
    #: Candidates are searched within μ_L + reach · σ_L of the base junction.
    reach: float = 3.0
    #: Weigh targets by how much their stored street statistics resemble the walking street's ...
    consistency: bool = True
    #: ... measured in units of this many of the walking street's standard deviations.
    consistency_width: float = 0.5
    #: A step may not pass closer than this to another junction (m; 002's snapping rule) ...
    snap: float = 20.0
    #: ... nor closer than this share of its own length.
    snap_share: float = 0.15
    #: After all levels, a street left dangling, or a side street that never started from a
    #: drawn junction, takes one step to a free junction of any level (growth: the example has
    #: no dead ends and its side streets meet something; reproduction keeps the thesis's rule).
    complete: bool = False
    #: A completion step meets the segments already at either end at no less than this angle (degrees).
    min_side_angle: float = 25.0


@dataclass(frozen=True)
class NodeCloud:
    """Junctions to connect, with their two records each (level -1: no record)."""

    xy: np.ndarray  # (N, 2)
    level: np.ndarray  # (N, 2)
    length_mean: np.ndarray
    length_std: np.ndarray
    angle_mean: np.ndarray
    angle_std: np.ndarray
    cap: np.ndarray  # (N, 2) segments allowed per record

    def __len__(self) -> int:
        return len(self.xy)

    @classmethod
    def from_example(cls, ex, take: np.ndarray | None = None, xy: np.ndarray | None = None) -> NodeCloud:
        """The example's junctions (or those in ``take``, placed at ``xy``) with their records."""
        pick = slice(None) if take is None else take
        return cls(xy=(ex.xy[pick] if xy is None else xy).copy(), level=ex.level[pick],
                   length_mean=ex.length_mean[pick], length_std=ex.length_std[pick],
                   angle_mean=ex.angle_mean[pick], angle_std=ex.angle_std[pick], cap=ex.record_cap[pick])

    def stacked(self, other: NodeCloud) -> NodeCloud:
        """This cloud followed by ``other`` (junction ids of ``other`` shift by ``len(self)``)."""
        return NodeCloud(**{f: np.concatenate([getattr(self, f), getattr(other, f)]) for f in
                            ("xy", "level", "length_mean", "length_std", "angle_mean", "angle_std", "cap")})


@dataclass
class WalkResult:
    streets: list[tuple[int, list[int]]] = field(default_factory=list)  # (level, junction ids)
    #: Every segment drawn, and the fixed ones, for later stages that must not cross them either ...
    drawn: SegmentIndex | None = None
    #: ... with the id of each drawn segment a–b in it, under (a, b) and (b, a).
    segment: dict[tuple[int, int], int] = field(default_factory=dict)

    @property
    def segments(self) -> set[tuple[int, int]]:
        return {(min(a, b), max(a, b)) for _, path in self.streets for a, b in zip(path, path[1:])}


class _Walker:
    def __init__(self, cloud: NodeCloud, opts: WalkOptions, obstacles, cell: float):
        self.c, self.opts = cloud, opts
        self.tree = cKDTree(cloud.xy)
        self.used = np.zeros_like(cloud.cap)
        self.links: dict[tuple[int, int], list[tuple[int, int]]] = {}
        self.index = SegmentIndex(cell)
        self.edges: set[tuple[int, int]] = set()
        self.adjacent: dict[int, list[int]] = {}
        self.segment: dict[tuple[int, int], int] = {}
        self.on_street = np.zeros(len(cloud.xy), dtype=bool)  # junctions of the street being walked
        self.obstacles = obstacles
        if obstacles is not None:
            shapely.prepare(obstacles)

    def scores(self, cur: int, rec: int, prev: int | None, level: int | None):
        """Candidate targets, the record each would use, and their transition probabilities."""
        c = self.c
        mu, sd = c.length_mean[cur, rec], c.length_std[cur, rec]
        cand = np.asarray(self.tree.query_ball_point(c.xy[cur], mu + self.opts.reach * sd), dtype=np.int64)
        # a record is free if no walk took it, or the walk that took it ended there (it joins)
        same = (c.level[cand] != -1) if level is None else ((c.level[cand] == level) | (c.level[cand] == ANY_LEVEL))
        free = same & (self.used[cand] < c.cap[cand]) & (c.cap[cand] > 0)
        keep = free.any(axis=1) & (cand != cur)
        keep &= ~self.on_street[cand]  # a street does not come back to itself
        cand, free = cand[keep], free[keep]
        if len(cand) == 0:
            return cand, cand, np.zeros(0)
        rec_c = self._pick_record(cand, free, cur, rec)
        d = c.xy[cand] - c.xy[cur]
        length = np.hypot(*d.T)
        p = np.exp(-0.5 * ((length - mu) / sd) ** 2)
        if prev is not None:
            h = c.xy[cur] - c.xy[prev]
            turn = np.degrees(np.arctan2(h[0] * d[:, 1] - h[1] * d[:, 0], d @ h))
            p = p * np.exp(-0.5 * ((turn - c.angle_mean[cur, rec]) / c.angle_std[cur, rec]) ** 2)
        if self.opts.consistency and level is not None:
            p = p * self._consistency(cur, rec, cand, rec_c)
        return cand, rec_c, p * self._join_turn(cur, cand, rec_c)

    def _join_turn(self, cur: int, cand: np.ndarray, rec_c: np.ndarray) -> np.ndarray:
        """Joining the loose end of a drawn piece makes a turn there too; weigh it by that street's angles."""
        c = self.c
        factor = np.ones(len(cand))
        for i in np.flatnonzero(self.used[cand, rec_c] == 1).tolist():
            t, r = int(cand[i]), int(rec_c[i])
            if c.level[t, r] == ANY_LEVEL:
                continue
            e = self.links[(t, r)][0][0]
            h, d = c.xy[t] - c.xy[e], c.xy[cur] - c.xy[t]
            turn = np.degrees(np.arctan2(h[0] * d[1] - h[1] * d[0], h @ d))
            factor[i] = np.exp(-0.5 * ((turn - c.angle_mean[t, r]) / c.angle_std[t, r]) ** 2)
        return factor

    def _consistency(self, cur: int, rec: int, cand: np.ndarray, rec_c: np.ndarray) -> np.ndarray:
        """How much a target's record looks like the walking street (1 when its statistics are equal)."""
        c = self.c
        dl = (c.length_mean[cand, rec_c] - c.length_mean[cur, rec]) / c.length_std[cur, rec]
        da = (c.angle_mean[cand, rec_c] - c.angle_mean[cur, rec]) / c.angle_std[cur, rec]
        width = self.opts.consistency_width
        factor = np.exp(-0.5 * (dl ** 2 + da ** 2) / width ** 2)
        return np.where(c.level[cand, rec_c] == ANY_LEVEL, 1.0, factor)  # border junctions: any street

    def step(self, cur: int, rec: int, prev: int | None, level: int | None,
             threshold: float) -> tuple[int, int] | None:
        cand, rec_c, p = self.scores(cur, rec, prev, level)
        order = np.argsort(-p, kind="stable")
        order = order[p[order] >= threshold]
        passing = self._passes_by(cur, cand[order])
        for i, by in zip(order.tolist(), passing.tolist()):
            target = int(cand[i])
            if by or self._blocked(cur, target) or (level is None and self._too_sharp(cur, target)):
                continue
            return target, int(rec_c[i])
        return None

    def _too_sharp(self, a: int, b: int) -> bool:
        """Would a–b leave a or reach b at a sliver angle to a segment already there?"""
        limit = np.radians(self.opts.min_side_angle)
        for u, v in ((a, b), (b, a)):
            others = self.adjacent.get(u, ())
            if not others:
                continue
            d = self.c.xy[v] - self.c.xy[u]
            e = self.c.xy[np.asarray(others)] - self.c.xy[u]
            cos = (e @ d) / np.maximum(np.hypot(*e.T) * np.hypot(*d), 1e-12)
            if (np.arccos(np.clip(cos, -1.0, 1.0)) < limit).any():
                return True
        return False

    def _pick_record(self, cand: np.ndarray, free: np.ndarray, cur: int, rec: int) -> np.ndarray:
        """Of a target's free records of this level, the one most like the walking street.

        A record already holding a piece of a street like this one is that
        street's loose end: joining it continues the street. Untaken breaks ties.
        """
        c = self.c
        diff = (np.abs(c.length_mean[cand] - c.length_mean[cur, rec])
                + np.abs(c.angle_mean[cand] - c.angle_mean[cur, rec]))
        diff = diff + np.where(self.used[cand] > 0, 1e-6, 0.0)
        diff = np.where(free, np.nan_to_num(diff, nan=np.inf), np.inf)
        return np.argmin(diff, axis=1)

    def _passes_by(self, a: int, targets: np.ndarray) -> np.ndarray:
        """Per target b: would a–b run past another junction so close that it should have stopped there?"""
        targets = np.asarray(targets, dtype=np.int64)
        if not len(targets):
            return np.zeros(0, dtype=bool)
        pa, pb = self.c.xy[a], self.c.xy[targets]
        length = np.hypot(*(pb - pa).T)
        snap = np.minimum(self.opts.snap, self.opts.snap_share * length)
        near = np.asarray(self.tree.query_ball_point(pa, float((length + snap).max())), dtype=np.int64)
        near = near[near != a]
        if len(near) == 0:
            return np.zeros(len(targets), dtype=bool)
        _, _, gap = closest_on_segments(self.c.xy[near][:, None, :], pa, pb[None, :, :])  # (near, targets)
        close = (gap < snap[None, :]) & (near[:, None] != targets[None, :])
        return close.any(axis=0)

    def _blocked(self, a: int, b: int) -> bool:
        """Is a–b drawn already, or would it cross a segment or an obstacle? (Passing by is checked apart.)"""
        if (min(a, b), max(a, b)) in self.edges:
            return True
        pa, pb = self.c.xy[a], self.c.xy[b]
        if self.index.crosses(pa, pb, a, b):
            return True
        return self.obstacles is not None and self.obstacles.intersects(shapely.LineString([pa, pb]))

    def connect(self, a: int, ra: int, b: int, rb: int) -> None:
        """Draw a–b as a step of the street whose records (a, ra) and (b, rb) are linked."""
        self.links.setdefault((a, ra), []).append((b, rb))
        self.links.setdefault((b, rb), []).append((a, ra))
        self.occupy(a, ra, b, rb)

    def occupy(self, a: int, ra: int, b: int, rb: int) -> None:
        """Draw segment a–b, taking a slot of record ra at a and rb at b."""
        self.used[a, ra] += 1
        self.used[b, rb] += 1
        self.edges.add((min(a, b), max(a, b)))
        self.adjacent.setdefault(a, []).append(b)
        self.adjacent.setdefault(b, []).append(a)
        self.segment[(a, b)] = self.segment[(b, a)] = self.index.add(self.c.xy[a], self.c.xy[b], a, b)

    def pair_up(self) -> list[tuple[int, list[int]]]:
        """Short side streets between junctions still short of their example's segment count.

        A junction copied from a T has room for three segments; the walk may
        leave it with two when the segment it needed went elsewhere. Two such
        junctions within a plausible step of each other are joined by a street
        of one segment, best match to their spacing first, if it crosses
        nothing, passes no junction, and meets the segments at both ends at a
        fair angle. These are streets of their own: they neither bend nor
        lengthen the streets they meet.
        """
        c, opts = self.c, self.opts
        room = (c.cap - self.used).clip(min=0) * (c.level >= 0)
        short = np.flatnonzero(room.sum(axis=1) > 0)
        if len(short) < 2:
            return []
        rec = np.argmax(room[short], axis=1)
        mu, sd = c.length_mean[short, rec], c.length_std[short, rec]
        tree = cKDTree(c.xy[short])
        near = tree.query_ball_point(c.xy[short], np.nan_to_num(mu + 2 * sd, nan=0.0))
        i = np.repeat(np.arange(len(short)), [len(n) for n in near])
        j = np.fromiter((k for n in near for k in n), dtype=np.int64, count=len(i))
        pairs = np.unique(np.column_stack([np.minimum(i, j), np.maximum(i, j)])[i != j], axis=0).reshape(-1, 2)
        i, j = pairs[:, 0], pairs[:, 1]
        length = np.hypot(*(c.xy[short[i]] - c.xy[short[j]]).T)
        z = np.maximum(np.abs(length - mu[i]) / sd[i], np.abs(length - mu[j]) / sd[j])
        ok = np.isfinite(z) & (np.exp(-0.5 * z ** 2) >= opts.threshold)
        out = []
        for k in np.lexsort((j[ok], i[ok], z[ok])).tolist():
            a, b = int(short[i[ok][k]]), int(short[j[ok][k]])
            ra, rb = int(np.argmax(c.cap[a] - self.used[a])), int(np.argmax(c.cap[b] - self.used[b]))
            if self.used[a, ra] >= c.cap[a, ra] or self.used[b, rb] >= c.cap[b, rb]:
                continue
            if self._passes_by(a, np.array([b]))[0] or self._blocked(a, b) or self._too_sharp(a, b):
                continue
            self.occupy(a, ra, b, rb)
            out.append((int(max(c.level[a, ra], c.level[b, rb], 0)), [a, b]))
        return out

    def chain_nodes(self, start: tuple[int, int]) -> set[int]:
        """Junctions of the street (chain of records) that ``start`` belongs to."""
        seen, todo = {start}, [start]
        while todo:
            for nxt in self.links.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return {j for j, _ in seen}

    def walk_on(self, cur: int, rec: int, level: int | None, threshold: float, max_steps: int = 1 << 30) -> int:
        """Extend the street at record (cur, rec) while steps reach ``threshold``; segments added.

        ``level=None`` accepts targets of any level (the completion step).
        """
        added = 0
        if self.used[cur, rec] >= self.c.cap[cur, rec]:
            return 0
        marked = list(self.chain_nodes((cur, rec)))
        self.on_street[marked] = True
        while self.used[cur, rec] < self.c.cap[cur, rec]:
            linked = self.links.get((cur, rec), ())
            prev = linked[0][0] if linked else None
            nxt = self.step(cur, rec, prev, level, threshold)
            if nxt is None:
                break
            target, trec = nxt
            joins = self.used[target, trec] > 0 or self.c.level[target, trec] == ANY_LEVEL
            self.connect(cur, rec, target, trec)
            added += 1
            if joins:  # met the end of another piece of this street: they are one street now
                break
            self.on_street[target] = True
            marked.append(target)
            cur, rec = target, trec
            if added >= max_steps:
                break
        self.on_street[marked] = False
        return added

    def streets(self) -> list[tuple[int, list[int]]]:
        """Chains of linked records as (level of the chain's first record, junction sequence)."""
        done: set[tuple[int, int]] = set()
        cur: tuple[int, int] | None
        out = []
        for first in sorted(self.links, key=lambda k: (int(self.c.level[k]), len(self.links[k]) != 1, k)):
            if first in done:
                continue
            path, prev, cur = [], None, first
            while cur is not None and cur not in done:
                done.add(cur)
                path.append(cur[0])
                nxt = [k for k in self.links[cur] if k != prev and k not in done]
                prev, cur = cur, (nxt[0] if nxt else None)
            if cur is not None and cur == first:  # a ring closes on itself
                path.append(first[0])
            if len(path) > 1:
                out.append((max(int(self.c.level[first]), 0), path))
        return out


#: Steps are laid down most confident first: a pass at each threshold over every record.
SCHEDULE = (0.9, 0.6, 0.3, 0.1)


def random_walk(cloud: NodeCloud, seed: int | np.random.Generator = 0, options: WalkOptions | None = None,
                obstacles=None, fixed: Sequence[tuple[np.ndarray, np.ndarray, int, int]] = ()) -> WalkResult:
    """Connect ``cloud`` into streets; same seed, same streets.

    ``fixed`` are segments already there (an old town's streets) that no step may cross,
    as (a, b, u, v) with u, v the cloud ids of their ends where they are cloud junctions.
    """
    opts = options or WalkOptions()
    rng = np.random.default_rng(seed)
    finite = cloud.length_mean[np.isfinite(cloud.length_mean) & (cloud.level >= 0)]
    cell = float(np.median(finite)) if len(finite) else 100.0
    walker = _Walker(cloud, opts, obstacles, max(cell, 1.0))
    for a, b, u, v in fixed:
        walker.index.add(np.asarray(a, dtype=float), np.asarray(b, dtype=float), u, v)
    thresholds = [t for t in SCHEDULE if t > opts.threshold] + [opts.threshold]
    for level in range(int(cloud.level.max(initial=-1)) + 1):
        order = _starts(cloud, level, rng, walker)
        for threshold in thresholds:
            for j, r in order:
                walker.walk_on(j, r, level, threshold)
    if opts.complete:
        on_street = (walker.used[:, ::-1] > 0)  # the junction's other record is drawn
        dangling = (walker.used > 0) & (walker.used < cloud.cap)
        unstarted = (walker.used == 0) & (cloud.cap == 1) & on_street & (cloud.level >= 0)
        for j, r in np.argwhere(dangling | unstarted).tolist():
            walker.walk_on(j, r, None, opts.threshold, max_steps=1)
    streets = walker.streets() + (walker.pair_up() if opts.complete else [])
    return WalkResult(streets=streets, drawn=walker.index, segment=walker.segment)


def _starts(cloud: NodeCloud, level: int, rng: np.random.Generator, walker: _Walker) -> list[tuple[int, int]]:
    """Records of this level, street ends first, the least ambiguous first step first.

    A walk whose first step is clear claims its junctions before an
    ambiguous one can take them by mistake; the seed breaks near-ties.
    """
    j, r = np.nonzero(cloud.level == level)
    margin = np.zeros(len(j))
    for i, (jj, rr) in enumerate(zip(j.tolist(), r.tolist())):
        _, _, p = walker.scores(jj, rr, None, level)
        top = np.sort(p)[::-1][:2]
        margin[i] = (top[0] - (top[1] if len(top) > 1 else 0.0)) if len(top) else 0.0
    margin += rng.uniform(0.0, 0.05, len(j))
    ends = cloud.cap[j, r] == 1
    order = np.lexsort((-margin, ~ends))
    return list(zip(j[order].tolist(), r[order].tolist()))
