"""Land-use types (seed 002 §4.3): what a type is, its valuation functions, its goal share, the bundled types
and the options; the types compiled into arrays of terms for the lot values.

A *land-use type* is a goal share of the city's lot area plus a convex
combination of *valuation functions* (002 §4.3, Eq. 4), each one of five
mapping functions (step, linear up/down, gain up/down; Perlin & Hoffert's
``gain`` for the S-shaped ones) applied to one lot attribute between two
bounds. A lot's value ``luv`` under a type lies in [0, 1].
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from osm_expand.errors import HistoryError, InputError
from osm_expand.model.enums import parse_enum
from osm_expand.model.options import require_positive

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
CLUSTER_CODE = len(STATIC_ATTRIBUTES)
INFLUENCE_CODE = CLUSTER_CODE + 1  # + index of the influencing type


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
        require_positive(self, ("influence_radius", "goal_scale", "chunk_share", "amenity_distance_unit",
                                "min_calibration_coverage"))
        for key in ("cluster_neighbours", "global_weight", "local_weight", "reject_slope", "sample_share",
                    "min_chunk"):
            if not getattr(self, key) >= 0:
                raise InputError(f"land_use {key}: must be ≥ 0, got {getattr(self, key)}")
        if not 0 < self.traffic_quantile <= 1:
            raise InputError(f"land_use traffic_quantile: must lie in (0, 1], got {self.traffic_quantile}")


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
    compile_types(result, available=(True,) * len(STATIC_ATTRIBUTES))
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


@dataclass(frozen=True)
class _Term:
    weight: float
    kind: str
    code: int  # static column, CLUSTER_CODE, or INFLUENCE_CODE + type index
    low: float
    high: float
    gain: float


@dataclass(frozen=True)
class CompiledTypes:
    names: tuple[str, ...]
    goals: NDArray[np.float64]
    terms: tuple[tuple[_Term, ...], ...]  # per type, weights renormalised to sum 1

    @property
    def n(self) -> int:
        return len(self.names)

    @cached_property
    def table(self) -> TermTable:
        """All terms as arrays, for :func:`~osm_expand.engine.buildout.lot_values.term_values`."""
        flat = [(t, term) for t, terms in enumerate(self.terms) for term in terms]
        kinds = np.array([term.kind for _, term in flat], dtype=object)
        codes = np.array([term.code for _, term in flat], dtype=np.int64)
        owner = np.array([t for t, _ in flat], dtype=np.int64)
        n_static = len(STATIC_ATTRIBUTES)
        # columns of [static | cluster per type | influence per type]
        column = np.where(codes < CLUSTER_CODE, codes,
                          np.where(codes == CLUSTER_CODE, n_static + owner,
                                   n_static + self.n + codes - INFLUENCE_CODE))
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
            if term.code >= INFLUENCE_CODE:
                by_pair.setdefault((t, term.code - INFLUENCE_CODE), []).append(f)
            elif term.code == CLUSTER_CODE:
                by_type.setdefault(t, []).append(f)
        influence = np.full((max([len(v) for v in by_pair.values()], default=0), self.n, self.n), -1, np.int64)
        for (t, src), fs in by_pair.items():
            influence[:len(fs), t, src] = fs
        cluster = np.full((max([len(v) for v in by_type.values()], default=0), self.n), -1, np.int64)
        for t, fs in by_type.items():
            cluster[:len(fs), t] = fs
        return TermTable(
            column=column, low=np.array([term.low for _, term in flat], dtype=np.float64),
            high=np.array([term.high for _, term in flat], dtype=np.float64), exponent=exponent,
            step=kinds == Valuation.STEP.value,
            gain=(kinds == Valuation.GAIN_UP.value) | (kinds == Valuation.GAIN_DOWN.value),
            down=(kinds == Valuation.LINEAR_DOWN.value) | (kinds == Valuation.GAIN_DOWN.value),
            weight=weight, term_weight=term_weight, influence=influence, cluster=cluster)


@dataclass(frozen=True, eq=False)
class TermTable:
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


def compile_types(types: Sequence[LandUseType], available: Sequence[bool]) -> CompiledTypes:
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
                code = INFLUENCE_CODE + index[term.of_type]
            elif attribute is Attribute.CLUSTER:
                code = CLUSTER_CODE
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
    return CompiledTypes(names, goal_shares(types), tuple(compiled))


#: The default options, one object (an argument default that is a module-level constant).
DEFAULT_OPTIONS = LandUseOptions()
