"""Beneš street patterns: minor streets grown from crossings (seed 000 §4.2.6).

A new street starts at an existing crossing (or at a point on a segment,
which becomes one) and is defined by its orientation and length. The
orientation is drawn from ``angle_pdf`` and measured in *world space*, in
*crossing space* — from the time-wise first incident street of the crossing
— or, for Weber's radial pattern (seed 002 §3.1), in *centre space*: from the
ray pointing away from a pattern centre. The length comes from a length PDF
or is a function of the orientation (``length_from_orientation``).

From that Default street four proposals are made (000 §4.2.6):

1. **Default** — the drawn street itself.
2. **Extend** — if lengthening the Default street by the look-ahead factor
   (×1.5, seed 002's "enlargement") meets a street that does not already
   share a crossing with the proposal, a street to that intersection point.
3. **Shorten** — if the Default street intersects other streets, a street to
   the first of these intersections.
4. **Snap** — a street to the nearest crossing within ``snap_radius_m``
   (25 m, seed 002) of the Default street's end.

They are evaluated Snap, Shorten, Extend, Default; the first valid one is
built. Each can be switched off. A proposal is valid when (000 §4.2.6, a–g)

a. it does not intersect any non-incident street or crossing;
b. it makes an angle of at least ``min_angle_deg`` with every street it
   shares a crossing with (at both ends);
c. its length lies in [``min_length_m``, ``max_length_m``];
d. it keeps at least ``min_cs_distance_m`` from every non-incident street;
e. a new end crossing is at least ``min_cc_distance_m`` from every existing
   crossing (also applied to a start point that splits a segment);
f. it closes no triangle of three streets and three crossings;
g. both its crossings have degree ≤ ``max_degree`` afterwards;

and, with water and forbidden areas given: it does not end in water nor
touch a forbidden area. A proposal that crosses water is a **bridge**: each
crossing makes one bridge attempt (000 §4.2.6), a bridge may be at most
``max_bridge_length_m`` long and no closer than ``min_bridge_spacing_m`` to
another bridge. Besides bridges that arise from ordinary proposals, a
crossing near water first tries 000 §4.2.3's bridge: rays shot in
``bridge_rays`` directions, the one that crosses water in the shortest span
becomes the proposal.

Weber's organic, grid and radial patterns (002 §3.1) and the eras' patterns
(000 §4.2.9) are parameter sets of :class:`PatternOptions`: ``ORGANIC``,
``GRID``, ``RADIAL``, ``MEDIEVAL``, ``GRID_19TH_CENTURY``,
``GRID_NORTH_AMERICAN``, ``SUBURBAN``.
"""
from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, fields, replace
from enum import StrEnum
from typing import Any, Protocol

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from osm_expand.errors import InputError
from osm_expand.model.enums import parse_enum
from synth.segment_index import _intersects
from synth.street_graph import StreetGraph

__all__ = [
    "AngleSpace", "GRID", "GRID_19TH_CENTURY", "GRID_NORTH_AMERICAN", "GrowthStep", "LengthMode",
    "MEDIEVAL", "ORGANIC", "PATTERNS", "PatternOptions", "PdfKind", "Proposal", "RADIAL", "Rule",
    "SUBURBAN", "Start", "StreetProposal", "check_proposal", "grow_streets", "pattern", "propose",
]

#: Tolerance (m) for "this point is an existing crossing / lies on this segment".
ON_TOLERANCE = 1e-6


class AngleSpace(StrEnum):
    """Frame in which a new street's orientation is drawn (000 §4.2.6 ``isWorldSpace``; 002 §3.1 radial)."""

    WORLD = "world"        #: from the x axis (east), plus ``angle_offset_deg``
    CROSSING = "crossing"  #: from the time-wise first street at the crossing, pointing away from it
    CENTRE = "centre"      #: from the ray pointing away from the pattern centre


class PdfKind(StrEnum):
    """How ``angle_pdf``'s (angle, weight) samples define the distribution (000 appendix A.4)."""

    DISCRETE = "discrete"      #: only the sampled angles, with their weights
    CONTINUOUS = "continuous"  #: density linear between consecutive samples around the circle
    GAUSSIAN = "gaussian"      #: a Gaussian of sd ``angle_spread_deg`` around each sample, weighted


class LengthMode(StrEnum):
    """Where a new street's length comes from (000 §4.2.6)."""

    PDF = "pdf"                  #: truncated Gaussian ``length_mean_m`` ± ``length_sd_m``
    ORIENTATION = "orientation"  #: ``length_from_orientation`` at the drawn angle, times a jitter


class Proposal(StrEnum):
    """The street proposals (000 §4.2.6), plus 000 §4.2.3's ray bridge."""

    SNAP = "snap"
    SHORTEN = "shorten"
    EXTEND = "extend"
    DEFAULT = "default"
    BRIDGE = "bridge"


class Rule(StrEnum):
    """Why a proposal is invalid: 000 §4.2.6's rules a–g, water and bridges."""

    CROSSING = "crossing"          #: a) crosses a non-incident street or crossing
    ANGLE = "angle"                #: b) angle below min_angle_deg at either end
    LENGTH = "length"              #: c) outside [min_length_m, max_length_m]
    CS_DISTANCE = "cs_distance"    #: d) closer than min_cs_distance_m to a non-incident street
    CC_DISTANCE = "cc_distance"    #: e) new crossing closer than min_cc_distance_m to a crossing
    TRIANGLE = "triangle"          #: f) closes a 3-cycle (or doubles an existing street)
    DEGREE = "degree"              #: g) a crossing would exceed max_degree
    WATER = "water"                #: ends in water, or crosses it with bridges off
    FORBIDDEN = "forbidden"        #: touches a forbidden area
    BRIDGE_ATTEMPT = "bridge_attempt"  #: the start crossing's one bridge attempt is used up
    BRIDGE_LENGTH = "bridge_length"    #: a bridge longer than max_bridge_length_m
    BRIDGE_SPACING = "bridge_spacing"  #: a bridge closer than min_bridge_spacing_m to another


