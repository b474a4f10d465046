"""Land use (seed 002 §4): types, valuation functions, lot attributes and the sampling update.

A *land-use type* is a goal share of the city's lot area plus a convex
combination of *valuation functions* (002 §4.3, Eq. 4), each one of five
mapping functions (step, linear up/down, gain up/down; Perlin & Hoffert's
``gain`` for the S-shaped ones) applied to one lot attribute between two
bounds. A lot's value ``luv`` under a type lies in [0, 1].

Lot attributes (002 §4.3), all vectorised over lots:

- ``cluster``: the share of the ``k`` (≈ 10) nearest other lots that have the
  type in question.
- ``influence`` of type *s*: the weighted share of lot area of type *s*
  within ``r`` (≈ 256 m). 002's Eq. 5–6 weight a neighbour by its distance
  times its area, which makes *far* lots count more, against its own text
  ("close lots are linearly weighted more"). We use the linear kernel the text
  describes: ``w(i, v) = area_v · (1 − d_iv / r)`` for ``0 < d_iv < r``, the lot
  itself excluded; ``influence_s(i) = Σ w [type_v = s] / Σ w`` (0 with no
  neighbour).
- ``center_dist``: the Euclidean distance to the nearest centre divided by
  the city's extent (002: "the longest distance in the urban configuration";
  here the diagonal of the lots' bounding box unless the caller gives one),
  clipped to [0, 1].
- ``water_dist``, ``green_dist`` (park/forest): distances in kilometres
  (``amenity_distance_unit``), clipped to [0, 1]; 1 when the town has no such
  feature. 002 divides these by the extent too, but being by the river is a
  matter of metres whatever the town's size: on a 15 km extract (north of
  Bayreuth) a quarter of the extent put every lot "by the water".
- ``traffic``: the summed traffic of a lot's adjacent streets (the caller's
  array) divided by its 95th percentile over the city's lots and clipped to
  [0, 1], so that bounds carry over between towns (002 uses raw volumes).
- ``slope`` (m/m, as given, Eq. 7) and ``elevation`` (rescaled to [0, 1]
  between the lowest and highest lot, Eq. 8), only when a height source
  exists; otherwise terms on them are dropped and each type's weights are
  renormalised over its remaining terms.

The *system value* (Eq. 1–3) is ``λ_g·luv_global + λ_l·luv_local`` with
``λ_g = λ_l = 0.5``; ``luv_local`` is the area-weighted mean lot value and

    luv_global = −(1/T) Σ_t ((share_t − goal_t) / scale)²,   scale ≈ 0.05,

with shares by lot area. 002's Eq. 2 has no ``1/T``: dividing by the number
of types makes ``luv_global`` the mean squared deviation in units of
``scale``, so that it lies in [−1, 0] exactly while every share is within
``scale`` of its goal — the same range as ``luv_local`` (a city whose shares
are off by one ``scale`` on average costs as much as a city where no lot suits
its type). Beyond that it stays unbounded below on purpose: its pull must not
fade far from the goals.

The *update* (002 §4.1, Table 3) samples ``m = sample_share · (assigned
lots)`` lots, tries a random *other* type for each and accepts by the
threshold rule: with ``Δ`` the change of the system value (new − old; Table
3 writes ``last − new``, which contradicts its own rule), the change is
always accepted when ``Δ > thresh``, else rejected with probability
``min(1, slope · (thresh − Δ))``. ``Δ`` is measured per unit of the changed
lot's area share (``Δ_system · A / area_i``), so the threshold and slope do
not depend on the city's size: a lot's own value changes by at most 1 on that
scale. ``Δ`` counts the lot's own value, the change it causes in its
neighbours' values (their ``influence`` and ``cluster``) and the global term.
No annealing: the same rule every year (002's dynamic disequilibrium).

For speed the proposals run in chunks of ``chunk_share`` of the lots: inside
a chunk every proposal's local change is computed against the state at the
chunk's start (vectorised), then the proposals are decided one after another
with the *global* term kept exact (shares are updated after each acceptance),
and the accepted changes are applied together. Proposals of one chunk do
not see each other's effect on their neighbourhoods (about ``chunk ×
neighbours / lots`` of them, ~4, lie within a proposal's 256 m). Measured on
2,000 synthetic lots over 10 years, 3 seeds: the mean lot value ends at 0.673
with 2 % chunks against 0.675 fully sequential (chunks of one), shares within
0.0014 of the goals either way, 9× faster.

New lots (type ``UNASSIGNED``) take the type that gives the highest system
value (002 §4.1), :func:`assign_types`; new blocks and quarters (no lots yet)
likewise, evaluated as one unit against the surrounding lots
(:func:`choose_types`): a block's type sets its lots' sizes and they inherit
it. Afterwards a block's type is the type of the largest share of its lots'
area (:func:`block_types`).
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import sparse
from scipy.spatial import cKDTree

from osm_expand.errors import HistoryError, InputError
from osm_expand.model.enums import parse_enum

__all__ = [
    "Attribute", "Valuation", "UNASSIGNED", "STATIC_ATTRIBUTES",
    "ValuationTerm", "LandUseType", "DEFAULT_TYPES", "LandUseOptions",
    "valuate", "types_from_config", "goal_shares",
    "distance_to", "lot_attributes", "LotLayout", "lot_layout",
    "lot_values", "area_shares", "SystemValue", "system_value",
    "LandUseUpdate", "acceptance_probability", "update_land_use", "assign_types", "choose_types", "block_types",
    "runs_this_year",
    "OSM_LANDUSE", "LandUseCalibration", "calibrate_landuse", "types_from_polygons",
    "rasterise_lots", "rasterise_polygons", "similarity",
]

#: The type index of a lot that has no land use yet.
UNASSIGNED = -1


class Valuation(StrEnum):
    """The five mapping functions of 002 §4.3 (figure 8)."""

    STEP = "step"
    LINEAR_UP = "linear_up"
    LINEAR_DOWN = "linear_down"
    GAIN_UP = "gain_up"
    GAIN_DOWN = "gain_down"


class Attribute(StrEnum):
    """Lot attributes a valuation function reads (002 §4.3)."""

    CLUSTER = "cluster"
    INFLUENCE = "influence"
    CENTER_DIST = "center_dist"
    WATER_DIST = "water_dist"
    GREEN_DIST = "green_dist"
    TRAFFIC = "traffic"
    SLOPE = "slope"
    ELEVATION = "elevation"


#: Column order of the static attribute matrix made by :func:`lot_attributes`.
STATIC_ATTRIBUTES: tuple[Attribute, ...] = (
    Attribute.CENTER_DIST, Attribute.WATER_DIST, Attribute.GREEN_DIST,
    Attribute.TRAFFIC, Attribute.SLOPE, Attribute.ELEVATION,
)
_CLUSTER_CODE = len(STATIC_ATTRIBUTES)
_INFLUENCE_CODE = _CLUSTER_CODE + 1  # + index of the influencing type


@dataclass(frozen=True)
class ValuationTerm:
    """One valuation function of a land-use type (002 §4.3, Eq. 4).

    ``kind`` maps ``attribute`` to [0, 1] between ``low`` and ``high``:
    ``step`` is 1 on ``low ≤ x ≤ high`` (use ±inf for a one-sided step),
    the ramps go from 0 at ``low`` to 1 at ``high`` (``_up``) or the reverse
    (``_down``). ``of_type`` names the influencing type for
    ``attribute = "influence"``. ``gain`` shapes the gain ramps (0.5: linear;
    above 0.5: an S-curve, flat at the bounds and steep in the middle).
    """

    weight: float
    kind: str
    attribute: str
    low: float
    high: float
    of_type: str = ""
    gain: float = 0.75


@dataclass(frozen=True)
class LandUseType:
    """A land-use type: its goal share of lot area and its valuation terms (002 §4).

    ``lot_size`` is the key the lot subdivision looks up (max area and min
    ratio per land use, 002 §5.1); empty means the type's own name.
    """

    name: str
    goal: float
    terms: tuple[ValuationTerm, ...]
    lot_size: str = ""

    @property
    def lot_size_key(self) -> str:
        return self.lot_size or self.name


_T = ValuationTerm
#: The bundled types. 002's own table of seven types is in its missing
#: supplement, so the weights and bounds are ours (centre distance a share of
#: the city's extent, water and green distances in km, traffic a share of the
#: 95th percentile):
#:
#: - low-density residential (40 %): near its own kind (cluster), away from
#:   industry, towards the edge (cheaper land, detached houses), on quiet
#:   streets, near green, not on steep or low land.
#: - high-density residential (20 %): clustered, near the centre and near
#:   shops, away from industry, on middling streets, near green.
#: - commercial (12 %): on busy streets (passing trade), near the centre, in
#:   clusters (shopping streets), near its customers (dense housing).
#: - industrial (13 %): on busy streets (freight), in estates (cluster), away
#:   from both residential kinds, at the edge, on flat land.
#: - park (15 %): by the water (riverside parks), next to forest and existing
#:   green (corridors), joined to other parks, on quiet streets, on slopes
#:   that are hard to build on.
DEFAULT_TYPES: tuple[LandUseType, ...] = (
    LandUseType("residential_low", 0.40, (
        _T(0.30, "linear_up", "cluster", 0.3, 0.9),
        _T(0.20, "linear_down", "influence", 0.0, 0.3, of_type="industrial"),
        _T(0.15, "linear_up", "center_dist", 0.05, 0.35),
        _T(0.15, "linear_down", "traffic", 0.2, 0.8),
        _T(0.10, "gain_down", "green_dist", 0.05, 0.5),
        _T(0.05, "linear_down", "slope", 0.15, 0.35),
        _T(0.05, "linear_up", "elevation", 0.2, 0.8),
    )),
    LandUseType("residential_high", 0.20, (
        _T(0.25, "linear_up", "cluster", 0.3, 0.9),
        _T(0.25, "linear_down", "center_dist", 0.05, 0.3),
        _T(0.15, "gain_up", "influence", 0.0, 0.3, of_type="commercial"),
        _T(0.15, "linear_down", "influence", 0.0, 0.3, of_type="industrial"),
        _T(0.10, "step", "traffic", 0.1, 0.9),
        _T(0.05, "linear_down", "green_dist", 0.05, 0.5),
        _T(0.05, "linear_down", "slope", 0.1, 0.3),
    )),
    LandUseType("commercial", 0.12, (
        _T(0.35, "linear_up", "traffic", 0.2, 0.9),
        _T(0.30, "gain_down", "center_dist", 0.0, 0.2),
        _T(0.20, "linear_up", "cluster", 0.2, 0.8),
        _T(0.15, "gain_up", "influence", 0.0, 0.4, of_type="residential_high"),
    )),
    LandUseType("industrial", 0.13, (
        _T(0.30, "linear_up", "traffic", 0.3, 1.0),
        _T(0.25, "linear_up", "cluster", 0.3, 0.9),
        _T(0.15, "linear_down", "influence", 0.1, 0.6, of_type="residential_low"),
        _T(0.10, "linear_down", "influence", 0.1, 0.6, of_type="residential_high"),
        _T(0.15, "linear_up", "center_dist", 0.1, 0.4),
        _T(0.05, "linear_down", "slope", 0.05, 0.2),
    )),
    LandUseType("park", 0.15, (
        _T(0.30, "gain_down", "water_dist", 0.0, 0.3),
        _T(0.25, "linear_down", "green_dist", 0.0, 0.3),
        _T(0.20, "linear_up", "cluster", 0.1, 0.6),
        _T(0.15, "linear_down", "traffic", 0.1, 0.6),
        _T(0.10, "linear_up", "slope", 0.1, 0.3),
    )),
)
del _T


@dataclass(frozen=True)
class LandUseOptions:
    #: Lots counted for ``cluster`` (002 §4.3: n ≈ 10).
    cluster_neighbours: int = 10
    #: Radius (m) of the neighbourhood for ``influence`` (002 §4.3: r ≈ 256 m).
    influence_radius: float = 256.0
    #: ``scale`` of the global goal term (002 Eq. 2: ≈ 0.05), a share of lot area.
    goal_scale: float = 0.05
    #: λ_global of Eq. 1 (002: 0.5).
    global_weight: float = 0.5
    #: λ_local of Eq. 1 (002: 0.5).
    local_weight: float = 0.5
    #: thresh_Δ of the acceptance rule (002 §4.1 gives no number), in lot-value
    #: units per unit of the lot's area share: 0 accepts every improvement and
    #: every neutral change.
    accept_threshold: float = 0.0
    #: A change ``x`` below the threshold is rejected with probability
    #: ``min(1, slope · x)``: 10 accepts a loss of 0.05 (a twentieth of the
    #: lot-value range) half the time and never one of 0.1 or more, so the city
    #: keeps moving without dissolving its clusters.
    reject_slope: float = 10.0
    #: Lots sampled per call as a share of the assigned lots (002 §4.1: 50 % per
    #: six months; the engine steps a year, hence 1.0 per yearly call).
    sample_share: float = 1.0
    #: Years between updates; 10 makes a centrally planned city (002 §4.1).
    update_interval: int = 1
    #: Proposals decided against one snapshot of the neighbourhoods, as a share
    #: of the lots (see the module docstring) ...
    chunk_share: float = 0.02
    #: ... and at least this many.
    min_chunk: int = 32
    #: Length (m) that water and green distances are divided by (then clipped to 1).
    amenity_distance_unit: float = 1000.0
    #: Traffic is divided by this quantile of the lots' traffic.
    traffic_quantile: float = 0.95
    #: Calibration: a residential polygon whose building footprints cover more
    #: than this share of it is high-density (a terrace/block city has 35–60 %
    #: ground coverage, detached houses 10–25 %).
    high_density_coverage: float = 0.30
    #: Calibration: the town's own shares replace the bundled goals fully when
    #: its mapped land use holds at least this share of its buildings, counted
    #: (of the town area without buildings); below, the goals blend in
    #: proportion. OSM maps industry and shops long before housing (Krems 2013:
    #: 58 % of the mapped land is industrial, only 13 % of its buildings lie in
    #: a mapped polygon), so only a nearly complete map may speak for the town.
    #: Buildings are counted, not weighed by footprint: the mapped industrial
    #: halls hold half of Krems' footprint area, which made its sparse map look
    #: half complete.
    min_calibration_coverage: float = 0.8

    def __post_init__(self) -> None:
        positive = ("influence_radius", "goal_scale", "chunk_share", "amenity_distance_unit",
                    "min_calibration_coverage")
        for key in positive:
            if not getattr(self, key) > 0:
                raise InputError(f"land_use {key}: must be positive, got {getattr(self, key)}")
        for key in ("cluster_neighbours", "global_weight", "local_weight", "reject_slope", "sample_share",
                    "min_chunk"):
            if not getattr(self, key) >= 0:
                raise InputError(f"land_use {key}: must be ≥ 0, got {getattr(self, key)}")
        if not 0 < self.traffic_quantile <= 1:
            raise InputError(f"land_use traffic_quantile: must lie in (0, 1], got {self.traffic_quantile}")


# --------------------------------------------------------------------------- valuation functions

def _gain(t: NDArray[np.float64], g: float) -> NDArray[np.float64]:
    """Perlin & Hoffert's gain (002 ref. [PH89]) of ``t`` in [0, 1]."""
    if g == 0.5:
        return t
    exponent = math.log(1.0 - g) / math.log(0.5)  # bias_b(x) = x ** (ln b / ln 0.5), b = 1 - g
    near = np.minimum(t, 1.0 - t)  # the curve is point-symmetric about (½, ½)
    half = 0.5 * (2.0 * near) ** exponent
    return np.where(t < 0.5, half, 1.0 - half)


