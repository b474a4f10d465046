"""A Beneš street pattern's tunables (000 §4.2.6) and the kinds they choose between."""
from __future__ import annotations

from dataclasses import dataclass, fields
from enum import StrEnum
from typing import Any

from osm_expand.errors import InputError
from osm_expand.model.enums import parse_enum


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