def _enum(kind: type[StrEnum], value: Any, key: str) -> StrEnum:
    return parse_enum(kind, value, f"pattern option {key}")


@dataclass(frozen=True)
class PatternOptions:
    """One street pattern: 000 §4.2.6's parameters plus 002 §3.1's snapping and look-ahead.

    The seeds name these parameters but give no values (000's eras.xml is
    not reproduced); each default says where it comes from. The defaults
    are Weber's organic pattern (:data:`ORGANIC`). Lists given for the
    tuple fields (as a TOML file gives them) are turned into tuples.
    """

    #: Frame of the drawn angle: world, crossing or centre (000 §4.2.6 isWorldSpace; centre for 002's radial).
    angle_space: AngleSpace = AngleSpace.CROSSING
    #: (angle in degrees, weight) samples of anglePDF (000 §4.2.6, appendix A.4's sampled functions).
    #: In crossing space 180° goes straight on from the first street, 90°/270° turn left/right.
    angle_pdf: tuple[tuple[float, float], ...] = ((180.0, 2.0), (90.0, 1.0), (270.0, 1.0))
    #: How the samples define the distribution: discrete, continuous or gaussian.
    angle_pdf_kind: PdfKind = PdfKind.GAUSSIAN
    #: Standard deviation (degrees) of each Gaussian peak: Weber's φσ for the organic pattern (002 §3.1
    #: leaves it to the user; 15° bends streets visibly without making them zig-zag).
    angle_spread_deg: float = 15.0
    #: Added to every drawn angle (degrees): the grid's orientation in world space, set by the engine
    #: from the town's own street bearings.
    angle_offset_deg: float = 0.0
    #: Length from a PDF or from the orientation (000 §4.2.6 lengthPDF / lengthFromOrientation).
    length_mode: LengthMode = LengthMode.PDF
    #: Mean (m) of the truncated-Gaussian length PDF (002 §3.1 organic: "the length is computed
    #: similarly"); 60 m is a typical old-town junction spacing.
    length_mean_m: float = 60.0
    #: Standard deviation (m) of the length PDF.
    length_sd_m: float = 20.0
    #: (angle in degrees, length in m) samples of lengthFromOrientation, linear in between and
    #: periodic over 360°; angles in the same frame as angle_pdf, before angle_offset_deg.
    length_from_orientation: tuple[tuple[float, float], ...] = ()
    #: Relative standard deviation of the orientation length (002's grid: "two length ranges").
    length_jitter: float = 0.0
    #: Which proposals are made (000 §4.2.6 defaultEnabled, extendEnabled, shortenEnabled, snapEnabled).
    default_enabled: bool = True
    extend_enabled: bool = True
    shorten_enabled: bool = True
    snap_enabled: bool = True
    #: Snap to the nearest crossing within this radius (m) of the Default end (002 §3.1: "typically 25 m").
    snap_radius_m: float = 25.0
    #: Extend looks this many times the Default length ahead (002 §3.1: "enlarge … by a factor 1.5").
    look_ahead: float = 1.5
    #: b) Minimum angle (degrees) with every street sharing a crossing. 30° lets organic streets meet
    #: at sharp but buildable angles (a lot in the wedge is still ~15 m deep 30 m from the crossing).
    min_angle_deg: float = 30.0
    #: c) Street length range (m). 20 m: below this a "street" is a kink (002's s_min); 150 m: an
    #: organic street grows in short pieces.
    min_length_m: float = 20.0
    max_length_m: float = 150.0
    #: d) Minimum distance (m) to a non-incident street: two facing rows of 6 m-deep houses.
    min_cs_distance_m: float = 12.0
    #: e) Minimum distance (m) of a new crossing to an existing one; below the 25 m snap radius so that
    #: a Default end near a crossing snaps to it instead of being rejected.
    min_cc_distance_m: float = 15.0
    #: g) Maximum crossing degree: 4 (002 §3.1: a node is finished when its valence exceeds 3).
    max_degree: int = 4
    #: Default streets drawn per start before it counts as exhausted (000: "several attempts").
    attempts_per_start: int = 8
    #: Streets grown from one start (003 §3.3.2 grows from G(t) nodes: one each by default; 000's queue
    #: grows until max_degree — set this to max_degree for that).
    streets_per_start: int = 1
    #: May streets start at points on segments (003 §3.3.2's temporary nodes)? A world-space grid
    #: should grow only from crossings, as 000's queue does: a start anywhere along a road puts the
    #: lattice out of phase and the blocks never close. The engine passes this to
    #: ``candidate_points(..., temporary_points=...)``; ``grow_streets`` skips such starts when False.
    segment_starts: bool = True
    #: Centre space only: bend a tangential street by asin(L / 2R) towards the centre so that its end
    #: lies on the start's circle, as 002's radial pattern puts it ("on a circle around the center").
    ring_chords: bool = True
    #: Bridges at all (000 §4.2.6).
    bridges_enabled: bool = True
    #: Longest bridge (m). 000/003 give none; 250 m spans the rivers of most small and mid-sized towns.
    max_bridge_length_m: float = 250.0
    #: No bridge this close (m) to another (000 §4.2.6 "a predefined constant"); 300 m keeps river
    #: crossings a few blocks apart, as in old towns.
    min_bridge_spacing_m: float = 300.0
    #: Rays of 000 §4.2.3's bridge search from a crossing near water (0: no ray bridges, only
    #: proposals that happen to cross water).
    bridge_rays: int = 16
    #: A crossing is "near water" (tries a ray bridge) within this distance (m); 000 §4.2.3 samples a
    #: circle around the vertex, the lattice pitch of 15–20 m is its natural radius.
    bridge_search_radius_m: float = 20.0
    #: Spacing (m) of the samples along a bridge ray (000 §4.2.3 marches along it).
    bridge_sample_step_m: float = 2.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "angle_space", _enum(AngleSpace, self.angle_space, "angle_space"))
        set_(self, "angle_pdf_kind", _enum(PdfKind, self.angle_pdf_kind, "angle_pdf_kind"))
        set_(self, "length_mode", _enum(LengthMode, self.length_mode, "length_mode"))
        for key in ("angle_pdf", "length_from_orientation"):
            try:
                pairs = tuple((float(a), float(b)) for a, b in getattr(self, key))
            except (TypeError, ValueError):
                raise InputError(f"pattern option {key}: expected a list of [angle, value] pairs") from None
            set_(self, key, pairs)
        self._validate()

    def _validate(self) -> None:
        def bad(key: str, why: str) -> InputError:
            return InputError(f"pattern option {key}: {why}, got {getattr(self, key)!r}")

        if not self.angle_pdf or any(w < 0 for _, w in self.angle_pdf) or sum(w for _, w in self.angle_pdf) <= 0:
            raise bad("angle_pdf", "needs at least one (angle, weight) with weights ≥ 0 and a positive sum")
        if self.length_mode is LengthMode.ORIENTATION and not self.length_from_orientation:
            raise bad("length_from_orientation", "is required when length_mode is orientation")
        if any(v <= 0 for _, v in self.length_from_orientation):
            raise bad("length_from_orientation", "lengths must be > 0 m")
        positive = ("length_mean_m", "snap_radius_m", "min_angle_deg", "min_length_m", "max_length_m",
                    "max_bridge_length_m", "bridge_sample_step_m")
        for key in positive:
            if not getattr(self, key) > 0:
                raise bad(key, "must be > 0")
        for key in ("angle_spread_deg", "length_sd_m", "length_jitter", "min_cs_distance_m",
                    "min_cc_distance_m", "min_bridge_spacing_m", "bridge_search_radius_m", "bridge_rays"):
            if getattr(self, key) < 0:
                raise bad(key, "must be ≥ 0")
        if self.max_length_m < self.min_length_m:
            raise bad("max_length_m", f"must be ≥ min_length_m ({self.min_length_m})")
        if self.min_angle_deg >= 180:
            raise bad("min_angle_deg", "must be < 180")
        if self.look_ahead < 1:
            raise bad("look_ahead", "must be ≥ 1")
        for key in ("max_degree", "attempts_per_start", "streets_per_start"):
            if getattr(self, key) < 1:
                raise bad(key, "must be ≥ 1")
            if getattr(self, key) > MAX_TRIES:  # a loop count: 10**9 would hang the run without a word
                raise bad(key, f"must be ≤ {MAX_TRIES}")
        if self.max_degree < 2:
            raise bad("max_degree", "must be ≥ 2")

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> PatternOptions:
        """Options from a mapping (a TOML table); unknown keys raise :class:`InputError`."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise InputError(f"pattern options: unknown key(s) {', '.join(unknown)}")
        return cls(**values)


#: Largest per-start loop count (``attempts_per_start``, ``streets_per_start``, ``max_degree``): the
#: defaults are 8, 1 and 4; a thousand tries per start is already far past any use.
MAX_TRIES = 1000


# --------------------------------------------------------------------------- parameter sets

#: Weber's organic pattern (002 §3.1): angle deviation from a truncated Gaussian around straight
#: on, left or right of the incoming street (crossing space); length likewise Gaussian.
ORGANIC = PatternOptions()

#: Weber's grid pattern (002 §3.1): angle deviation 0 (discrete straight/left/right in crossing
#: space), two length ranges: long blocks straight on (120 m), short ones across (60 m), ±10 %.
#: min_angle 60° keeps only right angles; min distances are half a short block. Grids grow from
#: crossings only, up to three streets each (000's queue grows a crossing to max_degree), so
#: that the blocks close.
GRID = PatternOptions(
    angle_space=AngleSpace.CROSSING, angle_pdf=((180.0, 2.0), (90.0, 1.0), (270.0, 1.0)),
    angle_pdf_kind=PdfKind.DISCRETE, angle_spread_deg=0.0, length_mode=LengthMode.ORIENTATION,
    length_from_orientation=((0.0, 120.0), (90.0, 60.0), (180.0, 120.0), (270.0, 60.0)),
    length_jitter=0.1, min_angle_deg=60.0, min_length_m=30.0, max_length_m=160.0,
    min_cs_distance_m=25.0, min_cc_distance_m=20.0, streets_per_start=3, segment_starts=False,
)

#: Weber's radial pattern (002 §3.1): the next node lies on a ray to or from the centre (0°, 180°
#: in centre space) or on the start's circle around it (90°/270°, bent into a chord). Ring
#: streets a little shorter than spokes (70 m vs 90 m): rings stay round near the centre.
RADIAL = PatternOptions(
    angle_space=AngleSpace.CENTRE, angle_pdf=((0.0, 2.0), (90.0, 1.0), (270.0, 1.0), (180.0, 0.5)),
    angle_pdf_kind=PdfKind.DISCRETE, angle_spread_deg=0.0, length_mode=LengthMode.ORIENTATION,
    length_from_orientation=((0.0, 90.0), (90.0, 70.0), (180.0, 90.0), (270.0, 70.0)),
    length_jitter=0.1, min_angle_deg=45.0, min_length_m=25.0, max_length_m=150.0,
    min_cs_distance_m=20.0, min_cc_distance_m=20.0,
)

#: 000 §4.2.9's medieval era ("mostly organic"): organic with short, strongly bent lanes
#: (40 ± 15 m, 25° spread), narrow spacing (10 m lanes between house rows) and sharp angles allowed.
MEDIEVAL = replace(
    ORGANIC, angle_spread_deg=25.0, length_mean_m=40.0, length_sd_m=15.0, min_length_m=15.0,
    max_length_m=90.0, min_angle_deg=25.0, min_cs_distance_m=10.0, min_cc_distance_m=12.0,
)

#: A 19th-century European block grid in world space (Hobrecht's Berlin, Cerdà's Barcelona: blocks
#: of about 110 × 70 m): 0°/180° long, 90°/270° short; the engine sets angle_offset_deg to the
#: town's dominant bearing.
GRID_19TH_CENTURY = PatternOptions(
    angle_space=AngleSpace.WORLD, angle_pdf=((0.0, 1.0), (90.0, 1.0), (180.0, 1.0), (270.0, 1.0)),
    angle_pdf_kind=PdfKind.DISCRETE, angle_spread_deg=0.0, length_mode=LengthMode.ORIENTATION,
    length_from_orientation=((0.0, 110.0), (90.0, 70.0), (180.0, 110.0), (270.0, 70.0)),
    length_jitter=0.05, min_angle_deg=60.0, min_length_m=30.0, max_length_m=150.0,
    min_cs_distance_m=30.0, min_cc_distance_m=20.0, streets_per_start=3, segment_starts=False,
)

#: A North-American grid in world space: the Chicago block, 1/8 × 1/16 mile ≈ 200 × 100 m.
GRID_NORTH_AMERICAN = replace(
    GRID_19TH_CENTURY,
    length_from_orientation=((0.0, 200.0), (90.0, 100.0), (180.0, 200.0), (270.0, 100.0)),
    min_length_m=40.0, max_length_m=260.0, min_cs_distance_m=40.0, min_cc_distance_m=25.0,
)

#: Modern suburban streets (000 §2: sprawl at the fringes): long gentle curves, T-junctions only
#: (max_degree 3), few connections — Snap and Extend off, so streets end in cul-de-sacs unless
#: they run into another street (Shorten).
SUBURBAN = replace(
    ORGANIC, angle_pdf=((180.0, 3.0), (90.0, 1.0), (270.0, 1.0)), angle_spread_deg=12.0,
    length_mean_m=70.0, length_sd_m=25.0, min_length_m=25.0, max_length_m=160.0, min_angle_deg=50.0,
    min_cs_distance_m=25.0, min_cc_distance_m=25.0, max_degree=3, snap_enabled=False, extend_enabled=False,
)

#: The named parameter sets, for a history file's ``pattern = "…"``.
PATTERNS: dict[str, PatternOptions] = {
    "organic": ORGANIC, "grid": GRID, "radial": RADIAL, "medieval": MEDIEVAL,
    "grid_19th_century": GRID_19TH_CENTURY, "grid_north_american": GRID_NORTH_AMERICAN,
    "suburban": SUBURBAN,
}


def pattern(name: str, **overrides: Any) -> PatternOptions:
    """A named parameter set (see :data:`PATTERNS`) with some fields replaced.

    Raises
    ------
    InputError
        For an unknown name or field.
    """
    if name not in PATTERNS:
        raise InputError(f"street pattern {name!r} is not one of {', '.join(PATTERNS)}")
    base = PATTERNS[name]
    return PatternOptions.from_mapping({**{f.name: getattr(base, f.name) for f in fields(base)}, **overrides})


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


# --------------------------------------------------------------------------- the rules

@dataclass
class _Verdict:
    rule: Rule | None
    bridge: bool = False        # the proposal crosses water
    bridge_tested: bool = False  # it reached the bridge tests: the start's attempt is used


class _Areas:
    """Water and forbidden areas, prepared once per call."""

    def __init__(self, water: shapely.Geometry | None, forbidden: shapely.Geometry | None):
        self.water = _prepared(water)
        self.forbidden = _prepared(forbidden)

    def in_water(self, p: NDArray[np.float64]) -> bool:
        return self.water is not None and bool(shapely.intersects_xy(self.water, p[0], p[1]))

    def crosses_water(self, p: NDArray[np.float64], q: NDArray[np.float64]) -> bool:
        return self.water is not None and bool(shapely.intersects(self.water, shapely.linestrings([p, q])))

    def touches_forbidden(self, p: NDArray[np.float64], q: NDArray[np.float64]) -> bool:
        return self.forbidden is not None and bool(shapely.intersects(self.forbidden, shapely.linestrings([p, q])))


def _prepared(geom: shapely.Geometry | None) -> shapely.Geometry | None:
    if geom is None or shapely.is_empty(geom):
        return None
    shapely.prepare(geom)
    return geom


def check_proposal(graph: StreetGraph, start: Start, proposal: StreetProposal, *,
                   options: PatternOptions = ORGANIC, water: shapely.Geometry | None = None,
                   forbidden: shapely.Geometry | None = None) -> Rule | None:
    """The first rule a proposal breaks, or None if it is valid (000 §4.2.6 a–g, water, bridges).

    Rules are tested in this order: spacing of a start that splits a
    segment (e), length (c), degree (g), angle at both ends (b), triangle
    (f), spacing of a new end crossing (e), crossing (a), street distance
    (d), forbidden area, water (ending in it; crossing it with bridges off),
    then for a bridge: the start's one attempt, ``max_bridge_length_m``,
    spacing to other bridges. A street longer than ``max_length_m`` but no
    longer than ``max_bridge_length_m`` passes c only if it is a bridge.

    Parameters
    ----------
    graph : StreetGraph
    start : Start
    proposal : StreetProposal
    options : PatternOptions
    water, forbidden : shapely geometry, optional
        Areas (m) a street may not end in / may not touch. Prepared in place.

    Returns
    -------
    Rule or None
    """
    ctx = _Context(graph, start)
    cand = _Candidates.gather(graph, ctx.xy, np.asarray(proposal.end_xy, dtype=np.float64), options)
    return _check(graph, ctx, proposal, cand, options, _Areas(water, forbidden)).rule


def _check(graph: StreetGraph, ctx: _Context, prop: StreetProposal, cand: _Candidates,
           options: PatternOptions, areas: _Areas) -> _Verdict:
    p = ctx.xy
    q = np.asarray(prop.end_xy, dtype=np.float64)
    v = q - p
    length = math.hypot(v[0], v[1])
    if ctx.node < 0 and cand.any_node_within(p, options.min_cc_distance_m):
        return _Verdict(Rule.CC_DISTANCE)
    # c) length (the upper bound waits for the water test when a bridge may be longer)
    longest = options.max_length_m
    if options.bridges_enabled:
        longest = max(longest, options.max_bridge_length_m)
    if length < options.min_length_m or length > longest:
        return _Verdict(Rule.LENGTH)
    # g) degree at both ends
    end_degree = graph.node_degree(prop.end_node) if prop.end_node >= 0 else (2 if prop.end_segment >= 0 else 0)
    if ctx.degree + 1 > options.max_degree or end_degree + 1 > options.max_degree:
        return _Verdict(Rule.DEGREE)
    # b) angle with every street sharing a crossing, at the start and at the end
    theta = math.atan2(v[1], v[0])
    min_angle = math.radians(options.min_angle_deg)
    if _min_angle_between(theta, ctx.incident_dirs) < min_angle:
        return _Verdict(Rule.ANGLE)
    end_nb = _end_neighbours(graph, prop)
    if len(end_nb) and _min_angle_between(theta + math.pi, _angles(graph.xy[end_nb] - q)) < min_angle:
        return _Verdict(Rule.ANGLE)
    # f) no triangle (nor a second street between the same crossings)
    if prop.end_node >= 0 and (prop.end_node in ctx.neighbours or set(ctx.neighbours) & set(end_nb.tolist())):
        return _Verdict(Rule.TRIANGLE)
    if prop.end_segment >= 0 and set(ctx.neighbours) & set(end_nb.tolist()):
        return _Verdict(Rule.TRIANGLE)
    # e) a new end crossing keeps its distance from existing crossings
    if prop.end_node < 0 and cand.any_node_within(q, options.min_cc_distance_m):
        return _Verdict(Rule.CC_DISTANCE)
    # a) and d) against the non-incident streets nearby
    excluded = list(ctx.excluded)
    if prop.end_node >= 0:
        excluded += graph.incident(prop.end_node)
    elif prop.end_segment >= 0:
        excluded.append(prop.end_segment)
    rule = _street_rules(p, q, cand, excluded, options.min_cs_distance_m)
    if rule is not None:
        return _Verdict(rule)
    # water and forbidden areas
    if areas.touches_forbidden(p, q):
        return _Verdict(Rule.FORBIDDEN)
    if areas.in_water(q):
        return _Verdict(Rule.WATER)
    if not areas.crosses_water(p, q):
        return _Verdict(Rule.LENGTH if length > options.max_length_m else None)
    if not options.bridges_enabled:
        return _Verdict(Rule.WATER, bridge=True)
    if ctx.bridge_tried:
        return _Verdict(Rule.BRIDGE_ATTEMPT, bridge=True)
    if length > options.max_bridge_length_m:
        return _Verdict(Rule.BRIDGE_LENGTH, bridge=True, bridge_tested=True)
    if _bridge_too_close(graph, p, q, options.min_bridge_spacing_m):
        return _Verdict(Rule.BRIDGE_SPACING, bridge=True, bridge_tested=True)
    return _Verdict(None, bridge=True, bridge_tested=True)


def _end_neighbours(graph: StreetGraph, prop: StreetProposal) -> NDArray[np.int64]:
    if prop.end_node >= 0:
        return np.asarray(graph.neighbours(prop.end_node), dtype=np.int64)
    if prop.end_segment >= 0:
        return graph.edges[prop.end_segment].copy()
    return np.zeros(0, dtype=np.int64)


def _street_rules(p: NDArray[np.float64], q: NDArray[np.float64], cand: _Candidates, excluded: list[int],
                  min_distance: float) -> Rule | None:
    """Rule a (no crossing of a non-incident street) and rule d (distance ≥ min_distance to one)."""
    if len(cand.ids) == 0:
        return None
    reach = min_distance + ON_TOLERANCE   # only segments whose box comes this near can cross or come close
    lo, hi = np.minimum(p, q) - reach, np.maximum(p, q) + reach
    keep = ((cand.lo[:, 0] <= hi[0]) & (cand.hi[:, 0] >= lo[0]) & (cand.lo[:, 1] <= hi[1])
            & (cand.hi[:, 1] >= lo[1]))
    for s in excluded:
        keep &= cand.ids != s
    a, b = cand.a[keep], cand.b[keep]
    if len(a) == 0:
        return None
    if _intersects(p, q, a, b).any():
        return Rule.CROSSING
    if min_distance > 0 and _segment_distance(p, q, a, b).min() < min_distance:
        return Rule.CS_DISTANCE
    return None


def _point_segment_distance(x: NDArray[np.float64], a: NDArray[np.float64],
                            b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (m) from points x to segments a–b, broadcast over the leading axes."""
    d = b - a
    t = np.clip(((x - a) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-24), 0.0, 1.0)
    f = x - (a + t[..., None] * d)
    return np.sqrt((f * f).sum(-1))