#: Valuation kinds by value (StrEnum members hash as their values, so members find themselves).
_KINDS: dict[str, Valuation] = {v.value: v for v in Valuation}


def valuate(kind: str, x: NDArray[np.float64] | float, low: float, high: float, *,
            gain: float = 0.75) -> NDArray[np.float64]:
    """Map an attribute to [0, 1] with one of the five valuation functions (002 §4.3, fig. 8).

    Parameters
    ----------
    kind : {"step", "linear_up", "linear_down", "gain_up", "gain_down"}
        ``step``: 1 where ``low ≤ x ≤ high``, else 0. ``linear_up``:
        ``clip((x − low) / (high − low), 0, 1)``; ``linear_down``: 1 minus
        that. ``gain_up``/``gain_down``: the linear ramp passed through
        Perlin & Hoffert's gain, ``gain(g, t) = bias_{1−g}(2t)/2`` below
        ``t = ½`` and ``1 − bias_{1−g}(2 − 2t)/2`` above, with
        ``bias_b(t) = t^{ln b / ln ½}``: 0 and 1 at the bounds like the
        ramp, ½ at the midpoint, S-shaped for ``g > ½``.
    x : array_like, shape (L,)
        The attribute per lot (NaN maps to 0).
    low, high : float
        The bounds ``p_min``, ``p_max`` (``low < high`` for the ramps).
    gain : float
        ``g`` in (0, 1) for the gain ramps.

    Returns
    -------
    ndarray, shape (L,)
        Values in [0, 1].
    """
    # the land-use update calls this ~10⁵ times a run: a known kind skips the enum lookup
    kind = _KINDS.get(kind) or parse_enum(Valuation, kind, "valuation kind", error=HistoryError)
    x = np.asarray(x, dtype=np.float64)
    if kind is Valuation.STEP:
        out = ((x >= low) & (x <= high)).astype(np.float64)
        return out
    t = np.minimum(np.maximum((x - low) / (high - low), 0.0), 1.0)  # np.clip's dispatch is slow on small arrays
    t = np.where(np.isnan(t), 0.0, t)
    if kind in (Valuation.GAIN_UP, Valuation.GAIN_DOWN):
        t = _gain(np.atleast_1d(t), gain).reshape(t.shape)
    if kind in (Valuation.LINEAR_DOWN, Valuation.GAIN_DOWN):
        t = 1.0 - t
        t = np.where(np.isnan(x), 0.0, t)
    return t


# --------------------------------------------------------------------------- type definitions

