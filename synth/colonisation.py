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
from dataclasses import dataclass, field, fields
from enum import StrEnum
from typing import Any, cast

import numpy as np
import shapely
from scipy import sparse
from scipy.spatial import cKDTree

from osm_expand.errors import InputError
from osm_expand.model import closest_on_segments
from synth.flowfield import FlowField
from synth.infomaps import Raster, forbidden_cells, slopes_within
from synth.segment_index import SegmentIndex

__all__ = [
    "ColonisationOptions", "ColonisationResult", "GrownStreet", "HierarchyBasis", "Join", "chain_streets",
    "colonise", "connection_force", "constrain_turn", "extra_pruning", "ideal_directions",
]


class HierarchyBasis(StrEnum):
    """What the hierarchy thresholds are shares of (001 §4.3.3)."""

    #: All APs introduced so far, active and dead: the thesis's literal rule. Its result depends on
    #: the region's size (a district of 200 SL² has 1/50 of the thesis's APs).
    INTRODUCED = "introduced"
    #: The APs the thesis would introduce on its 100 × 100 SL domain (001 §5.6) at the same
    #: density: the same numbers as the thesis on that domain, and independent of the region's size.
    REFERENCE = "reference"


#: The thesis's test domain in SL² (001 §5.6: "a 100x100 grid", SL = 1).
REFERENCE_AREA_SL2 = 100.0 * 100.0
#: Segments meeting at a node always differ by at least this angle (degrees), whatever ``min_angle`` says:
#: at zero they would run along each other.
MIN_ANGLE_FLOOR = 1.0
#: Hierarchy levels: 0 primary, 1 secondary, 2 tertiary (001 §4.3.3's three classes).
PRIMARY, SECONDARY, TERTIARY = 0, 1, 2


