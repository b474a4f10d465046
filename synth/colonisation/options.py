"""Space colonisation's tunables (001 ch. 4) and the hierarchy's levels."""
from __future__ import annotations

from dataclasses import dataclass, fields
from enum import StrEnum
from typing import Any

import numpy as np

from osm_expand.errors import InputError


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