def types_from_config(entries: Sequence[Mapping[str, Any]]) -> tuple[LandUseType, ...]:
    """Build land-use types from plain data (a TOML history's ``[[land_use]]`` tables).

    Parameters
    ----------
    entries : sequence of mappings
        Each with ``name`` (str), ``goal`` (float, share of lot area),
        optional ``lot_size`` (str) and ``terms``: a list of mappings with
        ``weight``, ``kind``, ``attribute``, ``low``, ``high`` and optional
        ``of_type`` and ``gain``.

    Returns
    -------
    tuple of LandUseType
        Validated (see :func:`goal_shares` and the term checks).

    Examples
    --------
    The TOML this reads (``tomllib.loads(text)["land_use"]``)::

        [[land_use]]
        name = "industrial"
        goal = 0.13
        lot_size = "large"

        [[land_use.terms]]
        weight = 0.6
        kind = "linear_up"
        attribute = "traffic"
        low = 0.3
        high = 1.0

        [[land_use.terms]]
        weight = 0.4
        kind = "linear_down"
        attribute = "influence"
        of_type = "residential_low"
        low = 0.1
        high = 0.6

    Raises
    ------
    InputError
        A missing key, an unknown kind or attribute, an influence naming an
        unknown type, negative weights or goals, ``low ≥ high`` on a ramp.
    """
    types = []
    for k, entry in enumerate(entries):
        where = f"land_use[{k}]"
        try:
            name = str(entry["name"])
            goal = float(entry["goal"])
            raw_terms = entry.get("terms", ())
            terms = tuple(ValuationTerm(
                weight=float(t["weight"]), kind=str(t["kind"]), attribute=str(t["attribute"]),
                low=float(t["low"]), high=float(t["high"]), of_type=str(t.get("of_type", "")),
                gain=float(t.get("gain", 0.75))) for t in raw_terms)
        except KeyError as missing:
            raise InputError(f"{where}: missing key {missing}") from None
        except (TypeError, ValueError) as bad:
            raise InputError(f"{where}: {bad}") from None
        types.append(LandUseType(name, goal, terms, str(entry.get("lot_size", ""))))
    result = tuple(types)
    _compile(result, available=(True,) * len(STATIC_ATTRIBUTES))
    return result


def goal_shares(types: Sequence[LandUseType]) -> NDArray[np.float64]:
    """The types' goals as shares summing to 1, shape (T,) (002 Eq. 2's ``goal_t``).

    Raises
    ------
    InputError
        A negative goal, or all goals zero.
    """
    goals = np.array([t.goal for t in types], dtype=np.float64)
    if np.any(goals < 0) or not np.isfinite(goals).all():
        raise InputError("land_use goal: goals must be finite and ≥ 0")
    total = goals.sum()
    if total <= 0:
        raise InputError("land_use goal: at least one goal must be positive")
    return goals / total


@dataclass(frozen=True)
class _Term:
    weight: float
    kind: str
    code: int  # static column, _CLUSTER_CODE, or _INFLUENCE_CODE + type index
    low: float
    high: float
    gain: float


@dataclass(frozen=True)
class _Compiled:
    names: tuple[str, ...]
    goals: NDArray[np.float64]
    terms: tuple[tuple[_Term, ...], ...]  # per type, weights renormalised to sum 1

    @property
    def n(self) -> int:
        return len(self.names)

    @cached_property
    def table(self) -> _TermTable:
        """All terms as arrays, for :func:`_values`."""
        flat = [(t, term) for t, terms in enumerate(self.terms) for term in terms]
        kinds = np.array([term.kind for _, term in flat], dtype=object)
        codes = np.array([term.code for _, term in flat], dtype=np.int64)
        owner = np.array([t for t, _ in flat], dtype=np.int64)
        n_static = len(STATIC_ATTRIBUTES)
        # columns of [static | cluster per type | influence per type]
        column = np.where(codes < _CLUSTER_CODE, codes,
                          np.where(codes == _CLUSTER_CODE, n_static + owner,
                                   n_static + self.n + codes - _INFLUENCE_CODE))
        gain = np.array([term.gain for _, term in flat], dtype=np.float64)
        with np.errstate(divide="ignore"):
            exponent = np.log(1.0 - gain) / np.log(0.5)
        term_weight = np.array([term.weight for _, term in flat], dtype=np.float64)
        weight = np.zeros((len(flat), self.n))
        weight[np.arange(len(flat)), owner] = term_weight
        # influence[r, t, s] / cluster[r, t]: the r-th term of type t on the influence of s / on cluster
        # (flat index, −1 for none); a type rarely has more than one, so r is almost always 0
        by_pair: dict[tuple[int, int], list[int]] = {}
        by_type: dict[int, list[int]] = {}
        for f, (t, term) in enumerate(flat):
            if term.code >= _INFLUENCE_CODE:
                by_pair.setdefault((t, term.code - _INFLUENCE_CODE), []).append(f)
            elif term.code == _CLUSTER_CODE:
                by_type.setdefault(t, []).append(f)
        influence = np.full((max([len(v) for v in by_pair.values()], default=0), self.n, self.n), -1, np.int64)
        for (t, src), fs in by_pair.items():
            influence[:len(fs), t, src] = fs
        cluster = np.full((max([len(v) for v in by_type.values()], default=0), self.n), -1, np.int64)
        for t, fs in by_type.items():
            cluster[:len(fs), t] = fs
        return _TermTable(
            column=column, low=np.array([term.low for _, term in flat], dtype=np.float64),
            high=np.array([term.high for _, term in flat], dtype=np.float64), exponent=exponent,
            step=kinds == Valuation.STEP.value,
            gain=(kinds == Valuation.GAIN_UP.value) | (kinds == Valuation.GAIN_DOWN.value),
            down=(kinds == Valuation.LINEAR_DOWN.value) | (kinds == Valuation.GAIN_DOWN.value),
            weight=weight, term_weight=term_weight, influence=influence, cluster=cluster)


@dataclass(frozen=True, eq=False)
class _TermTable:
    """Every term of every type as arrays (J,): its attribute column, bounds, gain exponent, kind flags;
    ``weight`` (J, T) puts each term's weight on its type's column."""

    column: NDArray[np.int64]
    low: NDArray[np.float64]
    high: NDArray[np.float64]
    exponent: NDArray[np.float64]
    step: NDArray[np.bool_]
    gain: NDArray[np.bool_]
    down: NDArray[np.bool_]
    weight: NDArray[np.float64]
    term_weight: NDArray[np.float64]  #: (J,)
    influence: NDArray[np.int64]  #: (R, T, T) flat index of the r-th term of type t on the influence of s, or −1
    cluster: NDArray[np.int64]  #: (R, T) flat index of the r-th cluster term of type t, or −1

    def valuate(self, x: NDArray[np.float64], term: NDArray[np.int64] | slice) -> NDArray[np.float64]:
        """:func:`valuate` of ``x`` under terms ``term`` (broadcast against ``x``'s last axis)."""
        low, high, exponent = self.low[term], self.high[term], self.exponent[term]
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.minimum(np.maximum((x - low) / (high - low), 0.0), 1.0)
            t = np.where(np.isnan(t), 0.0, t)
            half = 0.5 * (2.0 * np.minimum(t, 1.0 - t)) ** exponent
        t = np.where(self.gain[term], np.where(t < 0.5, half, 1.0 - half), t)
        t = np.where(self.down[term], np.where(np.isnan(x), 0.0, 1.0 - t), t)
        return np.where(self.step[term], ((x >= low) & (x <= high)).astype(np.float64), t)


def _compile(types: Sequence[LandUseType], available: Sequence[bool]) -> _Compiled:
    if len(types) == 0:
        raise InputError("land_use: at least one type is needed")
    names = tuple(t.name for t in types)
    if len(set(names)) != len(names):
        raise InputError(f"land_use name: duplicate type names in {names}")
    index = {n: i for i, n in enumerate(names)}
    static = {a: i for i, a in enumerate(STATIC_ATTRIBUTES)}
    compiled = []
    for t in types:
        terms = []
        for j, term in enumerate(t.terms):
            where = f"land_use {t.name!r} term {j}"
            kind = parse_enum(Valuation, term.kind, f"{where} kind", error=HistoryError)
            attribute = parse_enum(Attribute, term.attribute, f"{where} attribute", error=HistoryError)
            if not (term.weight >= 0 and np.isfinite(term.weight)):
                raise InputError(f"{where} weight: must be finite and ≥ 0, got {term.weight}")
            if kind is not Valuation.STEP and not term.low < term.high:
                raise InputError(f"{where}: low must be below high, got {term.low} and {term.high}")
            if kind is Valuation.STEP and not term.low <= term.high:
                raise InputError(f"{where}: low must not exceed high, got {term.low} and {term.high}")
            if not 0.0 < term.gain < 1.0:
                raise InputError(f"{where} gain: must lie in (0, 1), got {term.gain}")
            if attribute is Attribute.INFLUENCE:
                if term.of_type not in index:
                    raise InputError(f"{where} of_type: {term.of_type!r} is not one of {', '.join(names)}")
                code = _INFLUENCE_CODE + index[term.of_type]
            elif attribute is Attribute.CLUSTER:
                code = _CLUSTER_CODE
            else:
                code = static[attribute]
                if not available[code]:
                    continue  # no height source: slope/elevation terms drop out
            terms.append(_Term(term.weight, kind.value, code, term.low, term.high, term.gain))
        total = sum(x.weight for x in terms)
        if terms and total <= 0:
            raise InputError(f"land_use {t.name!r}: the term weights sum to zero")
        compiled.append(tuple(_Term(x.weight / total, x.kind, x.code, x.low, x.high, x.gain)
                              for x in terms))
    return _Compiled(names, goal_shares(types), tuple(compiled))


# --------------------------------------------------------------------------- lot attributes