@dataclass(frozen=True)
class ColonisationOptions:
    """Tunables of space colonisation; per-phase pairs are (phase 1, phase 2)."""

    #: SL, metres: the length of every grown segment. The integrator sets the town's junction spacing.
    segment_length: float = 100.0
    #: APs scattered per SL² of region in each phase. 001 uses 2500 (§5.2-5.5) or 10000 (figs. 104b,
    #: 108b) on its 100 × 100 domain, i.e. 0.25 or 1.0; districts are small, so the denser one.
    ap_density: tuple[float, float] = (1.0, 1.0)
    #: RoI in SL: an AP influences nodes closer than this (001 §5.5, the Espinho town case: 4).
    radius_of_influence: float = 4.0
    #: KD in SL per phase: the APs that influenced a new node and lie this close to it die (001 §3.1).
    #: 001 §5.5.1's coastal town, fig. 107b: 2.0/1.0, which with growth points every 2 SL gives streets
    #: 2 SL apart crossed every SL or so. A phase-2 value <= 0 means half of phase 1's (001 §4.2.3).
    kill_distance: tuple[float, float] = (2.0, 0.0)
    #: Nodes each AP attracts (001 §4.2.3: 1 as in SCA for phase 1, N = 2 "more pleasing" for phase 2).
    nodes_per_ap: tuple[int, int] = (1, 2)
    #: Phase-1 turn range from the parent segment, degrees, both sides (001 §5.5.1: 90°).
    #: (0, 180) is no constraint.
    angle_range_1: tuple[float, float] = (90.0, 90.0)
    #: Phase-2 turn range, degrees (001 §5.5.1: 80°-100°; §5.4.1 uses 80°-110°).
    angle_range_2: tuple[float, float] = (80.0, 100.0)
    #: Tolerance range around straight ahead per phase, degrees; negative: half the range's amplitude
    #: (001 §4.1.2's default: [30°, 45°] → 7.5°; a fixed 90° leaves exactly straight ahead).
    tolerance: tuple[float, float] = (-1.0, -1.0)
    #: Whether straight ahead (within the tolerance) is allowed per phase (001 §4.1.2, §5.3).
    straight_ahead: tuple[bool, bool] = (True, True)
    #: Minimum angle between two segments at a node, degrees, per phase (001 §4.1.2 fig. 76; §5.2, §5.6: 30°).
    min_angle: tuple[float, float] = (30.0, 30.0)
    #: Share of the flow-field direction in the blend per phase (001 §5.2: 100 %, §5.6: 85 %).
    flow_influence: tuple[float, float] = (1.0, 1.0)
    #: Steepest slope a segment or a node→AP line may climb, degrees (001 §5.6: 10° and 20°).
    max_steepness_deg: float = 20.0
    #: Height samples between a line's ends for the steepness check (001 §4.3.1 gives no number;
    #: 8 samples put one every half SL along an RoI of 4 SL).
    steepness_samples: int = 8
    #: Snapping distance in SL (001 gives none): under half the SL, so that a node never snaps onto
    #: a sibling branch at the 30° minimum angle (whose end is 0.52 SL away).
    snap_distance: float = 0.4
    #: Phase-2 APs closer than this to a segment are dropped, in SL (001 §4.2.2's default: half SL).
    safety_distance: float = 0.5
    #: Inter-connection candidates are closer than this, in SL (001 §4.2.1's default: one SL).
    interconnect_distance: float = 1.0
    #: Growth points along the old streets, every this many SL (001 places initial segments by hand).
    #: At 1 SL every point grows a street, a comb one SL apart that phase 2 then fills with one-SL
    #: blocks; at 2 SL the blocks are 2 × 1 SL, a town's proportions.
    seed_spacing: float = 2.0
    #: Share of APs that makes a branch the higher of its phase's two classes (001 §5.2-5.5: 1 %, 1 %).
    hierarchy_threshold: tuple[float, float] = (0.01, 0.01)
    #: What the thresholds are shares of (see :class:`HierarchyBasis`).
    hierarchy_basis: str = HierarchyBasis.REFERENCE.value
    #: Most important level phase 2 may give (001 §4.3.3: "the second phase only produces secondary
    #: and tertiary roads" in most examples): 1 secondary; 2 makes all of phase 2 tertiary.
    phase2_top_level: int = SECONDARY
    #: Highway class per level 0, 1, 2: a district's main roads, its connectors, its local streets.
    highways: tuple[str, str, str] = ("secondary", "tertiary", "residential")
    #: Run phase 2 (001 §4.2) after phase 1.
    second_phase: bool = True
    #: Connect phase-1 nodes at the start of phase 2 (001 §4.2.1).
    interconnect: bool = True
    #: Drop phase-2 APs near segments (001 §4.2.2).
    validate_aps: bool = True
    #: Delete the triangle edges of 001 §4.2.4 at the end.
    prune: bool = True
    #: Failed growth attempts in a row after which a node retires for the phase (001 gives none;
    #: without it a node whose only direction is blocked would hold its APs forever).
    patience: int = 3
    #: Safety stop per phase, iterations.
    max_iterations: int = 100_000
    #: Streets continue through a junction along the straightest pair of same-level segments turning
    #: less than this, degrees (chaining only; 004 §4.2 merges streets at > 160°, i.e. < 20° turn,
    #: but grown streets bend at snaps).
    street_turn_deg: float = 45.0
    #: Segments may leave the region by this much, in SL, so that streets start from old streets
    #: running along the region's edge; new nodes stay strictly inside.
    edge_tolerance: float = 0.1
    #: No segment is shorter than this, metres.
    min_segment_m: float = 1.0

    def __post_init__(self) -> None:
        self._check()

    def _check(self) -> None:
        def bad(key: str, why: str) -> InputError:
            return InputError(f"colonisation option {key}: {why}")

        if not (np.isfinite(self.segment_length) and self.segment_length > 0):
            raise bad("segment_length", f"must be a positive number of metres, got {self.segment_length}")
        for key in ("ap_density", "kill_distance", "nodes_per_ap", "angle_range_1", "angle_range_2", "tolerance",
                    "straight_ahead", "min_angle", "flow_influence", "hierarchy_threshold"):
            if len(getattr(self, key)) != 2:
                raise bad(key, f"needs two values, got {getattr(self, key)!r}")
        if min(self.ap_density) < 0:
            raise bad("ap_density", f"must not be negative, got {self.ap_density}")
        if self.kill_distance[0] <= 0:
            raise bad("kill_distance", f"phase 1 must be positive, got {self.kill_distance[0]}")
        for phase in (1, 2):
            kd = self.kill(phase)
            if self.radius_of_influence <= kd:
                raise bad("radius_of_influence", f"{self.radius_of_influence} SL must exceed phase {phase}'s kill "
                          f"distance {kd} SL, or nothing grows (001 §4.1.1)")
        if min(self.nodes_per_ap) < 1:
            raise bad("nodes_per_ap", f"must be at least 1, got {self.nodes_per_ap}")
        for key in ("angle_range_1", "angle_range_2"):
            lo, hi = getattr(self, key)
            if not 0.0 <= lo <= hi <= 180.0:
                raise bad(key, f"needs 0 <= min <= max <= 180 degrees, got {(lo, hi)}")
        if not all(0.0 <= v < 180.0 for v in self.min_angle):
            raise bad("min_angle", f"must be in [0, 180) degrees, got {self.min_angle}")
        if not all(0.0 <= v <= 1.0 for v in self.flow_influence):
            raise bad("flow_influence", f"must be shares in [0, 1], got {self.flow_influence}")
        if not all(0.0 <= v <= 1.0 for v in self.hierarchy_threshold):
            raise bad("hierarchy_threshold", f"must be shares in [0, 1], got {self.hierarchy_threshold}")
        valid = [b.value for b in HierarchyBasis]
        if self.hierarchy_basis not in valid:
            raise bad("hierarchy_basis", f"{self.hierarchy_basis!r} is not one of {', '.join(valid)}")
        if self.phase2_top_level not in (PRIMARY, SECONDARY, TERTIARY):
            raise bad("phase2_top_level", f"must be 0, 1 or 2, got {self.phase2_top_level}")
        if len(self.highways) != 3:
            raise bad("highways", f"needs one class per level 0, 1, 2, got {self.highways!r}")
        for key in ("snap_distance", "safety_distance", "interconnect_distance", "seed_spacing", "edge_tolerance",
                    "min_segment_m"):
            if not getattr(self, key) >= 0:
                raise bad(key, f"must not be negative, got {getattr(self, key)}")
        if self.snap_distance >= 1.0:
            raise bad("snap_distance", f"{self.snap_distance} SL would snap a new node back onto its own parent; "
                      "use less than 1")
        if self.seed_spacing <= 0:
            raise bad("seed_spacing", f"must be positive, got {self.seed_spacing}")
        if not 0.0 <= self.max_steepness_deg <= 90.0:
            raise bad("max_steepness_deg", f"must be in [0, 90] degrees, got {self.max_steepness_deg}")
        if self.steepness_samples < 0 or self.patience < 1 or self.max_iterations < 1:
            raise bad("steepness_samples/patience/max_iterations", "must be >= 0, >= 1 and >= 1")

    def kill(self, phase: int) -> float:
        """KD of ``phase`` (1 or 2) in SL; phase 2 defaults to half of phase 1's (001 §4.2.3)."""
        kd = self.kill_distance[phase - 1]
        return kd if kd > 0 else 0.5 * self.kill_distance[0]

    def tolerance_of(self, phase: int) -> float:
        """Tolerance range around straight ahead of ``phase``, degrees (001 §4.1.2)."""
        lo, hi = self.angle_range_1 if phase == 1 else self.angle_range_2
        tol = self.tolerance[phase - 1]
        return 0.5 * (hi - lo) if tol < 0 else tol

    def to_dict(self) -> dict[str, Any]:
        """The options as plain JSON values (tuples become lists), with KD and tolerances resolved."""
        out = {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}
        out["resolved_kill_distance"] = [self.kill(1), self.kill(2)]
        out["resolved_tolerance"] = [self.tolerance_of(1), self.tolerance_of(2)]
        return out


