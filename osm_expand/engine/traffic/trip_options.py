"""The options of the trip model and of the streets' status and widths (002 §2, §3.2); the model
is described in :mod:`osm_expand.engine.traffic.trips`."""
from __future__ import annotations

import enum
from dataclasses import dataclass

from osm_expand.errors import InputError
from osm_expand.model.options import require_positive

__all__ = ["DistanceDecay", "TripOptions"]


class DistanceDecay(enum.StrEnum):
    """The gravity model's distance function ``f`` (002 §3.2, after McNally)."""

    EXPONENTIAL = "exponential"
    POWER = "power"


@dataclass(frozen=True)
class TripOptions:
    # --- trips (002 §3.2; the paper gives no numbers)
    #: One-way trips a day per resident of a street (002 ``tripsperresidents``).
    #: 2: out and back; residents include people working or shopping there
    #: (002: "how many people will be there during a 24 hour period").
    trips_per_resident: float = 2.0
    #: Simulated trips if every segment were sampled (002: "the total number of
    #: simulated trips is approximately equal to a user specified constant");
    #: one simulated trip carries Σ trips / target_trips people (at least 1).
    target_trips: int = 30_000
    #: ``f``: ``"exponential"`` exp(−d/L) or ``"power"`` (1 + d/L)^−k (002: 1/x²).
    decay: str = "exponential"
    #: L, equivalent metres. 1.5 km: most trips inside a town stay within a
    #: few km, and a typical path also carries one or two 500 m turns.
    decay_length: float = 1500.0
    #: k of the power law (002: 1/x², so 2).
    decay_power: float = 2.0
    #: Dijkstra stops at cutoff · L (f there: e^−3 = 5 %, or 4^−2 = 6 % for the power law).
    cutoff: float = 3.0
    #: Cost of a 90° turn, metres of straight minor street (002: "a 90 degree
    #: turn as a straight 500m drive"); linear in the turn angle.
    turn_cost: float = 500.0
    #: Speed on minor streets, km/h (the cost unit: 1 m of minor street = 1).
    minor_speed: float = 30.0
    #: Speed on major roads, km/h (002: the distance depends on "the type of
    #: street and its speed"); 50 km/h is the urban limit in most of Europe.
    major_speed: float = 50.0
    #: Share of unchanged segments re-sampled each step (002 ``trafficsamplerate``).
    sample_rate: float = 0.08
    #: Residents changed when they differ from those at the last sampling by
    #: more than this share (and by more than one person).
    resident_change: float = 0.05
    #: At most this many segments are re-sampled per step (new, then changed,
    #: then the random share); the rest wait. Keeps a year ≤ 0.3 s at 3,000
    #: segments (one source costs about 0.5 ms of CPU there, 0.9 ms at 10,000);
    #: ``step_trips(full=True)`` ignores it (the first fill).
    max_sources: int = 250
    #: Sources per Dijkstra call: bounds the (batch × 3E) distance matrix.
    batch_sources: int = 64
    #: Residents per m² of block when lots are not known yet (80 per hectare:
    #: a European town's net residential density, counting day-time people).
    density: float = 0.008
    # --- status and widths (002 §2, §3.2)
    #: A planned street is built when its traffic reaches this (people/day;
    #: 002 "a user-defined threshold"): about ten houses' worth of trips.
    build_threshold: float = 50.0
    #: People a day one lane carries (≈ 4,000 vehicles at 1.25 people each,
    #: a comfortable urban lane); lanes = ceil(traffic / lane_capacity).
    lane_capacity: float = 5000.0
    #: Width of a lane, m (the issue: "lanes × 3.5 m + sidewalks").
    lane_width: float = 3.5
    #: Width of one sidewalk, m; a street has two.
    sidewalk_width: float = 2.0
    #: Fewest lanes of a minor street (a one-lane old-town street: 7.5 m).
    min_lanes: int = 1
    #: Fewest lanes of a major road (two-way: 11 m).
    major_min_lanes: int = 2
    #: Most lanes (25 m with sidewalks).
    max_lanes: int = 6
    #: Years between a width's need changing and the street being rebuilt
    #: (002: "the final street width is computed after a user specified time span").
    width_delay: int = 5
    #: Whether built streets may narrow when traffic falls (real streets are
    #: lined with buildings; by default they only widen).
    shrink: bool = False

    def __post_init__(self) -> None:
        try:
            DistanceDecay(self.decay)
        except ValueError:
            raise InputError(f"trips.decay must be one of {', '.join(d.value for d in DistanceDecay)}, "
                             f"got {self.decay!r}") from None
        require_positive(self, ("decay_length", "decay_power", "cutoff", "minor_speed", "major_speed",
                                "lane_capacity", "lane_width", "target_trips", "max_sources", "batch_sources"))
        for key in ("trips_per_resident", "turn_cost", "resident_change", "density",
                    "build_threshold", "sidewalk_width", "width_delay"):
            if not getattr(self, key) >= 0:
                raise InputError(f"trips.{key} must be ≥ 0, got {getattr(self, key)}")
        if not 0 <= self.sample_rate <= 1:
            raise InputError(f"trips.sample_rate is a share in [0, 1], got {self.sample_rate}")
        if not 1 <= self.min_lanes <= self.max_lanes or not 1 <= self.major_min_lanes <= self.max_lanes:
            raise InputError(f"trips: need 1 ≤ min_lanes, major_min_lanes ≤ max_lanes, got "
                             f"{self.min_lanes}, {self.major_min_lanes}, {self.max_lanes}")

    @property
    def limit(self) -> float:
        """Dijkstra's search radius, equivalent metres."""
        return self.cutoff * self.decay_length