def distance_to(xy: NDArray[np.float64], geometries: Sequence[Any]) -> NDArray[np.float64]:
    """Distance (m) from each point to the nearest of some shapely geometries.

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Points in metres.
    geometries : sequence of shapely geometries
        Water, park or forest areas and lines (metres).

    Returns
    -------
    ndarray, shape (L,)
        0 inside an area; ``inf`` for every point when there are no geometries.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    geoms = [g for g in geometries if g is not None and not shapely.is_empty(g)]
    if not geoms or len(xy) == 0:
        return np.full(len(xy), np.inf)
    tree = shapely.STRtree(geoms)
    points = shapely.points(xy)
    (pi, _gi), dist = tree.query_nearest(points, return_distance=True, all_matches=False)
    out = np.full(len(xy), np.inf)
    out[pi] = dist
    return out


def lot_attributes(xy: NDArray[np.float64], *, centres: NDArray[np.float64],
                   extent: float | None = None,
                   water: Sequence[Any] = (), green: Sequence[Any] = (),
                   water_distance: NDArray[np.float64] | None = None,
                   green_distance: NDArray[np.float64] | None = None,
                   traffic: NDArray[np.float64] | None = None,
                   slope: NDArray[np.float64] | None = None,
                   elevation: NDArray[np.float64] | None = None,
                   options: LandUseOptions = LandUseOptions()) -> NDArray[np.float64]:
    """The static lot attributes of 002 §4.3 as one matrix (columns :data:`STATIC_ATTRIBUTES`).

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Lot centroids (m).
    centres : ndarray, shape (C, 2)
        The city centre(s) (m); ``center_dist`` is to the nearest.
    extent : float, optional
        The length (m) the centre distance is divided by; default the
        diagonal of the lots' bounding box (002: "the longest distance in the
        urban configuration").
    water, green : sequence of shapely geometries
        Water, and park/forest areas; ignored when the matching
        ``*_distance`` array (m, shape (L,)) is given.
    traffic : ndarray, shape (L,), optional
        Summed traffic of each lot's adjacent streets (002 §4.3); divided by
        its ``traffic_quantile`` over the lots and clipped to 1. None: 0.
    slope : ndarray, shape (L,), optional
        Mean terrain gradient magnitude in the lot (m/m, Eq. 7), kept as is.
    elevation : ndarray, shape (L,), optional
        Mean terrain height in the lot (m, Eq. 8), rescaled to [0, 1]
        between the lowest and the highest lot.

    Returns
    -------
    ndarray, shape (L, 6)
        ``center_dist, water_dist, green_dist, traffic, slope, elevation``;
        the last two columns are NaN without a height source.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = len(xy)
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    if len(centres) == 0:
        raise InputError("land use: at least one city centre is needed")
    if extent is None:
        span = xy.max(axis=0) - xy.min(axis=0) if n else np.zeros(2)
        extent = float(np.hypot(*span))
    extent = max(float(extent), 1.0)
    out = np.full((n, len(STATIC_ATTRIBUTES)), np.nan)
    if n == 0:
        return out
    out[:, 0] = cKDTree(centres).query(xy)[0] / extent
    wd = distance_to(xy, water) if water_distance is None else np.asarray(water_distance, float)
    gd = distance_to(xy, green) if green_distance is None else np.asarray(green_distance, float)
    out[:, 1] = np.minimum(wd / options.amenity_distance_unit, 1.0)
    out[:, 2] = np.minimum(gd / options.amenity_distance_unit, 1.0)
    out[:, 0] = np.minimum(out[:, 0], 1.0)
    if traffic is None:
        out[:, 3] = 0.0
    else:
        tr = np.maximum(np.asarray(traffic, dtype=np.float64), 0.0)
        ref = np.quantile(tr, options.traffic_quantile) if n else 0.0
        ref = ref if ref > 0 else (tr.max() if n and tr.max() > 0 else 1.0)
        out[:, 3] = np.minimum(tr / ref, 1.0)
    if slope is not None:
        out[:, 4] = np.asarray(slope, dtype=np.float64)
    if elevation is not None:
        h = np.asarray(elevation, dtype=np.float64)
        lo, hi = np.nanmin(h), np.nanmax(h)
        out[:, 5] = (h - lo) / (hi - lo) if hi > lo else 0.0
    return out


# --------------------------------------------------------------------------- the lot layout

@dataclass(frozen=True)
class LotLayout:
    """The lots of one year with their spatial neighbourhoods (rebuild when lots change).

    ``knn`` (L, k) are each lot's ``k`` nearest other lots (cluster);
    ``weights`` is the sparse (L, L) influence kernel, row ``v`` holding
    ``w(v, u) = area_u · (1 − d/r)``, and ``weights_by_source`` its transpose;
    ``reverse_knn`` (CSR: ``indptr``, ``indices``) lists, per lot ``u``, the
    lots that count ``u`` among their ``k`` nearest.
    """

    xy: NDArray[np.float64]
    area: NDArray[np.float64]
    attributes: NDArray[np.float64]
    knn: NDArray[np.int64]
    weights: sparse.csr_matrix
    weights_by_source: sparse.csr_matrix
    weight_sums: NDArray[np.float64]
    reverse_knn_indptr: NDArray[np.int64]
    reverse_knn_indices: NDArray[np.int64]
    tree: cKDTree = field(repr=False)

    @property
    def n(self) -> int:
        return len(self.area)

    @property
    def available(self) -> tuple[bool, ...]:
        """Which static attribute columns have data (slope/elevation need a height source)."""
        if self.n == 0:
            return (True,) * 4 + (False, False)
        return tuple(bool(np.isfinite(self.attributes[:, j]).any()) for j in range(self.attributes.shape[1]))