@dataclass(frozen=True)
class _Phase:
    """One phase's settings resolved to metres and degrees."""

    number: int
    kill: float  # m
    nodes_per_ap: int
    lo: float
    hi: float
    tolerance: float
    straight: bool
    min_angle: float
    flow: float
    threshold: float
    top: int
    bottom: int

    @classmethod
    def of(cls, opts: ColonisationOptions, number: int) -> _Phase:
        lo, hi = opts.angle_range_1 if number == 1 else opts.angle_range_2
        k = number - 1
        top = PRIMARY if number == 1 else opts.phase2_top_level
        return cls(number=number, kill=opts.kill(number) * opts.segment_length, nodes_per_ap=opts.nodes_per_ap[k],
                   lo=lo, hi=hi, tolerance=opts.tolerance_of(number), straight=opts.straight_ahead[k],
                   min_angle=opts.min_angle[k], flow=opts.flow_influence[k], threshold=opts.hierarchy_threshold[k],
                   top=top, bottom=SECONDARY if number == 1 else TERTIARY)


# --------------------------------------------------------------------------- pure rules


def constrain_turn(turn_deg: np.ndarray | float, *, lo: float, hi: float, tolerance: float,
                   straight: bool = True) -> np.ndarray:
    """Snap turns from the parent segment into the allowed range (001 §4.1.2, fig. 73).

    Allowed are ``lo <= |turn| <= hi`` on either side and, when ``straight``,
    ``|turn| <= tolerance`` around straight ahead. A turn outside moves to
    the nearest allowed value on its own side.

    Parameters
    ----------
    turn_deg : float or ndarray
        Signed turns in degrees, in (-180, 180] (positive: left).
    lo, hi : float
        The range of allowed turns, degrees, 0 <= lo <= hi <= 180.
    tolerance : float
        Half-width of the straight-ahead range, degrees.
    straight : bool
        Whether the straight-ahead range is allowed.

    Returns
    -------
    ndarray
        Snapped signed turns, degrees.

    Examples
    --------
    >>> constrain_turn([20.0, -5.0, 10.0, 60.0], lo=30, hi=45, tolerance=7.5).tolist()
    [30.0, -5.0, 7.5, 45.0]
    """
    turn = np.asarray(turn_deg, dtype=float)
    mag = np.abs(turn)
    lo_edge, hi_edge = np.full_like(mag, lo), np.full_like(mag, hi)
    options = [np.clip(mag, lo_edge, hi_edge)]
    if straight:
        options.append(np.minimum(mag, tolerance))
    options_arr = np.stack(options)
    best = options_arr[np.argmin(np.abs(options_arr - mag), axis=0), np.arange(mag.size).reshape(mag.shape)] \
        if mag.ndim else options_arr[int(np.argmin(np.abs(options_arr - mag)))]
    return np.where(turn < 0, -best, best)