def _segment_distance(p: NDArray[np.float64], q: NDArray[np.float64], a: NDArray[np.float64],
                      b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (m) between segment p–q and each non-crossing segment a–b: the least end-to-segment distance."""
    ends = np.stack([p, q])[:, None, :]                      # (2, 1, 2) against (K, 2)
    to_them = _point_segment_distance(ends, a[None], b[None]).min(axis=0)
    to_us = _point_segment_distance(np.stack([a, b]), p, q).min(axis=0)
    return np.minimum(to_them, to_us)


def _bridge_too_close(graph: StreetGraph, p: NDArray[np.float64], q: NDArray[np.float64], spacing: float) -> bool:
    if spacing <= 0:
        return False
    ids = np.flatnonzero(graph.bridge)
    if len(ids) == 0:
        return False
    a, b = graph.segment_ends(ids)
    close = _segment_distance(p, q, a, b) < spacing
    close |= _intersects(p, q, a, b)
    return bool(close.any())


# --------------------------------------------------------------------------- drawing a Default street

class _Sampler:
    """Draws (relative angle, length) pairs from a pattern's PDFs."""

    def __init__(self, options: PatternOptions):
        self.o = options
        ang = np.array([a for a, _ in options.angle_pdf]) % 360.0
        w = np.array([w for _, w in options.angle_pdf])
        self.kind = options.angle_pdf_kind
        if self.kind is PdfKind.CONTINUOUS:
            order = np.argsort(ang, kind="stable")
            ang, w = ang[order], w[order]
            nxt_a = np.append(ang[1:], ang[0] + 360.0)
            nxt_w = np.append(w[1:], w[0])
            self.lo, self.width, self.w0, self.w1 = ang, nxt_a - ang, w, nxt_w
            area = 0.5 * (w + nxt_w) * self.width
            self.cum = np.cumsum(area) / area.sum()
        else:
            self.peaks = ang
            self.cum = np.cumsum(w) / w.sum()
        if options.length_from_orientation:
            la = np.array([a for a, _ in options.length_from_orientation]) % 360.0
            lv = np.array([v for _, v in options.length_from_orientation])
            order = np.argsort(la, kind="stable")
            la, lv = la[order], lv[order]
            self.len_angle = np.concatenate([la - 360.0, la, la + 360.0])
            self.len_value = np.concatenate([lv, lv, lv])

    def angle(self, rng: np.random.Generator) -> float:
        """A relative angle in degrees."""
        k = min(int(np.searchsorted(self.cum, rng.random(), side="right")), len(self.cum) - 1)
        if self.kind is PdfKind.CONTINUOUS:
            w0, w1, width = self.w0[k], self.w1[k], self.width[k]
            u = rng.random()
            if abs(w1 - w0) < 1e-12 * max(w0, w1, 1e-12):
                x = u * width
            else:  # inverse CDF of a density linear from w0 to w1 over [0, width]
                x = width * (-w0 + math.sqrt(w0 * w0 + (w1 * w1 - w0 * w0) * u)) / (w1 - w0)
            return float(self.lo[k] + x)
        a = float(self.peaks[k])
        if self.kind is PdfKind.GAUSSIAN and self.o.angle_spread_deg > 0:
            a += self.o.angle_spread_deg * float(rng.standard_normal())
        return a

    def length(self, rel_angle_deg: float, rng: np.random.Generator) -> float:
        o = self.o
        if o.length_mode is LengthMode.ORIENTATION:
            base = float(np.interp(rel_angle_deg % 360.0, self.len_angle, self.len_value))
            value = base * (1.0 + o.length_jitter * float(rng.standard_normal())) if o.length_jitter else base
            return float(np.clip(value, o.min_length_m, o.max_length_m))
        for _ in range(8):  # truncated Gaussian by rejection, then clipped
            value = o.length_mean_m + o.length_sd_m * float(rng.standard_normal())
            if o.min_length_m <= value <= o.max_length_m:
                return value
        return float(np.clip(value, o.min_length_m, o.max_length_m))


def _reference_angle(ctx: _Context, options: PatternOptions, centre: NDArray[np.float64] | None) -> float:
    """World direction (rad) that relative angle 0 points to."""
    off = math.radians(options.angle_offset_deg)
    if options.angle_space is AngleSpace.CROSSING and ctx.first_dir is not None:
        return ctx.first_dir + off
    if options.angle_space is AngleSpace.CENTRE and centre is not None:
        ray = _direction(ctx.xy - centre)
        if ray is not None:
            return ray + off
    return off


def _draw_default(ctx: _Context, sampler: _Sampler, options: PatternOptions, centre: NDArray[np.float64] | None,
                  rng: np.random.Generator) -> tuple[float, float]:
    """World angle (rad) and length (m) of a Default street from the start."""
    rel = sampler.angle(rng)
    length = sampler.length(rel, rng)
    theta = _reference_angle(ctx, options, centre) + math.radians(rel)
    if options.angle_space is AngleSpace.CENTRE and options.ring_chords and centre is not None:
        radius = math.hypot(*(ctx.xy - centre))
        if radius > 0:
            theta += math.asin(min(1.0, length / (2 * radius))) * math.sin(math.radians(rel))
    return theta, length


# --------------------------------------------------------------------------- bridges by rays (000 §4.2.3)

def _ray_bridge(ctx: _Context, options: PatternOptions, areas: _Areas,
                rng: np.random.Generator) -> StreetProposal | None:
    """000 §4.2.3: from a crossing near water, the ray that crosses water in the shortest span."""
    if areas.water is None or options.bridge_rays == 0 or not options.bridges_enabled:
        return None
    p = ctx.xy
    if not shapely.dwithin(areas.water, shapely.points(p), options.bridge_search_radius_m):
        return None
    step = options.bridge_sample_step_m
    n = int(options.max_bridge_length_m // step)
    fan = 2 * math.pi / options.bridge_rays
    theta = (rng.random() + np.arange(options.bridge_rays)) * fan
    dist = step * np.arange(1, n + 1)
    x = p[0] + np.cos(theta)[:, None] * dist
    y = p[1] + np.sin(theta)[:, None] * dist
    wet = shapely.intersects_xy(areas.water, x, y)
    best, best_len = None, math.inf
    for r in range(options.bridge_rays):
        w = np.flatnonzero(wet[r])
        if len(w) == 0:
            continue
        dry = np.flatnonzero(~wet[r, w[0]:])
        if len(dry) == 0:
            continue
        j = w[0] + dry[0]
        if dist[j] < best_len:
            best, best_len = (x[r, j], y[r, j]), dist[j]
    return None if best is None else StreetProposal(Proposal.BRIDGE, (float(best[0]), float(best[1])))


# --------------------------------------------------------------------------- growing

def grow_streets(graph: StreetGraph, starts: StartPoints | ArrayLike | Sequence[Start], *,
                 options: PatternOptions = ORGANIC, rng: np.random.Generator,
                 water: shapely.Geometry | None = None, forbidden: shapely.Geometry | None = None,
                 centre: ArrayLike | None = None, time: float = 0.0) -> GrowthStep:
    """Grow streets from each start with one street pattern (000 §4.2.6), updating ``graph`` in place.

    For each start in order: up to ``attempts_per_start`` times, draw a
    Default street (angle from ``angle_pdf`` in the pattern's frame, length
    from the length PDF or the orientation), make the Snap, Shorten, Extend
    and Default proposals and build the first valid one (rules a–g, water,
    bridges); stop after ``streets_per_start`` streets. A crossing within
    ``bridge_search_radius_m`` of water that has not made its bridge attempt
    first tries 000 §4.2.3's ray bridge. A start on a segment is split only
    when a street grows from it. Every start that was a crossing, or became
    one, is marked in ``graph.spawned`` (grown or exhausted: 002 §3.1 marks
    a node finished "if the expansion fails multiple times").

    Parameters
    ----------
    graph : StreetGraph
        Modified in place: nodes and segments added, segments split, the
        ``spawned`` and ``bridge_tried`` marks set.
    starts : int array of shape (S,), sequence of Start, or StartPoints
        Node ids, or objects with ``node`` (-1 for a point on a segment),
        ``segment`` and ``xy`` arrays (e.g. the ranked candidates of
        :func:`osm_expand.engine.growth.nuclei.candidate_points`). A segment start
        whose segment was split earlier in the call is found again by position;
        segment starts are skipped when the pattern's ``segment_starts`` is False.
    options : PatternOptions
        The era's street pattern.
    rng : numpy.random.Generator
        The only source of randomness; same state, same result.
    water, forbidden : shapely geometry, optional
        Water (streets may cross it only as bridges, never end in it) and
        forbidden areas (streets may not touch them), in metres. Prepared in place.
    centre : array_like, shape (2,), optional
        Pattern centre (m) for ``angle_space = "centre"`` (002's radial: the
        nearest city centre); required then.
    time : float
        Creation time recorded on the new segments (the current year).

    Returns
    -------
    GrowthStep
        What was added, with ids into ``graph``.
    """
    if options.angle_space is AngleSpace.CENTRE and centre is None:
        raise InputError("grow_streets: angle_space 'centre' needs a centre point")
    centre_xy = None if centre is None else np.asarray(centre, dtype=np.float64).reshape(2)
    start_list = _as_starts(graph, starts)
    sampler = _Sampler(options)
    areas = _Areas(water, forbidden)
    log = _Log()
    grown = np.zeros(len(start_list), dtype=bool)
    start_node = np.full(len(start_list), -1, dtype=np.int64)
    for i, raw in enumerate(start_list):
        if raw.node < 0 and not options.segment_starts:
            continue
        start = _resolve(graph, raw)
        if start is None:
            continue
        made, node = _grow_from(graph, start, i, options, sampler, areas, centre_xy, rng, time, log)
        grown[i] = made > 0
        if node < 0:
            log.failed.append(start.xy)
        start_node[i] = node
        if node >= 0:
            graph.spawned[node] = True
    return GrowthStep(
        new_nodes=np.asarray(log.nodes, dtype=np.int64),
        new_segments=np.asarray(log.segments, dtype=np.int64),
        proposal=np.asarray(log.kinds, dtype=np.str_),
        start_index=np.asarray(log.starts, dtype=np.int64),
        bridges=np.asarray(log.bridges, dtype=np.int64),
        split_segment=np.asarray([s[0] for s in log.splits], dtype=np.int64),
        split_node=np.asarray([s[1] for s in log.splits], dtype=np.int64),
        split_new_segment=np.asarray([s[2] for s in log.splits], dtype=np.int64),
        failed_xy=np.asarray(log.failed, dtype=np.float64).reshape(-1, 2),
        grown=grown, start_node=start_node,
    )


def _as_starts(graph: StreetGraph, starts: Any) -> list[Start]:
    if isinstance(starts, (list, tuple)) and starts and isinstance(starts[0], Start):
        return list(starts)
    if hasattr(starts, "node") and hasattr(starts, "segment") and hasattr(starts, "xy"):
        node = np.asarray(starts.node, dtype=np.int64)
        seg = np.asarray(starts.segment, dtype=np.int64)
        xy = np.asarray(starts.xy, dtype=np.float64).reshape(-1, 2)
        return [Start.at_node(graph, int(n)) if n >= 0 else Start.on_segment(int(s), p)
                for n, s, p in zip(node.tolist(), seg.tolist(), xy)]
    ids = np.asarray(starts, dtype=np.int64).reshape(-1)
    if len(ids) and (ids.min() < 0 or ids.max() >= graph.n_nodes):
        raise InputError(f"grow_streets: start node ids must lie in 0..{graph.n_nodes - 1}")
    return [Start.at_node(graph, int(n)) for n in ids.tolist()]


def _grow_from(graph: StreetGraph, start: Start, index: int, options: PatternOptions, sampler: _Sampler,
               areas: _Areas, centre: NDArray[np.float64] | None, rng: np.random.Generator, time: float,
               log: _Log) -> tuple[int, int]:
    """Grow up to streets_per_start streets from one start; returns how many, and its crossing (or -1)."""
    made = 0
    ctx = _Context(graph, start)
    if ctx.degree >= options.max_degree:
        return 0, start.node
    if start.node >= 0 and not ctx.bridge_tried:
        bridge = _ray_bridge(ctx, options, areas, rng)
        if bridge is not None:
            cand = _Candidates.gather(graph, ctx.xy, np.asarray(bridge.end_xy), options)
            verdict = _check(graph, ctx, bridge, cand, options, areas)
            graph.bridge_tried[start.node] = ctx.bridge_tried = True
            if verdict.rule is None:
                start = _build(graph, start, bridge, True, index, time, log, areas)
                made += 1
                ctx = _Context(graph, start)
    for _ in range(options.attempts_per_start):
        if made >= options.streets_per_start or ctx.degree >= options.max_degree:
            break
        theta, length = _draw_default(ctx, sampler, options, centre, rng)
        if _hopeless(ctx, theta, length, options):
            continue
        end = ctx.xy + length * np.array([math.cos(theta), math.sin(theta)])
        cand = _Candidates.gather(graph, ctx.xy, end, options)
        for prop in _propose(graph, ctx, cand, theta, length, options):
            verdict = _check(graph, ctx, prop, cand, options, areas)
            if verdict.bridge_tested:  # the start's one bridge attempt is used, built or not
                ctx.bridge_tried = True
                if start.node >= 0:
                    graph.bridge_tried[start.node] = True
            if verdict.rule is None:
                start = _build(graph, start, prop, verdict.bridge, index, time, log, areas)
                if verdict.bridge or ctx.bridge_tried:
                    graph.bridge_tried[start.node] = True
                made += 1
                ctx = _Context(graph, start)
                break
    return made, start.node


def _hopeless(ctx: _Context, theta: float, length: float, options: PatternOptions) -> bool:
    """No proposal of this Default street can pass rule b at the start (a shortcut, not a rule).

    Shorten, Extend and Default share its direction; a Snap end lies within
    the snap radius of its end, so its direction differs by at most
    asin(snap_radius / length) (any direction when the street is shorter).
    """
    gap = _min_angle_between(theta, ctx.incident_dirs)
    min_angle = math.radians(options.min_angle_deg)
    if gap >= min_angle:
        return False
    if not options.snap_enabled or options.snap_radius_m >= length:
        return not options.snap_enabled
    return gap + math.asin(options.snap_radius_m / length) < min_angle


def _build(graph: StreetGraph, start: Start, prop: StreetProposal, bridge: bool, index: int, time: float,
           log: _Log, areas: _Areas) -> Start:
    """Add the proposal's street (splitting where it starts or ends on a segment); returns the start as a crossing."""
    c = start.node
    if c < 0:
        c = _split(graph, start.segment, np.asarray(start.xy), log, areas)
    end_xy = np.asarray(prop.end_xy, dtype=np.float64)
    if prop.end_node >= 0:
        e = prop.end_node
    elif prop.end_segment >= 0:
        seg = prop.end_segment
        if graph.segment_at(end_xy) != seg:  # the start split moved it
            seg = graph.segment_at(end_xy)
        e = _split(graph, seg, end_xy, log, areas)
    else:
        e = graph.add_node(end_xy)
        log.nodes.append(e)
    s = graph.add_segment(c, e, created=time, bridge=bridge)
    log.segments.append(s)
    log.kinds.append(str(prop.kind))
    log.starts.append(index)
    if bridge:
        log.bridges.append(s)
        graph.bridge_tried[e] = True
    return Start.at_node(graph, c)


def _split(graph: StreetGraph, segment: int, point: NDArray[np.float64], log: _Log, areas: _Areas) -> int:
    """Split a segment for a new street's end; a split bridge stays a bridge only where it crosses water."""
    node = graph.split(segment, point)
    half = graph.n_segments - 1
    log.nodes.append(node)
    log.splits.append((segment, node, half))
    if graph.bridge[segment] and areas.water is not None:
        for k in (segment, half):
            a, b = graph.segment_ends([k])
            graph.bridge[k] = areas.crosses_water(a[0], b[0])
    return node