def _kernel(d: NDArray[np.float64], area_u: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    return area_u * np.clip(1.0 - d / radius, 0.0, None)


def lot_layout(xy: NDArray[np.float64], area: NDArray[np.float64],
               attributes: NDArray[np.float64], *,
               options: LandUseOptions = LandUseOptions()) -> LotLayout:
    """Index the lots for the cluster and influence attributes (cKDTree, sparse kernel).

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Lot centroids (m).
    area : ndarray, shape (L,)
        Lot areas (m²), > 0.
    attributes : ndarray, shape (L, 6)
        From :func:`lot_attributes`.

    Returns
    -------
    LotLayout
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    area = np.asarray(area, dtype=np.float64)
    attributes = np.asarray(attributes, dtype=np.float64)
    n = len(xy)
    if area.shape != (n,) or attributes.shape != (n, len(STATIC_ATTRIBUTES)):
        raise InputError(f"land use: {n} lots need ({n},) areas and ({n}, 6) attributes, "
                         f"got {area.shape} and {attributes.shape}")
    if n and not (area > 0).all():
        raise InputError("land use: lot areas must be positive")
    tree = cKDTree(xy)
    k = min(options.cluster_neighbours, max(n - 1, 0))
    if k > 0:
        _, idx = tree.query(xy, k=k + 1)
        idx = idx.reshape(n, k + 1)
        self_hit = idx == np.arange(n)[:, None]
        # drop the lot itself, or the farthest when a duplicate point hid it
        drop = np.where(self_hit.any(axis=1), self_hit.argmax(axis=1), k)
        keep = np.ones_like(idx, dtype=bool)
        keep[np.arange(n), drop] = False
        knn = idx[keep].reshape(n, k).astype(np.int64)
    else:
        knn = np.zeros((n, 0), dtype=np.int64)
    r = options.influence_radius
    pairs = tree.query_pairs(r, output_type="ndarray") if n > 1 else np.zeros((0, 2), np.int64)
    d = np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T) if len(pairs) else np.zeros(0)
    kernel = np.clip(1.0 - d / r, 0.0, None)
    # the distance kernel is symmetric: one CSR serves both directions, scaled by
    # the neighbour's area (rows of ``weights``) or the row lot's own area (``by_source``)
    sym = sparse.coo_matrix((np.concatenate([kernel, kernel]),
                             (np.concatenate([pairs[:, 0], pairs[:, 1]]),
                              np.concatenate([pairs[:, 1], pairs[:, 0]]))), shape=(n, n)).tocsr()
    row_of = np.repeat(np.arange(n), np.diff(sym.indptr))
    weights = sparse.csr_matrix((sym.data * area[sym.indices], sym.indices, sym.indptr), shape=(n, n))
    by_source = sparse.csr_matrix((sym.data * area[row_of], sym.indices, sym.indptr), shape=(n, n))
    rows = knn.ravel()
    order = np.argsort(rows, kind="stable")
    rk_indices = np.repeat(np.arange(n, dtype=np.int64), k)[order]
    rk_indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=rk_indptr[1:])
    return LotLayout(xy=xy, area=area, attributes=attributes, knn=knn, weights=weights,
                     weights_by_source=by_source, weight_sums=np.asarray(weights.sum(axis=1)).ravel(),
                     reverse_knn_indptr=rk_indptr, reverse_knn_indices=rk_indices, tree=tree)


def _ragged(indptr: NDArray[np.int64], rows: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """For CSR ``indptr`` and some rows: (which of ``rows`` each entry belongs to, entry positions)."""
    starts = indptr[rows]
    counts = indptr[rows + 1] - starts
    owner = np.repeat(np.arange(len(rows)), counts)
    offsets = np.cumsum(counts) - counts
    pos = np.repeat(starts - offsets, counts) + np.arange(counts.sum())
    return owner, pos


def _type_counts(layout: LotLayout, lut: NDArray[np.int64], n_types: int
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per lot: how many of its k nearest lots have each type; kernel weight of each type nearby."""
    n = layout.n
    onehot = np.zeros((n, n_types))
    assigned = lut >= 0
    onehot[np.flatnonzero(assigned), lut[assigned]] = 1.0
    counts = onehot[layout.knn].sum(axis=1) if layout.knn.shape[1] else np.zeros((n, n_types))
    sums = layout.weights @ onehot
    return counts, np.asarray(sums)


def _values(ct: _Compiled, static: NDArray[np.float64], counts: NDArray[np.float64],
            sums: NDArray[np.float64], wsum: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """Every row's value under every type, (N, T): :func:`valuate` of all terms at once (the update
    calls this for the neighbours of every accepted change)."""
    tab = ct.table
    n = len(static)
    cluster = counts / k if k else np.zeros((n, ct.n))
    influence = np.divide(sums, wsum[:, None], out=np.zeros((n, ct.n)), where=wsum[:, None] > 0)
    x = np.hstack([static, cluster, influence])[:, tab.column]  # (N, J)
    return tab.valuate(x, slice(None)) @ tab.weight


def _check_lut(layout: LotLayout, lut: NDArray[np.int64], n_types: int) -> NDArray[np.int64]:
    lut = np.asarray(lut, dtype=np.int64)
    if lut.shape != (layout.n,):
        raise InputError(f"land use: {layout.n} lots need ({layout.n},) types, got {lut.shape}")
    if layout.n and (lut.max(initial=-1) >= n_types or lut.min(initial=0) < UNASSIGNED):
        raise InputError(f"land use: lot types must lie in -1..{n_types - 1}")
    return lut


def lot_values(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
               options: LandUseOptions = LandUseOptions()) -> NDArray[np.float64]:
    """Every lot's value ``luv`` under every type, given its neighbours' types (002 Eq. 4).

    Parameters
    ----------
    layout : LotLayout
    lut : ndarray of int, shape (L,)
        Current type per lot (index into ``types``; ``UNASSIGNED`` = −1 lots
        count for no type).

    Returns
    -------
    ndarray, shape (L, T)
        Values in [0, 1]; ``values[i, lut[i]]`` is the lot's current ``luv``.
    """
    ct = _compile(types, layout.available)
    lut = _check_lut(layout, lut, ct.n)
    counts, sums = _type_counts(layout, lut, ct.n)
    return _values(ct, layout.attributes, counts, sums, layout.weight_sums, layout.knn.shape[1])


def area_shares(area: NDArray[np.float64], lut: NDArray[np.int64], n_types: int) -> NDArray[np.float64]:
    """Share of the assigned lot area per type (002 Eq. 3), shape (T,); zeros with none assigned."""
    lut = np.asarray(lut)
    assigned = lut >= 0
    per = np.asarray(np.bincount(lut[assigned], weights=np.asarray(area)[assigned], minlength=n_types),
                     dtype=np.float64)
    total = per.sum()
    return per / total if total > 0 else per


@dataclass(frozen=True)
class SystemValue:
    """The system value of Eq. 1 and its parts; ``shares`` (T,) by area."""

    value: float
    global_value: float
    local_value: float
    shares: NDArray[np.float64]


def _global(shares: NDArray[np.float64], goals: NDArray[np.float64], scale: float) -> float:
    return -float(np.mean(((shares - goals) / scale) ** 2))


def system_value(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
                 options: LandUseOptions = LandUseOptions()) -> SystemValue:
    """The system value ``λ_g·luv_global + λ_l·luv_local`` (002 Eq. 1–3, normalised as in the module doc).

    Parameters
    ----------
    layout : LotLayout
    lut : ndarray of int, shape (L,)

    Returns
    -------
    SystemValue
        ``local_value`` is the area-weighted mean ``luv`` of the assigned lots;
        ``global_value = −mean_t((share_t − goal_t)/scale)²``.
    """
    ct = _compile(types, layout.available)
    lut = _check_lut(layout, lut, ct.n)
    values = lot_values(layout, lut, types=types, options=options)
    shares = area_shares(layout.area, lut, ct.n)
    assigned = np.flatnonzero(lut >= 0)
    a = layout.area[assigned]
    local = float((a * values[assigned, lut[assigned]]).sum() / a.sum()) if len(assigned) else 0.0
    glob = _global(shares, ct.goals, options.goal_scale)
    return SystemValue(options.global_weight * glob + options.local_weight * local, glob, local, shares)


# --------------------------------------------------------------------------- the update

@dataclass(frozen=True)
class LandUseUpdate:
    """The result of one update: new types (L,), counts, shares (T,) and each lot's ``luv`` (L,)."""

    lut: NDArray[np.int64]
    proposed: int
    accepted: int
    shares: NDArray[np.float64]
    luv: NDArray[np.float64]


class _State:
    """Mutable working copy of the lots' types with their neighbour tallies and values."""

    def __init__(self, layout: LotLayout, lut: NDArray[np.int64], ct: _Compiled) -> None:
        self.layout, self.ct = layout, ct
        self.lut = lut.copy()
        self.k = layout.knn.shape[1]
        self.counts, self.sums = _type_counts(layout, self.lut, ct.n)
        #: (type, influencing type, term) of every influence term; listens[t, s]: t has one on s
        self.influence_terms = [(t, term.code - _INFLUENCE_CODE, term) for t, terms in enumerate(ct.terms)
                                for term in terms if term.code >= _INFLUENCE_CODE]
        self.listens = np.zeros((ct.n, ct.n), dtype=bool)
        for t, s_, _ in self.influence_terms:
            self.listens[t, s_] = True
        self.refresh()

    def refresh(self, rows: NDArray[np.int64] | None = None) -> None:
        """Recompute the lots' values under every type (all lots, or only ``rows``)."""
        lay = self.layout
        if rows is None:
            self.values = _values(self.ct, lay.attributes, self.counts, self.sums, lay.weight_sums, self.k)
        elif len(rows):
            self.values[rows] = _values(self.ct, lay.attributes[rows], self.counts[rows], self.sums[rows],
                                        lay.weight_sums[rows], self.k)

    def externalities(self, lots: NDArray[np.int64], old: NDArray[np.int64],
                      new: NDArray[np.int64]) -> NDArray[np.float64]:
        """Σ_v area_v Δluv_v over the neighbours v whose attributes change when lots go old → new."""
        lay, ct, lut = self.layout, self.ct, self.lut
        total = np.zeros(len(lots))
        # influence: v's kernel sums of old and new type shift by w(v, i); only
        # neighbours whose type has a term on the influence of either count
        wt = lay.weights_by_source
        owner, pos = _ragged(wt.indptr, lots)
        v = wt.indices[pos]
        tv = lut[v]
        a, b = old[owner], new[owner]
        tvc = np.maximum(tv, 0)
        keep = (tv >= 0) & (self.listens[tvc, a] | self.listens[tvc, b])
        owner, v, a, b, w = owner[keep], v[keep], a[keep], b[keep], wt.data[pos][keep]
        tab = ct.table
        if len(v):
            tv = tv[keep]
            ws = lay.weight_sums[v]
            ws = np.where(ws > 0, ws, 1.0)
            dw = w / ws
            delta = np.zeros(len(v))
            for src, sign in ((a, -1.0), (b, 1.0)):  # v's share of src falls (the old type) or rises (the new)
                x0 = self.sums[v, np.maximum(src, 0)] / ws
                for layer in tab.influence:
                    j = np.where(src >= 0, layer[tv, np.maximum(src, 0)], -1)  # an unassigned lot held no share
                    m = np.flatnonzero(j >= 0)
                    if len(m):
                        jm = j[m]
                        delta[m] += tab.term_weight[jm] * (tab.valuate(x0[m] + sign * dw[m], jm)
                                                           - tab.valuate(x0[m], jm))
            total += np.bincount(owner, weights=lay.area[v] * delta, minlength=len(lots))
        # cluster: v's count of its own type moves by ±1 when i is among its k nearest
        if self.k:
            owner, pos = _ragged(lay.reverse_knn_indptr, lots)
            v = lay.reverse_knn_indices[pos]
            tv = lut[v]
            step = ((tv == new[owner]).astype(float) - (tv == old[owner])) / self.k
            keep = (tv >= 0) & (step != 0)
            owner, v, tv, step = owner[keep], v[keep], tv[keep], step[keep]
            if len(v):
                c0 = self.counts[v, tv] / self.k
                delta = np.zeros(len(v))
                for layer in tab.cluster:
                    j = layer[tv]
                    m = np.flatnonzero(j >= 0)
                    if len(m):
                        jm = j[m]
                        delta[m] += tab.term_weight[jm] * (tab.valuate(c0[m] + step[m], jm) - tab.valuate(c0[m], jm))
                total += np.bincount(owner, weights=lay.area[v] * delta, minlength=len(lots))
        return total

    def apply(self, lots: NDArray[np.int64], new: NDArray[np.int64]) -> None:
        lay, n_t = self.layout, self.ct.n
        old = self.lut[lots]
        wt = lay.weights_by_source
        owner, pos = _ragged(wt.indptr, lots)
        v, w = wt.indices[pos], wt.data[pos]
        flat = self.sums.reshape(-1)
        was = old[owner] >= 0
        flat -= np.bincount(v[was] * n_t + old[owner][was], weights=w[was], minlength=flat.size)
        flat += np.bincount(v * n_t + new[owner], weights=w, minlength=flat.size)
        touched = [lots, v]
        if self.k:
            owner, pos = _ragged(lay.reverse_knn_indptr, lots)
            v = lay.reverse_knn_indices[pos]
            cflat = self.counts.reshape(-1)
            was = old[owner] >= 0
            cflat -= np.bincount(v[was] * n_t + old[owner][was], minlength=cflat.size)
            cflat += np.bincount(v * n_t + new[owner], minlength=cflat.size)
            touched.append(v)
        self.lut[lots] = new
        rows = np.unique(np.concatenate(touched))
        self.refresh(rows if len(rows) < lay.n // 2 else None)


def _chunks(order: NDArray[np.int64], size: int) -> Iterable[NDArray[np.int64]]:
    for start in range(0, len(order), size):
        yield order[start:start + size]


def _chunk_size(n: int, options: LandUseOptions) -> int:
    return max(options.min_chunk, int(np.ceil(options.chunk_share * n)), 1)


def update_land_use(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
                    rng: np.random.Generator, sample_share: float | None = None,
                    allowed: NDArray[np.bool_] | None = None,
                    options: LandUseOptions = LandUseOptions()) -> LandUseUpdate:
    """One land-use update (002 §4.1, Table 3): sample lots, try a random other type, accept by threshold.

    Parameters
    ----------
    layout : LotLayout
        The current lots (:func:`lot_layout`).
    lut : ndarray of int, shape (L,)
        Current type per lot; ``UNASSIGNED`` lots are left alone (give them a
        type with :func:`assign_types` first).
    types : sequence of LandUseType
    rng : numpy.random.Generator
        All randomness (lot sample, proposed types, acceptance draws).
    sample_share : float, optional
        ``m`` as a share of the assigned lots (default ``options.sample_share``);
        each lot is sampled at most once per pass over the lots.
    allowed : ndarray of bool, shape (L, T), optional
        Which types each lot may take (a lot whose area lies outside a lot
        class's bounds cannot take that class's types); a proposal of a type
        not allowed is dropped before it is valued (it counts as neither
        proposed nor accepted). The random draws are the same with or
        without it. None: every type.

    Returns
    -------
    LandUseUpdate
        The new types (a copy), how many changes were proposed and accepted,
        the area shares and each lot's ``luv`` after the update.

    Notes
    -----
    Acceptance (Table 3, §4.1): ``Δ`` = system value after − before, per unit
    of the lot's area share; accept when ``Δ > accept_threshold``, otherwise
    reject with probability ``min(1, reject_slope · (accept_threshold − Δ))``.
    """
    ct = _compile(types, layout.available)
    lut = _check_lut(layout, lut, ct.n)
    share = options.sample_share if sample_share is None else float(sample_share)
    if share < 0 or not np.isfinite(share):
        raise InputError(f"land_use sample_share: must be ≥ 0, got {share}")
    if allowed is not None:
        allowed = np.asarray(allowed, dtype=bool)
        if allowed.shape != (layout.n, ct.n):
            raise InputError(f"land use: allowed types must have shape ({layout.n}, {ct.n}), got {allowed.shape}")
    state = _State(layout, lut, ct)
    assigned = np.flatnonzero(lut >= 0)
    m = int(round(share * len(assigned)))
    proposed = accepted = 0
    if ct.n > 1 and m > 0:
        total_area = float(layout.area[assigned].sum())
        excess = list(area_shares(layout.area, lut, ct.n) - ct.goals)
        coef = 2.0 / (ct.n * options.goal_scale ** 2)
        size = _chunk_size(layout.n, options)
        n_passes = -(-m // len(assigned))
        order_all = np.concatenate([rng.permutation(assigned) for _ in range(n_passes)])[:m]
        for p in range(n_passes):  # a lot is sampled at most once per pass, hence once per chunk
            order = order_all[p * len(assigned):(p + 1) * len(assigned)]
            for lots in _chunks(order, size):
                old = state.lut[lots]
                new = (old + rng.integers(1, ct.n, size=len(lots))) % ct.n
                u = rng.random(len(lots))
                if allowed is not None:
                    ok = allowed[lots, new]
                    lots, old, new, u = lots[ok], old[ok], new[ok], u[ok]
                    if not len(lots):
                        continue
                own = state.values[lots, new] - state.values[lots, old]
                local = own + state.externalities(lots, old, new) / layout.area[lots]
                take = _decide(lots, old, new, local, u, excess, layout.area, total_area, coef, options)
                proposed += len(lots)
                accepted += len(take)
                if len(take):
                    state.apply(lots[take], new[take])
    luv = np.where(state.lut >= 0, state.values[np.arange(layout.n), np.maximum(state.lut, 0)], 0.0)
    return LandUseUpdate(state.lut, proposed, accepted, area_shares(layout.area, state.lut, ct.n), luv)


def acceptance_probability(delta: NDArray[np.float64] | float, *,
                           options: LandUseOptions = LandUseOptions()) -> NDArray[np.float64]:
    """Probability of keeping a proposed change (002 §4.1, Table 3's ``accept``).

    Parameters
    ----------
    delta : array_like
        Change of the system value, new − old, per unit of the changed lot's
        area share (see the module docstring).

    Returns
    -------
    ndarray
        1 where ``delta > accept_threshold``; otherwise
        ``max(0, 1 − reject_slope · (accept_threshold − delta))``: the
        rejection probability grows in proportion to the shortfall.
    """
    d = np.asarray(delta, dtype=np.float64)
    thresh = options.accept_threshold
    return np.where(d > thresh, 1.0, np.clip(1.0 - options.reject_slope * (thresh - d), 0.0, 1.0))


def _decide(lots: NDArray[np.int64], old: NDArray[np.int64], new: NDArray[np.int64],
            local: NDArray[np.float64], u: NDArray[np.float64], excess: list[float],
            area: NDArray[np.float64], total_area: float, coef: float,
            options: LandUseOptions) -> NDArray[np.int64]:
    """Table 3's sequential accept/reject with the global term kept exact; mutates ``excess``."""
    thresh, slope = options.accept_threshold, options.reject_slope
    lg, ll = options.global_weight, options.local_weight
    share = (area[lots] / total_area).tolist()
    olds, news, locs, draws = old.tolist(), new.tolist(), local.tolist(), u.tolist()
    take = []
    for q in range(len(olds)):
        a, b, d = olds[q], news[q], share[q]
        # d(luv_global)/d(share moved a → b) per unit share: −(2/(T·scale²))·(e_b − e_a + d)
        delta = lg * -coef * (excess[b] - excess[a] + d) + ll * locs[q]
        if delta > thresh or draws[q] >= slope * (thresh - delta):  # = u < acceptance_probability
            excess[a] -= d
            excess[b] += d
            take.append(q)
    return np.asarray(take, dtype=np.int64)


def assign_types(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
                 rng: np.random.Generator,
                 options: LandUseOptions = LandUseOptions()) -> NDArray[np.int64]:
    """Give every ``UNASSIGNED`` lot the type that raises the system value most (002 §4.1).

    New lots are visited in random order, in chunks; each takes
    ``argmax_t λ_l·luv_t(i) − λ_g·(2/(T·scale²))·(share_t − goal_t)`` (its own
    value plus the marginal global term of adding its area to type ``t``),
    shares updated after every lot, neighbour tallies after every chunk.

    Parameters
    ----------
    layout : LotLayout
    lut : ndarray of int, shape (L,)
    types : sequence of LandUseType
    rng : numpy.random.Generator
        Orders the new lots.

    Returns
    -------
    ndarray of int, shape (L,)
        A copy of ``lut`` with no ``UNASSIGNED`` left (unchanged where assigned).
    """
    ct = _compile(types, layout.available)
    lut = _check_lut(layout, lut, ct.n)
    state = _State(layout, lut, ct)
    new_lots = rng.permutation(np.flatnonzero(lut < 0))
    if len(new_lots) == 0:
        return state.lut
    per = np.asarray(np.bincount(lut[lut >= 0], weights=layout.area[lut >= 0], minlength=ct.n), dtype=np.float64)
    for lots in _chunks(new_lots, _chunk_size(layout.n, options)):
        state.apply(lots, _greedy(state.values[lots], layout.area[lots], per, ct, options))
    return state.lut


def choose_types(layout: LotLayout, lut: NDArray[np.int64], xy: NDArray[np.float64],
                 area: NDArray[np.float64], attributes: NDArray[np.float64], *,
                 types: Sequence[LandUseType],
                 options: LandUseOptions = LandUseOptions()) -> NDArray[np.int64]:
    """The best type for new blocks or quarters that have no lots yet (002 §2.2, §4.1).

    Each unit is valued like a lot against the current lots (its ``k``
    nearest lots, the lots within ``r``), with the marginal global term of
    adding its area; units are decided in the given order, each adding its
    area to the shares the next one sees (their neighbourhoods do not see one
    another).

    Parameters
    ----------
    layout : LotLayout
        The existing lots.
    lut : ndarray of int, shape (L,)
    xy : ndarray, shape (U, 2)
        Unit centroids (m).
    area : ndarray, shape (U,)
        Unit areas (m²).
    attributes : ndarray, shape (U, 6)
        From :func:`lot_attributes` (use the same ``extent`` as the lots).

    Returns
    -------
    ndarray of int, shape (U,)
        A type index per unit (the lot sizes of its subdivision follow it).
    """
    ct = _compile(types, layout.available)
    lut = _check_lut(layout, lut, ct.n)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    u = len(xy)
    if u == 0:
        return np.zeros(0, dtype=np.int64)
    onehot = np.zeros((layout.n, ct.n))
    ok = lut >= 0
    onehot[np.flatnonzero(ok), lut[ok]] = 1.0
    k = min(options.cluster_neighbours, layout.n)
    counts = np.zeros((u, ct.n))
    if k:
        _, idx = layout.tree.query(xy, k=k)
        counts = onehot[np.asarray(idx).reshape(u, k)].sum(axis=1)
    r = options.influence_radius
    near = layout.tree.query_ball_point(xy, r)
    owner = np.repeat(np.arange(u), [len(x) for x in near])
    other = np.fromiter((j for x in near for j in x), dtype=np.int64, count=len(owner))
    d = np.hypot(*(xy[owner] - layout.xy[other]).T) if len(other) else np.zeros(0)
    w = _kernel(d, layout.area[other], r)
    sums = np.zeros((u, ct.n))
    if len(other):
        np.add.at(sums, owner, w[:, None] * onehot[other])
    wsum = np.asarray(np.bincount(owner, weights=w, minlength=u), dtype=np.float64)
    values = _values(ct, np.asarray(attributes, dtype=np.float64).reshape(u, -1), counts, sums, wsum, k)
    per = np.asarray(np.bincount(lut[ok], weights=layout.area[ok], minlength=ct.n), dtype=np.float64)
    return _greedy(values, np.asarray(area, dtype=np.float64).reshape(u), per, ct, options)


def _greedy(values: NDArray[np.float64], area: NDArray[np.float64], per: NDArray[np.float64],
            ct: _Compiled, options: LandUseOptions) -> NDArray[np.int64]:
    """Units in order each take ``argmax_t λ_l·value_t − λ_g·(2/(T·scale²))·(share_t − goal_t)``.

    ``per`` (T,) is the area per type so far; it grows by each unit's area
    (mutated), so a batch of new units does not all rush to one short type.
    """
    coef = 2.0 / (ct.n * options.goal_scale ** 2)
    chosen = np.empty(len(values), dtype=np.int64)
    for q in range(len(values)):
        total = per.sum() + area[q]
        excess = per / total - ct.goals if total > 0 else -ct.goals
        t = int(np.argmax(options.local_weight * values[q] - options.global_weight * coef * excess))
        chosen[q] = t
        per[t] += area[q]
    return chosen


def block_types(block: NDArray[np.int64], area: NDArray[np.float64], lut: NDArray[np.int64],
                n_blocks: int, n_types: int) -> NDArray[np.int64]:
    """A block's (or quarter's) type: the type holding the largest share of its lots' area.

    Parameters
    ----------
    block : ndarray of int, shape (L,)
        Block index per lot.
    area : ndarray, shape (L,)
    lut : ndarray of int, shape (L,)
    n_blocks, n_types : int

    Returns
    -------
    ndarray of int, shape (B,)
        Ties go to the lower type index; ``UNASSIGNED`` for a block without
        assigned lots.
    """
    block, lut = np.asarray(block, dtype=np.int64), np.asarray(lut, dtype=np.int64)
    ok = lut >= 0
    table = np.bincount(block[ok] * n_types + lut[ok], weights=np.asarray(area)[ok],
                        minlength=n_blocks * n_types).reshape(n_blocks, n_types)
    out = np.argmax(table, axis=1).astype(np.int64)
    out[table.sum(axis=1) <= 0] = UNASSIGNED
    return out


def runs_this_year(year: int, first_year: int, *, options: LandUseOptions = LandUseOptions()) -> bool:
    """Whether the update runs in ``year`` (every ``update_interval`` years from ``first_year``)."""
    if options.update_interval < 1:
        raise InputError(f"land_use update_interval: must be ≥ 1, got {options.update_interval}")
    return (year - first_year) % options.update_interval == 0


# --------------------------------------------------------------------------- calibration from OSM

#: OSM ``landuse=*`` (and a few ``leisure=*``) values → bundled type. Housing
#: is ``residential``, split by ground coverage into low/high density when
#: building footprints are given. Shops and offices are ``commercial``;
#: production, storage and transport land is ``industrial``; urban green open
#: to people is ``park``. Farmland, forest, meadow, water and the like are not
#: urban land use and are left out (forest counts as ``green`` for distances).
OSM_LANDUSE: Mapping[str, str] = {
    "residential": "residential",
    "retail": "commercial", "commercial": "commercial", "shops": "commercial",
    "industrial": "industrial", "port": "industrial", "railway": "industrial",
    "depot": "industrial", "garages": "industrial", "quarry": "industrial",
    "grass": "park", "recreation_ground": "park", "village_green": "park",
    "park": "park", "garden": "park", "cemetery": "park", "allotments": "park",
    "playground": "park", "pitch": "park", "sports_centre": "park",
}


@dataclass(frozen=True)
class LandUseCalibration:
    """Shares of the town's own land use and the goals derived from them (aligned with ``types``).

    ``shares`` (T,) are the town's tagged land use by area; ``goals`` (T,)
    blend them with the bundled goals by ``weight`` (see
    :func:`calibrate_landuse`); ``coverage`` is the share of the buildings
    (counted) inside mapped land use (or the mapped area over the town
    area); ``ignored`` the tag values that map to no type, with their counts.
    """

    shares: NDArray[np.float64]
    goals: NDArray[np.float64]
    mapped_area: float
    coverage: float
    weight: float
    ignored: tuple[tuple[str, int], ...]

    def with_goals(self, types: Sequence[LandUseType]) -> tuple[LandUseType, ...]:
        """The types with their goals replaced by the calibrated ones."""
        return tuple(LandUseType(t.name, float(g), t.terms, t.lot_size) for t, g in zip(types, self.goals))


def _resolve_types(names: Sequence[str]) -> dict[str, int]:
    index = {n: i for i, n in enumerate(names)}
    low = index.get("residential_low", index.get("residential", -1))
    high = index.get("residential_high", low)
    out = {}
    for value, kind in OSM_LANDUSE.items():
        if kind == "residential":
            out[value] = low
        else:
            out[value] = index.get(kind, -1)
    out["_residential_high"] = high
    return out


def _classified_pieces(polygons: Sequence[tuple[Any, str]], types: Sequence[LandUseType],
                       buildings: Sequence[Any] | None, options: LandUseOptions
                       ) -> tuple[list[Any], NDArray[np.int64], dict[str, int]]:
    """Mapped polygons, overlaps resolved (smaller wins), with their type index."""
    resolve = _resolve_types([t.name for t in types])
    ignored: dict[str, int] = {}
    geoms, kinds = [], []
    for geom, value in polygons:
        t = resolve.get(str(value), -1)
        if t < 0 or geom is None or shapely.is_empty(geom) or shapely.area(geom) <= 0:
            ignored[str(value)] = ignored.get(str(value), 0) + 1
            continue
        geoms.append(shapely.make_valid(geom) if not shapely.is_valid(geom) else geom)
        kinds.append((t, str(value) == "residential"))
    if not geoms:
        return [], np.zeros(0, np.int64), ignored
    areas = shapely.area(np.asarray(geoms, dtype=object))
    order = np.argsort(areas, kind="stable")  # small, specific polygons win over the large ones they sit in
    geoms = [geoms[i] for i in order]
    kinds = [kinds[i] for i in order]
    tree = shapely.STRtree(geoms)
    pieces = []
    for i, g in enumerate(geoms):
        earlier = [j for j in tree.query(g, predicate="intersects").tolist() if j < i]
        pieces.append(g.difference(shapely.union_all([geoms[j] for j in earlier])) if earlier else g)
    index = np.array([t for t, _ in kinds], dtype=np.int64)
    residential = np.array([r for _, r in kinds])
    if buildings is not None and len(buildings) and residential.any():
        footprints = np.asarray(list(buildings), dtype=object)
        foot = shapely.STRtree(footprints)
        high = resolve["_residential_high"]
        for i in np.flatnonzero(residential).tolist():
            hits = foot.query(pieces[i], predicate="intersects")
            covered = shapely.area(shapely.intersection(footprints[hits], pieces[i])).sum() if len(hits) else 0.0
            if shapely.area(pieces[i]) > 0 and covered / shapely.area(pieces[i]) > options.high_density_coverage:
                index[i] = high
    return pieces, index, ignored


def calibrate_landuse(polygons: Sequence[tuple[Any, str]], town_area: float | Any, *,
                      types: Sequence[LandUseType] = DEFAULT_TYPES,
                      buildings: Sequence[Any] | None = None,
                      options: LandUseOptions = LandUseOptions()) -> LandUseCalibration:
    """Initial shares and goals from the town's own ``landuse=*`` polygons (issue: calibrate from OSM).

    Parameters
    ----------
    polygons : sequence of (shapely Polygon, str)
        The town's land-use areas (m) with their ``landuse`` (or ``leisure``)
        value; values map to types by :data:`OSM_LANDUSE`, others are ignored.
        Where polygons overlap, the smaller one owns the overlap (a park inside
        a residential area is a park).
    town_area : float or shapely Polygon
        The town's built-up area (m²), or its outline: then land use outside
        it does not count (a residential polygon spanning a whole valley
        counts only where the town is) and its area is the town area.
    types : sequence of LandUseType
        Types named ``residential_low``/``residential_high`` (or
        ``residential``), ``commercial``, ``industrial``, ``park`` receive the
        mapped values.
    buildings : sequence of shapely Polygon, optional
        Building footprints (m); a residential polygon whose footprints cover
        more than ``high_density_coverage`` of it is high-density, and the
        coverage is the share of the buildings (a point inside each) in mapped polygons.

    Returns
    -------
    LandUseCalibration
        ``goals = w·shares + (1 − w)·bundled goals`` with
        ``w = min(1, coverage / min_calibration_coverage)`` (all bundled when
        nothing maps).
    """
    names = [t.name for t in types]
    default = goal_shares(types)
    outline = None
    if isinstance(town_area, shapely.Geometry):
        outline, town_area = town_area, float(shapely.area(town_area))
    pieces, index, ignored = _classified_pieces(polygons, types, buildings, options)
    geoms = np.asarray(pieces, dtype=object)
    if outline is not None and len(geoms):
        geoms = shapely.intersection(geoms, outline)
    per = (np.bincount(index, weights=shapely.area(geoms), minlength=len(names)).astype(np.float64)
           if len(index) else np.zeros(len(names)))
    mapped = float(per.sum())
    shares = per / mapped if mapped > 0 else np.zeros(len(names))
    if buildings is not None and len(buildings):
        points = shapely.point_on_surface(np.asarray(list(buildings), dtype=object))
        inside = np.zeros(len(points), dtype=bool)
        if len(geoms):
            hit, _ = shapely.STRtree(geoms).query(points, predicate="intersects")
            inside[hit] = True
        coverage = float(inside.mean())
    else:
        coverage = min(1.0, mapped / town_area) if town_area > 0 else 0.0
    weight = min(1.0, coverage / options.min_calibration_coverage) if mapped > 0 else 0.0
    goals = weight * shares + (1.0 - weight) * default
    return LandUseCalibration(shares, goals / goals.sum(), mapped, coverage, weight,
                              tuple(sorted(ignored.items())))


def types_from_polygons(xy: NDArray[np.float64], polygons: Sequence[tuple[Any, str]], *,
                        types: Sequence[LandUseType] = DEFAULT_TYPES,
                        buildings: Sequence[Any] | None = None,
                        options: LandUseOptions = LandUseOptions()) -> NDArray[np.int64]:
    """The type of the tagged land-use polygon each point lies in, same mapping as :func:`calibrate_landuse`.

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Lot centroids (m).
    polygons : sequence of (shapely Polygon, str)

    Returns
    -------
    ndarray of int, shape (L,)
        Type index, ``UNASSIGNED`` outside every mapped polygon (initial types
        for the old town's lots).
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.full(len(xy), UNASSIGNED, dtype=np.int64)
    pieces, index, _ = _classified_pieces(polygons, types, buildings, options)
    if not pieces or not len(xy):
        return out
    points = shapely.points(xy)
    pi, gi = shapely.STRtree(pieces).query(points, predicate="within")
    out[pi] = index[gi]
    return out


# --------------------------------------------------------------------------- similarity (002 §6)

def rasterise_lots(xy: NDArray[np.float64], lut: NDArray[np.int64], *,
                   bounds: tuple[float, float, float, float], cell: float,
                   max_distance: float) -> NDArray[np.int64]:
    """A land-use image: each cell takes the type of the nearest lot centroid within ``max_distance``.

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
    lut : ndarray of int, shape (L,)
    bounds : (xmin, ymin, xmax, ymax)
        Metres.
    cell : float
        Pixel size (m).
    max_distance : float
        Cells farther than this (m) from every lot are ``UNASSIGNED``.

    Returns
    -------
    ndarray of int, shape (rows, cols)
        Row 0 at ``ymin``.
    """
    xs, ys = _grid(bounds, cell)
    gx, gy = np.meshgrid(xs, ys)
    out = np.full(gx.shape, UNASSIGNED, dtype=np.int64)
    if len(xy) == 0:
        return out
    d, i = cKDTree(np.asarray(xy, float)).query(np.column_stack([gx.ravel(), gy.ravel()]),
                                               distance_upper_bound=max_distance)
    hit = np.isfinite(d)
    flat = out.reshape(-1)
    flat[hit] = np.asarray(lut)[i[hit]]
    return out


def _grid(bounds: tuple[float, float, float, float], cell: float) -> tuple[NDArray, NDArray]:
    xmin, ymin, xmax, ymax = bounds
    if not cell > 0 or not (xmax > xmin and ymax > ymin):
        raise InputError(f"land use raster: bad bounds {bounds} or cell {cell}")
    return (np.arange(xmin + cell / 2, xmax, cell), np.arange(ymin + cell / 2, ymax, cell))


def rasterise_polygons(polygons: Sequence[tuple[Any, str]], *, bounds: tuple[float, float, float, float],
                       cell: float, types: Sequence[LandUseType] = DEFAULT_TYPES,
                       buildings: Sequence[Any] | None = None,
                       options: LandUseOptions = LandUseOptions()) -> NDArray[np.int64]:
    """The town's real land use as an image (cell centres in mapped polygons; see :func:`types_from_polygons`).

    Returns
    -------
    ndarray of int, shape (rows, cols)
        Type index per cell, ``UNASSIGNED`` where nothing is mapped; row 0 at ``ymin``.
    """
    xs, ys = _grid(bounds, cell)
    gx, gy = np.meshgrid(xs, ys)
    flat = types_from_polygons(np.column_stack([gx.ravel(), gy.ravel()]), polygons,
                               types=types, buildings=buildings, options=options)
    return flat.reshape(gx.shape)


def similarity(image: NDArray[np.int64], reference: NDArray[np.int64], n: int, *,
               samples: int = 1000, rng: np.random.Generator | None = None,
               nodata: int | None = None) -> float:
    """Weber's texture similarity ``Similarity(X, Y)`` of two land-use images (002 §6, Eq. 12–13).

    For each sampled pixel ``p`` of ``image`` (X) take its ``n×n``
    neighbourhood ``x_p``, find the neighbourhood ``z_p`` of ``reference`` (Y)
    with the most identical values, and average ``sim = (identical values) /
    n²`` over the samples. The best match is exact: with one-hot codes per
    value the count of identical values is a dot product, so all of Y's
    neighbourhoods are scored at once by a matrix product (in blocks). Cost
    ``samples × (Y's windows) × n² × (distinct values)``: about a second for
    ``n = 8`` on 200×200 with 1,000 samples; ``samples`` trades accuracy
    (standard error ≤ 0.5/√samples) for time.

    Parameters
    ----------
    image, reference : ndarray of int, shape (H, W) and (H', W')
        Land-use images (any integer codes; equal codes are the same use).
    n : int
        Neighbourhood size (pixels), at most the smaller image side.
    samples : int
        Pixels of X sampled (all when X has fewer windows).
    rng : numpy.random.Generator, optional
        Picks the samples (default: a fixed seed, so the measure is repeatable).
    nodata : int, optional
        X pixels with this value (the real town's untagged land) are never
        sampled as centres and do not count in a neighbourhood: Eq. 13 then
        divides by the number of X's other pixels instead of ``n²``.

    Returns
    -------
    float
        In [0, 1]; 1 when every sampled neighbourhood of X occurs in Y.
    """
    x = np.asarray(image)
    y = np.asarray(reference)
    if x.ndim != 2 or y.ndim != 2:
        raise InputError("similarity: images must be 2-D")
    if not 1 <= n <= min(*x.shape, *y.shape):
        raise InputError(f"similarity: n must lie in 1..{min(*x.shape, *y.shape)}, got {n}")
    rng = np.random.default_rng(0) if rng is None else rng
    codes, inverse = np.unique(np.concatenate([x.ravel(), y.ravel()]), return_inverse=True)
    k = len(codes)
    xc = inverse[:x.size].reshape(x.shape)
    yc = inverse[x.size:].reshape(y.shape)
    xw = np.lib.stride_tricks.sliding_window_view(xc, (n, n)).reshape(-1, n * n)
    yw = np.lib.stride_tricks.sliding_window_view(yc, (n, n)).reshape(-1, n * n)
    candidates = np.arange(len(xw))
    if nodata is not None:
        centre = np.lib.stride_tricks.sliding_window_view(x, (n, n))[:, :, n // 2, n // 2].ravel()
        candidates = candidates[centre != nodata]
        if len(candidates) == 0:
            raise InputError("similarity: every pixel of the image is nodata")
    if len(candidates) > samples:
        candidates = np.sort(rng.choice(candidates, size=samples, replace=False))
    xs = _one_hot(xw[candidates], k)
    valid = np.full(len(candidates), float(n * n))
    if nodata is not None and nodata in codes:
        code = int(np.searchsorted(codes, nodata))
        xs[:, code::k] = 0.0  # a nodata pixel of X matches nothing and does not count
        valid = (xw[candidates] != code).sum(axis=1).astype(np.float64)
    best = np.zeros(len(candidates))
    block = max(1, int(2e7 // (n * n * k)))  # ~80 MB of float32 per block of Y's windows
    for start in range(0, len(yw), block):
        yb = _one_hot(yw[start:start + block], k)
        np.maximum(best, (xs @ yb.T).max(axis=1), out=best)
    return float((best / valid).mean())


def _one_hot(windows: NDArray[np.int64], k: int) -> NDArray[np.float32]:
    out = np.zeros((len(windows), windows.shape[1] * k), dtype=np.float32)
    cols = np.arange(windows.shape[1]) * k
    out[np.arange(len(windows))[:, None], cols[None, :] + windows] = 1.0
    return out