def _snap_turn(turn: float, lo: float, hi: float, tolerance: float, straight: bool) -> float:
    """:func:`constrain_turn` for one turn (the growth loop's hot path)."""
    mag = abs(turn)
    best = min(max(mag, lo), hi)
    if straight and abs(min(mag, tolerance) - mag) < abs(best - mag):
        best = min(mag, tolerance)
    return -best if turn < 0 else best


def ideal_directions(incident: np.ndarray, incoming: np.ndarray | None) -> np.ndarray:
    """A node's ideal directions for a new connection, as angles in degrees (001 §4.2.1).

    Parameters
    ----------
    incident : ndarray, shape (k, 2)
        Unit vectors from the node to each of its neighbours.
    incoming : ndarray, shape (2,), optional
        Unit vector of the connection that reached the node (parent → node);
        used when the node has no descendants (k <= 1).

    Returns
    -------
    ndarray
        Angles in degrees, counter-clockwise from east. With no descendants:
        straight on along the incoming connection and both perpendiculars
        ("perpendicular or parallel to the previous connection"; the fourth,
        back along it, is the connection itself). Otherwise the bisectors of
        consecutive connection directions around the node. Empty when the
        node has no connection at all.
    """
    incident = np.asarray(incident, dtype=float).reshape(-1, 2)
    if len(incident) <= 1:
        if incoming is None:
            if not len(incident):
                return np.zeros(0)
            incoming = -incident[0]
        base = np.degrees(np.arctan2(incoming[1], incoming[0]))
        return np.mod(base + np.array([0.0, 90.0, -90.0]), 360.0)
    ang = np.sort(np.mod(np.degrees(np.arctan2(incident[:, 1], incident[:, 0])), 360.0))
    gaps = np.diff(np.append(ang, ang[0] + 360.0))
    return np.mod(ang + gaps / 2, 360.0)


def connection_force(alpha_deg: np.ndarray | float, distance: np.ndarray | float,
                     threshold: float) -> np.ndarray:
    """001 eq. 3: force = ((180° − α)/180°) · ((threshold − |NC|)/threshold).

    Parameters
    ----------
    alpha_deg : float or ndarray
        Angle between the candidate connection and the nearest ideal direction, degrees in [0, 180].
    distance : float or ndarray
        Length of the candidate connection |NC|, same unit as ``threshold``.
    threshold : float
        The inter-connection distance threshold.

    Returns
    -------
    ndarray
        Force in [0, 1] (0 at or beyond the threshold).

    Examples
    --------
    >>> float(connection_force(90.0, 50.0, 100.0))
    0.25
    """
    alpha = np.asarray(alpha_deg, dtype=float)
    dist = np.asarray(distance, dtype=float)
    return (180.0 - alpha) / 180.0 * np.clip((threshold - dist) / threshold, 0.0, 1.0)


def _first_hit(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[int, float] | None:
    """The segment a→b that p→q meets first (touching included), and where along it; None if none.

    Parameters
    ----------
    p, q : ndarray, shape (2,)
        The proposed segment.
    a, b : ndarray, shape (k, 2)
        Candidate segments.

    Returns
    -------
    (index into a/b, parameter along a→b in [0, 1]) or None
    """
    r = q - p
    s = b - a
    denom = r[0] * s[:, 1] - r[1] * s[:, 0]
    ap = a - p
    safe = np.where(np.abs(denom) > 1e-12, denom, np.inf)  # parallel: t = u = 0, rejected below
    t = (ap[:, 0] * s[:, 1] - ap[:, 1] * s[:, 0]) / safe  # along p→q
    u = (ap[:, 0] * r[1] - ap[:, 1] * r[0]) / safe  # along a→b
    eps = 1e-9
    ok = np.isfinite(safe) & (t > eps) & (t <= 1 + eps) & (u >= -eps) & (u <= 1 + eps)
    if not ok.any():
        return None
    k = int(np.flatnonzero(ok)[np.argmin(t[ok])])
    return k, float(np.clip(u[k], 0.0, 1.0))


def _angle_between(a_deg: np.ndarray, b_deg: np.ndarray) -> np.ndarray:
    """Smallest absolute difference of angles, degrees in [0, 180]."""
    d = np.mod(np.asarray(a_deg) - np.asarray(b_deg), 360.0)
    return np.minimum(d, 360.0 - d)


def extra_pruning(edges: np.ndarray, *, deletable: np.ndarray, level: np.ndarray,
                  length: np.ndarray) -> np.ndarray:
    """Which edges survive 001 §4.2.4's extra pruning.

    A triangle a, b, c (all three mutually connected) with a and b of degree
    >= 3 and c of degree 2 loses one of c's edges: the less important one
    (higher level), then the longer one, then the one to the higher node id
    (001 leaves the choice open; keeping c's more important, shorter edge
    keeps c on the street it came from). Only ``deletable`` edges go; when
    neither of c's edges may go, the triangle stays. Triangles whose nodes
    all have degree >= 3, and those at a road end (two nodes of degree 2),
    stay. Nodes are visited in increasing order with the current degrees,
    repeatedly, until nothing changes.

    Parameters
    ----------
    edges : ndarray of int, shape (E, 2)
        Node pairs.
    deletable : ndarray of bool, shape (E,)
        Edges that may be deleted (grown ones; the old town's stay).
    level : ndarray of int, shape (E,)
        Hierarchy level per edge (0 most important).
    length : ndarray of float, shape (E,)
        Edge lengths.

    Returns
    -------
    ndarray of bool, shape (E,)
        True for the edges kept.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    keep = np.ones(len(edges), dtype=bool)
    adj: dict[int, dict[int, int]] = {}
    for e, (u, v) in enumerate(edges.tolist()):
        adj.setdefault(u, {})[v] = e
        adj.setdefault(v, {})[u] = e
    changed = True
    while changed:
        changed = False
        for c in sorted(adj):
            if len(adj[c]) != 2:
                continue
            a, b = sorted(adj[c])
            if b not in adj[a] or len(adj[a]) < 3 or len(adj[b]) < 3:
                continue
            pair = [(int(level[adj[c][x]]), float(length[adj[c][x]]), x, adj[c][x]) for x in (a, b)
                    if deletable[adj[c][x]]]
            if not pair:
                continue
            _, _, other, e = max(pair)
            keep[e] = False
            del adj[c][other], adj[other][c]
            changed = True
    return keep


def chain_streets(edges: np.ndarray, xy: np.ndarray, level: np.ndarray, *, degree: np.ndarray,
                  max_turn_deg: float) -> list[list[int]]:
    """Chain edges into streets: node sequences of one level each.

    A street continues through a node of (total) degree 2 whose two edges
    have the same level, and through a junction along the straightest pair
    of same-level edges turning less than ``max_turn_deg`` (pairs taken
    greedily, straightest first). A closed chain repeats its first node.

    Parameters
    ----------
    edges : ndarray of int, shape (E, 2)
        The edges to chain.
    xy : ndarray, shape (N, 2)
        Node positions, metres.
    level : ndarray of int, shape (E,)
        Level per edge.
    degree : ndarray of int, shape (N,)
        Degree of every node in the whole network (old streets included), so
        that a street ending on an old street is not continued through it.
    max_turn_deg : float
        Largest turn to continue through a junction, degrees.

    Returns
    -------
    list of list of int
        Node sequences, in a deterministic order (by smallest edge id).
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    at: dict[int, list[int]] = {}
    for e, (u, v) in enumerate(edges.tolist()):
        at.setdefault(u, []).append(e)
        at.setdefault(v, []).append(e)
    partner: dict[tuple[int, int], int] = {}  # (node, edge) -> the edge the street continues on
    for node, es in at.items():
        if len(es) < 2:
            continue
        if degree[node] == 2 and len(es) == 2:
            if level[es[0]] == level[es[1]]:
                partner[(node, es[0])], partner[(node, es[1])] = es[1], es[0]
            continue
        out = {e: xy[edges[e, 1] if edges[e, 0] == node else edges[e, 0]] - xy[node] for e in es}
        pairs = []
        for i, e1 in enumerate(es):
            for e2 in es[i + 1:]:
                if level[e1] != level[e2]:
                    continue
                d1, d2 = out[e1], out[e2]
                cos = float(d1 @ d2) / max(float(np.hypot(*d1) * np.hypot(*d2)), 1e-12)
                turn = 180.0 - np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
                if turn < max_turn_deg:
                    pairs.append((turn, e1, e2))
        used: set[int] = set()
        for _, e1, e2 in sorted(pairs):
            if e1 not in used and e2 not in used:
                used |= {e1, e2}
                partner[(node, e1)], partner[(node, e2)] = e2, e1
    done = np.zeros(len(edges), dtype=bool)
    streets: list[list[int]] = []

    def walk(e: int, node: int) -> list[int]:
        """Nodes from ``node`` along ``e`` and onward until the chain ends or closes."""
        path = [node]
        while True:
            done[e] = True
            u, v = edges[e]
            node = int(v if u == node else u)
            path.append(node)
            nxt = partner.get((node, e))
            if nxt is None or done[nxt]:
                return path
            e = nxt

    for e in range(len(edges)):  # open chains first: start at an end whose edge has no partner there
        if done[e]:
            continue
        u, v = (int(x) for x in edges[e])
        if (u, e) not in partner:
            streets.append(walk(e, u))
        elif (v, e) not in partner:
            streets.append(walk(e, v))
    for e in range(len(edges)):  # what is left are closed rings
        if not done[e]:
            streets.append(walk(e, int(edges[e, 0])))
    return streets


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class GrownStreet:
    """A new street: its node ids in :attr:`ColonisationResult.xy`, shape, level and highway class."""

    nodes: tuple[int, ...]
    xy: np.ndarray  # (k, 2) metres
    level: int
    highway: str


@dataclass(frozen=True)
class Join:
    """A node where new streets meet an old street.

    ``seed`` names the old street (its index in ``seeds``). When ``vertex`` is
    True the node is that street's vertex number ``segment`` (no split
    needed); otherwise it is a new point on the segment between its vertices
    ``segment`` and ``segment + 1``, where the integrator splits the real way.
    """

    node: int
    xy: tuple[float, float]
    seed: int
    segment: int
    vertex: bool


@dataclass(frozen=True)
class ColonisationResult:
    """What :func:`colonise` grew.

    ``xy`` holds every node of the grown graph (old-town nodes first, flagged
    in ``fixed``); ``edges`` the grown edges only, with their level and phase.
    """

    xy: np.ndarray  # (N, 2)
    fixed: np.ndarray  # (N,) bool: old-town nodes (never moved)
    edges: np.ndarray  # (E, 2) grown edges
    edge_level: np.ndarray  # (E,)
    edge_phase: np.ndarray  # (E,) 1 or 2
    streets: tuple[GrownStreet, ...]
    joins: tuple[Join, ...]
    attraction_xy: np.ndarray  # (M, 2) every regular AP introduced
    attraction_phase: np.ndarray  # (M,)
    attraction_alive: np.ndarray  # (M,) bool, at the end of its phase
    flow: FlowField | None
    options: ColonisationOptions
    report: dict[str, Any] = field(default_factory=dict)

    def polylines(self) -> list[tuple[int, np.ndarray]]:
        """(level, polyline) per street, like :meth:`synth.grow.GrowResult.polylines`."""
        return [(s.level, s.xy) for s in self.streets]

    def debug_features(self, *, flow_step: int = 1) -> list[dict[str, Any]]:
        """GeoJSON-ready features in metres: APs, flow grid and primitives, parameters (001 §5.1.2).

        Parameters
        ----------
        flow_step : int
            Draw every ``flow_step``-th flow grid cell in both directions.

        Returns
        -------
        list of dict
            ``{"type": "Feature", "geometry": ..., "properties": {"layer": ...}}``;
            layers ``attraction_point`` (phase, alive), ``flow_vector`` (a line
            from a cell centre along the unit flow, half a cell long; vx, vy,
            speed), ``flow_primitive`` (kind, strength, direction_deg) and
            ``parameters`` (no geometry; the options and the report).
        """
        feats: list[dict[str, Any]] = []
        for (x, y), ph, alive in zip(self.attraction_xy.tolist(), self.attraction_phase.tolist(),
                                     self.attraction_alive.tolist()):
            feats.append(_feature({"type": "Point", "coordinates": [x, y]},
                                  layer="attraction_point", phase=int(ph), alive=bool(alive)))
        if self.flow is not None:
            ny, nx = self.flow.vectors.shape[:2]
            centres = self.flow.centres().reshape(ny, nx, 2)[::flow_step, ::flow_step].reshape(-1, 2)
            vec = self.flow.vectors[::flow_step, ::flow_step].reshape(-1, 2)
            speed = np.hypot(vec[:, 0], vec[:, 1])
            unit = np.where(speed[:, None] > 0, vec / np.maximum(speed, 1e-300)[:, None], 0.0)
            tips = centres + unit * 0.5 * self.flow.cell * flow_step
            for c, t, v, s in zip(centres.tolist(), tips.tolist(), vec.tolist(), speed.tolist()):
                feats.append(_feature({"type": "LineString", "coordinates": [c, t]}, layer="flow_vector",
                                      vx=v[0], vy=v[1], speed=s))
            for p in self.flow.primitives:
                feats.append(_feature({"type": "Point", "coordinates": [p.x, p.y]}, layer="flow_primitive",
                                      **p.to_dict()))
        feats.append({"type": "Feature", "geometry": None,
                      "properties": {"layer": "parameters", "options": self.options.to_dict(),
                                     "report": self.report}})
        return feats


def _feature(geometry: dict[str, Any], **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": geometry, "properties": properties}


# --------------------------------------------------------------------------- the growing network


class _Network:
    """Nodes, edges and the segment index of the network being grown (old streets included)."""

    def __init__(self, cell: float):
        self.xy = np.zeros((1024, 2))
        self.n = 0
        #: failed attempts in a row, retired for the phase, never grows (an old-street node outside the region)
        self.fails = np.zeros(1024, dtype=np.int64)
        self.retired = np.zeros(1024, dtype=bool)
        self.static = np.zeros(1024, dtype=bool)
        self.fixed: list[bool] = []
        self.through: list[bool] = []  # a node inside a street (seed vertex, split point): no parent direction
        self.parent: list[int] = []
        self.phase: list[int] = []
        self.seed_ref: list[tuple[int, int, bool] | None] = []
        self.creator: list[int] = []  # the edge whose growth created the node, else -1
        self.adj: list[dict[int, int]] = []
        self.eu: list[int] = []
        self.ev: list[int] = []
        self.elevel: list[int] = []
        self.ephase: list[int] = []
        self.eseed: list[tuple[int, int]] = []
        self.ealive: list[bool] = []
        self.eslot: list[int] = []
        self.eorigin: list[int] = []  # the grown edge a split half came from (itself otherwise)
        self.index = SegmentIndex(cell)

    def add_node(self, p: np.ndarray, *, fixed: bool = False, through: bool = False, parent: int = -1,
                 phase: int = 0, seed_ref: tuple[int, int, bool] | None = None, creator: int = -1) -> int:
        if self.n == len(self.xy):
            self.xy = np.vstack([self.xy, np.zeros_like(self.xy)])
            for name in ("fails", "retired", "static"):
                old = getattr(self, name)
                setattr(self, name, np.concatenate([old, np.zeros_like(old)]))
        k = self.n
        self.xy[k] = p
        self.n += 1
        self.fixed.append(fixed)
        self.through.append(through)
        self.parent.append(parent)
        self.phase.append(phase)
        self.seed_ref.append(seed_ref)
        self.creator.append(creator)
        self.adj.append({})
        return k

    def add_edge(self, u: int, v: int, *, level: int, phase: int, seed: tuple[int, int] = (-1, -1),
                 origin: int = -1) -> int:
        e = len(self.eu)
        self.eorigin.append(e if origin < 0 else origin)
        self.eu.append(u)
        self.ev.append(v)
        self.elevel.append(level)
        self.ephase.append(phase)
        self.eseed.append(seed)
        self.ealive.append(True)
        self.eslot.append(self.index.add(self.xy[u].copy(), self.xy[v].copy(), u, v))
        self.adj[u][v] = e
        self.adj[v][u] = e
        return e

    def remove_edge(self, e: int) -> None:
        self.ealive[e] = False
        self.index.remove(self.eslot[e])
        u, v = self.eu[e], self.ev[e]
        del self.adj[u][v], self.adj[v][u]

    def node_level(self, m: int) -> int:
        """A node's hierarchy: the most important level of the roads it joins (001 §4.1.3)."""
        return min((self.elevel[e] for e in self.adj[m].values()), default=TERTIARY + 1)

    def directions(self, m: int, at: np.ndarray | None = None) -> np.ndarray:
        """Unit vectors from node ``m`` (or from ``at``) to each neighbour, shape (k, 2)."""
        if not self.adj[m]:
            return np.zeros((0, 2))
        nb = np.fromiter(self.adj[m].keys(), dtype=np.int64)
        d = self.xy[nb] - (self.xy[m] if at is None else at)
        return d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-12)[:, None]

    def segments_near(self, p: np.ndarray, radius: float) -> np.ndarray:
        """Slots of the index's live segments whose grid cells come within ``radius`` of ``p``."""
        idx = self.index
        lo = np.floor((p - radius) / idx.cell).astype(int)
        hi = np.floor((p + radius) / idx.cell).astype(int)
        found: list[int] = []
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                found.extend(idx.grid.get((i, j), ()))
        if not found:
            return np.zeros(0, dtype=np.int64)
        slots = np.unique(np.asarray(found, dtype=np.int64))
        return slots[idx.active[slots]]


# --------------------------------------------------------------------------- the kernel


@dataclass
class _APs:
    """One phase's attractors: scattered points, and (phase 2) phase-1 nodes."""

    xy: np.ndarray  # (M, 2)
    node: np.ndarray  # (M,) node id for a node attractor, else -1
    alive: np.ndarray
    active: np.ndarray  # within RoI of some node at some time: the only ones worth a query
    tree: cKDTree


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
