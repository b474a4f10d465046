"""The economy of lots and buildings: price, floor space, floors, heights, occupants, substitution.

Seed 002 §5.2–5.4 with seed 004 §4.3.4's height shape.

Economy (002 §5.2–5.3), per lot ``i``:

    price_i      = area_i · avgprice(t) · luv_i / mean_j luv_j                 (Eq. 9)
    floorspace_i = price_i · margin_i,  margin_i ~ N(μ_t, σ_t) truncated     (Eq. 10)
    floors_i     = floorspace_i / envelope_area_i                             (Eq. 11)

``avgprice(t)`` (currency per m² of land) is the history's time function;
``margin`` (m² of floor per unit of currency) is per land-use type,
truncated at ``±margin_truncation`` standard deviations and at 0. The bundled
margins assume ``avgprice = 100`` at the start, where ``avgprice · margin``
is each type's floor-area ratio (FAR): 0.5 detached houses, 1.6 urban
blocks, 1.2 shops and offices, 0.5 sheds and halls, 0 for parks.

Height shape (004 §4.3.4): 004 makes a building's height a Gaussian of its
distance to the centre, adds noise, and doubles it with a chance that rises
toward the centre. The default :class:`HeightShape` ``economy_falloff``
combines the two: the economy gives each lot its floors, the fall-off
redistributes them by position,

    raw_i = floors_i · s(d_i) · ε_i · D_i,
    s(d)  = e + (1 − e) · exp(−½ (d/σ)²)          (d: distance to the nearest centre / city extent)
    ε_i   ~ lognormal(0, noise_sd),   D_i = 2 with probability p₀ · exp(−½ (d/σ)²), else 1,

so a lot's value and type decide how much it builds and the centre decides
how tall that becomes. ``falloff`` is 004 alone (``floors_i = 1``: only the
shape), ``economy`` is 002 alone (``s = ε = D = 1``).

Calibration: ``storey_height`` is the median ``height / building:levels``
of the town's buildings that carry both tags (else 3 m); the target height
distribution is that of the tagged buildings (``height``, or ``levels ×
storey`` where only levels are tagged), else 2–3–4 floors (quartiles and
median). Floors are ``round(a · raw^b)``, at least 1, at most the type's
``max_floors``; :func:`fit_height_scale` picks ``a`` so that the median lands
on the target median and ``b`` so that the quartile ratio matches too. Fit once (on the first
year's lots) and keep it: a rising ``avgprice(t)`` then raises the city, as 002
intends. Height = floors × storey height.

Occupants (for the trip model, 002 §3.2: "residents" are all the people on
a lot during 24 hours): residents = built floor space / m² per resident,
jobs = built floor space / m² per job, visitors = lot area × visitors per m²
(parks); per type in :data:`DEFAULT_ECONOMY`.

Substitution (002 §5.4): ``p_sub = f₁(age) + f₂(Δprice)`` per year, clipped
to [0, 1], with ``f₁``, ``f₂`` valuation functions (002: "user selected
functions … see previous section") times a weight, and
``Δprice = (price − floorspace_existing / margin_t) / price``: the share of a
new building's price that the existing building does not pay for, computed
as ``1 − floorspace_existing / floorspace_new`` on built floor space (see
:func:`substitution_probability`). A replaced building gets the current year.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr, ndtri

from osm_expand.engine.buildout.landuse_types import valuate
from osm_expand.errors import InputError
from osm_expand.model.enums import parse_enum
from osm_expand.model.options import require_positive

__all__ = [
    "HeightShape", "TypeEconomy", "DEFAULT_ECONOMY", "EconomyOptions",
    "lot_prices", "expected_floor_space", "sample_margins", "floors_from_floor_space", "centre_falloff",
    "raw_floors", "HeightCalibration", "calibrate_heights", "HeightScale", "fit_height_scale",
    "building_floors", "Occupants", "occupants", "LotEconomy", "lot_economy",
    "substitution_probability", "Substitution", "substitute",
]


class HeightShape(StrEnum):
    """How floors come about: 002's economy, 004's centre fall-off, or both (default)."""

    ECONOMY_FALLOFF = "economy_falloff"
    ECONOMY = "economy"
    FALLOFF = "falloff"


@dataclass(frozen=True)
class TypeEconomy:
    """Economic parameters of one land-use type (matched to the land-use types by ``name``)."""

    name: str
    #: Mean of the truncated Gaussian margin (m² of floor per unit of price; 002 Eq. 10).
    margin_mean: float
    #: Its standard deviation.
    margin_sd: float
    #: Gross floor space per resident (m²); 0: nobody lives there.
    floor_per_resident: float = 0.0
    #: Gross floor space per job (m²); 0: no jobs.
    floor_per_job: float = 0.0
    #: People visiting per m² of lot per day (parks).
    visitors_per_area: float = 0.0
    #: Upper bound on floors.
    max_floors: int = 30


#: Bundled economics for :data:`osm_expand.engine.buildout.landuse_types.DEFAULT_TYPES`.
#: Margins: FAR / 100 (see the module docstring), spread 20 % (002 gives no
#: numbers). Floor space per person: ~45 m² of living space per person in
#: Central Europe, plus walls and stairs (gross ≈ 1.2 × living): 55 m² in
#: houses, 40 m² in flats. Jobs: ~30 m² per office/shop job, ~100 m² per job
#: in sheds and halls. Parks: 20 visitors per hectare per day. Max floors:
#: houses 4, flats 20, offices 30, halls 4.
DEFAULT_ECONOMY: tuple[TypeEconomy, ...] = (
    TypeEconomy("residential_low", 0.005, 0.001, floor_per_resident=55.0, max_floors=4),
    TypeEconomy("residential_high", 0.016, 0.0032, floor_per_resident=40.0, max_floors=20),
    TypeEconomy("commercial", 0.012, 0.0024, floor_per_job=30.0, max_floors=30),
    TypeEconomy("industrial", 0.005, 0.001, floor_per_job=100.0, max_floors=4),
    TypeEconomy("park", 0.0, 0.0, visitors_per_area=0.002, max_floors=0),
)


@dataclass(frozen=True)
class EconomyOptions:
    #: How floors come about (:class:`HeightShape`); the issue asks for 004's fall-off as the default shape.
    shape: str = "economy_falloff"
    #: Storey height (m) when the town has too few buildings with both tags;
    #: 3 m is the usual floor-to-floor height of housing (OSM's rule of thumb too).
    storey_height: float = 3.0
    #: A calibrated storey height is clipped to this range (m): tagging errors aside,
    #: storeys are 2.4 m (low housing) to 5 m (shops, halls).
    storey_range: tuple[float, float] = (2.4, 5.0)
    #: Buildings with both ``height`` and ``building:levels`` needed to calibrate the storey height.
    min_storey_pairs: int = 5
    #: Buildings with a height (or levels) needed to calibrate the height distribution.
    min_tagged: int = 10
    #: Without tags: the median floors of generated buildings (a Central-European
    #: small town: two to four storeys, three typical) ...
    default_median_floors: float = 3.0
    #: ... and their quartiles (floors).
    default_quartile_floors: tuple[float, float] = (2.0, 4.0)
    #: Fit the quartile ratio of the target heights too (``b`` of ``a · raw^b``;
    #: without tags the default quartiles: the economy's lot values alone spread
    #: floors five-fold between the quartiles, more than towns show) ...
    match_spread: bool = True
    #: ... with ``b`` kept within [1/this, this].
    max_spread_exponent: float = 2.0
    #: Margins are truncated at this many standard deviations (002: "truncated Gaussian").
    margin_truncation: float = 2.0
    #: σ of 004's Gaussian fall-off, as a share of the city extent (the
    #: distance unit of ``center_dist``): a quarter of the diagonal, so the
    #: old centre stands out and the outskirts are flat.
    falloff_sigma: float = 0.25
    #: ``e``: the fall-off factor far from the centre (1 at the centre); 0.5
    #: halves heights at the edge, about what small towns show (004 gives no number).
    falloff_edge: float = 0.5
    #: Standard deviation of the log of 004's multiplicative height noise.
    noise_sd: float = 0.15
    #: 004's doubling chance at the centre; it falls off with the same Gaussian.
    double_chance: float = 0.10
    #: Substitution f₁(age): valuation kind and bounds (years) ...
    age_kind: str = "linear_up"
    age_bounds: tuple[float, float] = (40.0, 120.0)
    #: ... and weight: 2 %/year from 120 years on (buildings last 50–150 years).
    age_weight: float = 0.02
    #: Substitution f₂(Δprice): valuation kind and bounds (share of the new price) ...
    price_kind: str = "linear_up"
    price_bounds: tuple[float, float] = (0.25, 0.75)
    #: ... and weight: 5 %/year once the old building pays for a quarter of
    #: the land's worth or less.
    price_weight: float = 0.05

    def __post_init__(self) -> None:
        _shape(self)
        require_positive(self, ("storey_height", "default_median_floors", "falloff_sigma", "max_spread_exponent",
                                "margin_truncation"))
        for key in ("noise_sd", "age_weight", "price_weight", "falloff_edge"):
            if not getattr(self, key) >= 0:
                raise InputError(f"economy {key}: must be ≥ 0, got {getattr(self, key)}")
        if not 0 <= self.double_chance <= 1:
            raise InputError(f"economy double_chance: must lie in [0, 1], got {self.double_chance}")
        lo, hi = self.storey_range
        if not 0 < lo <= hi:
            raise InputError(f"economy storey_range: must be 0 < low ≤ high, got {self.storey_range}")


def _shape(options: EconomyOptions) -> HeightShape:
    return parse_enum(HeightShape, options.shape, "economy shape")


def _per_type(lut: NDArray[np.int64], economies: Sequence[TypeEconomy],
              field: str) -> NDArray[np.float64]:
    """A TypeEconomy field per lot (0 for unassigned lots)."""
    table = np.array([getattr(e, field) for e in economies] + [0.0], dtype=np.float64)
    lut = np.asarray(lut, dtype=np.int64)
    if len(lut) and lut.max(initial=-1) >= len(economies):
        raise InputError(f"economy: lot types go up to {lut.max()} but only {len(economies)} economies are given")
    return table[np.where(lut >= 0, lut, len(economies))]


def lot_prices(area: NDArray[np.float64], luv: NDArray[np.float64], avgprice: float) -> NDArray[np.float64]:
    """Lot prices (002 Eq. 9): ``area · avgprice · luv / mean(luv)``.

    Parameters
    ----------
    area : ndarray, shape (L,)
        Lot areas (m²).
    luv : ndarray, shape (L,)
        Land-use values of the lots under their types (``LandUseUpdate.luv``), ≥ 0.
    avgprice : float
        This year's ``avgprice(t)`` (currency per m² of land).

    Returns
    -------
    ndarray, shape (L,)
        Price per lot (currency); ``area · avgprice`` everywhere when every
        ``luv`` is 0.
    """
    area = np.asarray(area, dtype=np.float64)
    luv = np.maximum(np.asarray(luv, dtype=np.float64), 0.0)
    mean = luv.mean() if len(luv) else 0.0
    ratio = luv / mean if mean > 0 else np.ones_like(luv)
    return area * float(avgprice) * ratio


def expected_floor_space(area: NDArray[np.float64], luv: NDArray[np.float64], lut: NDArray[np.int64],
                         avgprice: float, *, economies: Sequence[TypeEconomy] = DEFAULT_ECONOMY
                         ) -> NDArray[np.float64]:
    """Floor space (m²) the land use expects on each lot before anything is built: price · mean margin.

    002 Eq. 9–10 with each type's mean margin instead of a draw (002 §4:
    "the number of residents per lot depends on the land use value"): what
    the traffic model counts for lots whose street is still planned, so that
    the street draws the traffic that gets it built (002 §3.2).

    Parameters
    ----------
    area, luv : ndarray, shape (L,)
        As for :func:`lot_prices` (all the city's units: the price uses their mean ``luv``).
    lut : ndarray of int, shape (L,)
    avgprice : float

    Returns
    -------
    ndarray, shape (L,)
        0 for types without a margin (parks) and unassigned lots.
    """
    return lot_prices(area, luv, avgprice) * _per_type(lut, economies, "margin_mean")


def sample_margins(lut: NDArray[np.int64], *, economies: Sequence[TypeEconomy] = DEFAULT_ECONOMY,
                   rng: np.random.Generator,
                   options: EconomyOptions = EconomyOptions()) -> NDArray[np.float64]:
    """Per-lot margins from the type's truncated Gaussian (002 Eq. 10).

    Parameters
    ----------
    lut : ndarray of int, shape (L,)
        Type per lot (``UNASSIGNED`` → margin 0).
    economies : sequence of TypeEconomy
        Aligned with the land-use types.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (L,)
        Margins within ``μ ± margin_truncation · σ`` and ≥ 0 (inverse-CDF
        sampling of the truncated normal, one uniform per lot).
    """
    mu = _per_type(lut, economies, "margin_mean")
    sd = _per_type(lut, economies, "margin_sd")
    u = rng.random(len(mu))
    k = options.margin_truncation
    safe = np.where(sd > 0, sd, 1.0)
    lo = np.maximum(-k, np.where(sd > 0, -mu / safe, -k))  # truncate at 0 as well
    a, b = ndtr(lo), ndtr(k)
    z = ndtri(np.clip(a + u * (b - a), 1e-12, 1 - 1e-12))
    return np.where(sd > 0, np.maximum(mu + z * sd, 0.0), mu)


def floors_from_floor_space(floor_space: NDArray[np.float64],
                            envelope_area: NDArray[np.float64]) -> NDArray[np.float64]:
    """Floors (002 Eq. 11): floor space / building envelope (footprint) area; 0 without an envelope."""
    fs = np.asarray(floor_space, dtype=np.float64)
    env = np.asarray(envelope_area, dtype=np.float64)
    return np.divide(fs, env, out=np.zeros_like(fs), where=env > 0)


def centre_falloff(centre_dist: NDArray[np.float64], *,
                   options: EconomyOptions = EconomyOptions()) -> NDArray[np.float64]:
    """004 §4.3.4's Gaussian of the distance to the centre: ``e + (1 − e)·exp(−½ (d/σ)²)``.

    Parameters
    ----------
    centre_dist : ndarray, shape (L,)
        Distance to the nearest centre as a share of the city extent (the
        land-use attribute ``center_dist``).

    Returns
    -------
    ndarray, shape (L,)
        1 at a centre, falling to ``falloff_edge``.
    """
    d = np.asarray(centre_dist, dtype=np.float64)
    e = options.falloff_edge
    return e + (1.0 - e) * np.exp(-0.5 * (d / options.falloff_sigma) ** 2)


def raw_floors(econ_floors: NDArray[np.float64], centre_dist: NDArray[np.float64], *,
               rng: np.random.Generator,
               options: EconomyOptions = EconomyOptions()) -> NDArray[np.float64]:
    """Unscaled floors of the height shape (module docstring): economy × fall-off × noise × doubling.

    Parameters
    ----------
    econ_floors : ndarray, shape (L,)
        Floors from the economy (Eq. 11); lots with 0 stay 0 (no building).
    centre_dist : ndarray, shape (L,)
        As in :func:`centre_falloff`.
    rng : numpy.random.Generator
        Two draws per lot (noise, doubling) in every shape, so shapes share streams.

    Returns
    -------
    ndarray, shape (L,)
        ≥ 0; scale with :func:`fit_height_scale` / :func:`building_floors`.
    """
    shape = _shape(options)
    econ = np.asarray(econ_floors, dtype=np.float64)
    d = np.asarray(centre_dist, dtype=np.float64)
    noise = np.exp(options.noise_sd * rng.standard_normal(len(econ)))
    doubled = rng.random(len(econ)) < options.double_chance * np.exp(-0.5 * (d / options.falloff_sigma) ** 2)
    if shape is HeightShape.ECONOMY:
        return econ.copy()
    base = np.where(econ > 0, 1.0, 0.0) if shape is HeightShape.FALLOFF else econ
    return base * centre_falloff(d, options=options) * noise * np.where(doubled, 2.0, 1.0)


# --------------------------------------------------------------------------- calibration

@dataclass(frozen=True)
class HeightCalibration:
    """The town's storey height and the target height distribution (m)."""

    storey_height: float
    median: float
    quartiles: tuple[float, float]
    n_tagged: int
    n_storey_pairs: int
    from_tags: bool


def calibrate_heights(heights: NDArray[np.float64], levels: NDArray[np.float64], *,
                      options: EconomyOptions = EconomyOptions()) -> HeightCalibration:
    """Storey height and height distribution from the town's ``height`` / ``building:levels`` tags.

    Parameters
    ----------
    heights : ndarray, shape (N,)
        ``height`` per existing building (m), NaN where untagged.
    levels : ndarray, shape (N,)
        ``building:levels`` per building, NaN where untagged.

    Returns
    -------
    HeightCalibration
        ``storey_height``: median ``height / levels`` over buildings with both
        (at least ``min_storey_pairs``), clipped to ``storey_range``; else
        ``options.storey_height``. ``median``/``quartiles``: of the tagged
        heights (``levels × storey`` where only levels are tagged) when at least
        ``min_tagged`` buildings have one; else the defaults in floors × storey.
    """
    h = np.asarray(heights, dtype=np.float64)
    lv = np.asarray(levels, dtype=np.float64)
    if h.shape != lv.shape:
        raise InputError(f"calibrate_heights: heights {h.shape} and levels {lv.shape} differ in shape")
    h = np.where(h > 0, h, np.nan)
    lv = np.where(lv > 0, lv, np.nan)
    both = np.isfinite(h) & np.isfinite(lv)
    storey = options.storey_height
    if both.sum() >= options.min_storey_pairs:
        storey = float(np.clip(np.median(h[both] / lv[both]), *options.storey_range))
    tagged = np.where(np.isfinite(h), h, lv * storey)
    tagged = tagged[np.isfinite(tagged)]
    if len(tagged) >= options.min_tagged:
        q25, q50, q75 = np.quantile(tagged, [0.25, 0.5, 0.75])
        return HeightCalibration(storey, float(q50), (float(q25), float(q75)), len(tagged), int(both.sum()), True)
    q25, q75 = options.default_quartile_floors
    return HeightCalibration(storey, options.default_median_floors * storey, (q25 * storey, q75 * storey),
                             len(tagged), int(both.sum()), False)


@dataclass(frozen=True)
class HeightScale:
    """``floors = round(a · raw^b)``: the fitted map from raw to real floors."""

    a: float
    b: float = 1.0


def fit_height_scale(raw: NDArray[np.float64], calibration: HeightCalibration, *,
                     options: EconomyOptions = EconomyOptions()) -> HeightScale:
    """Fit ``a`` (and ``b``) so that generated floors match the town's tagged heights.

    Parameters
    ----------
    raw : ndarray, shape (L,)
        :func:`raw_floors` of a representative set of lots (the first year's);
        zeros (no building) are ignored.
    calibration : HeightCalibration

    Returns
    -------
    HeightScale
        ``a·median(raw)^b`` = target median floors (``median / storey``);
        ``b`` matches the quartile ratio of the target (the town's tagged
        heights, else the default quartiles) when ``match_spread``, within
        ``[1/max_spread_exponent, max_spread_exponent]``; else 1.
    """
    r = np.asarray(raw, dtype=np.float64)
    r = r[r > 0]
    target = calibration.median / calibration.storey_height
    if len(r) == 0:
        return HeightScale(target, 1.0)
    q25, m, q75 = np.quantile(r, [0.25, 0.5, 0.75])
    b = 1.0
    t25, t75 = calibration.quartiles
    if options.match_spread and q75 > q25 > 0 and t75 > t25 > 0:
        b = float(np.log(t75 / t25) / np.log(q75 / q25))
        lim = options.max_spread_exponent
        b = float(np.clip(b, 1.0 / lim, lim))
    return HeightScale(float(target / m ** b), b)


def building_floors(raw: NDArray[np.float64], lut: NDArray[np.int64], scale: HeightScale, *,
                    economies: Sequence[TypeEconomy] = DEFAULT_ECONOMY) -> NDArray[np.int64]:
    """Whole floors: ``round(a · raw^b)``, at least 1 where ``raw > 0``, at most the type's ``max_floors``.

    Returns
    -------
    ndarray of int, shape (L,)
        0 where nothing is built (``raw = 0``, a park, an unassigned lot).
    """
    r = np.asarray(raw, dtype=np.float64)
    cap = _per_type(lut, economies, "max_floors")
    floors = np.rint(scale.a * np.power(np.maximum(r, 0.0), scale.b))
    floors = np.where(r > 0, np.maximum(floors, 1.0), 0.0)
    return np.minimum(floors, cap).astype(np.int64)


# --------------------------------------------------------------------------- occupants and the whole step

@dataclass(frozen=True)
class Occupants:
    """People on each lot over a day (002 §3.2), shape (L,) each; ``people`` is the trip model's residents."""

    residents: NDArray[np.float64]
    jobs: NDArray[np.float64]
    visitors: NDArray[np.float64]

    @property
    def people(self) -> NDArray[np.float64]:
        return self.residents + self.jobs + self.visitors


def occupants(floor_space: NDArray[np.float64], lot_area: NDArray[np.float64], lut: NDArray[np.int64], *,
              economies: Sequence[TypeEconomy] = DEFAULT_ECONOMY) -> Occupants:
    """Residents, jobs and visitors per lot from built floor space and land use (002 §5.2, §3.2).

    Parameters
    ----------
    floor_space : ndarray, shape (L,)
        Built floor space (m²): floors × footprint area of the lot's building.
    lot_area : ndarray, shape (L,)
        Lot area (m²), for visitors.
    lut : ndarray of int, shape (L,)

    Returns
    -------
    Occupants
        ``floor_space / floor_per_resident`` etc. (0 where the type has none).
    """
    fs = np.asarray(floor_space, dtype=np.float64)

    def per(field: str) -> NDArray[np.float64]:
        denom = _per_type(lut, economies, field)
        return np.divide(fs, denom, out=np.zeros_like(fs), where=denom > 0)

    visitors = np.asarray(lot_area, dtype=np.float64) * _per_type(lut, economies, "visitors_per_area")
    return Occupants(per("floor_per_resident"), per("floor_per_job"), visitors)


@dataclass(frozen=True)
class LotEconomy:
    """One year's economy for the lots, shape (L,) each, plus the height scale used."""

    price: NDArray[np.float64]
    margin: NDArray[np.float64]
    floor_space: NDArray[np.float64]
    floors: NDArray[np.int64]
    height: NDArray[np.float64]
    occupants: Occupants
    scale: HeightScale
    raw: NDArray[np.float64] | None = None  #: (L,) :func:`raw_floors` before the scale


def lot_economy(area: NDArray[np.float64], envelope_area: NDArray[np.float64], luv: NDArray[np.float64],
                lut: NDArray[np.int64], centre_dist: NDArray[np.float64], *, avgprice: float,
                calibration: HeightCalibration, scale: HeightScale | None = None,
                reference_raw: NDArray[np.float64] | None = None,
                economies: Sequence[TypeEconomy] = DEFAULT_ECONOMY, rng: np.random.Generator,
                options: EconomyOptions = EconomyOptions()) -> LotEconomy:
    """Price, floor space, floors, height and occupants of a building on every lot (002 §5.2–5.3, 004 §4.3.4).

    Parameters
    ----------
    area : ndarray, shape (L,)
        Lot areas (m²); pass all the city's lots (the price uses their mean ``luv``).
    envelope_area : ndarray, shape (L,)
        Footprint area (m²) of the building the lot can hold (0: none).
    luv : ndarray, shape (L,)
        Lot values under their types (``LandUseUpdate.luv``).
    lut : ndarray of int, shape (L,)
    centre_dist : ndarray, shape (L,)
        Distance to the nearest centre / city extent (``center_dist``).
    avgprice : float
        This year's ``avgprice(t)``.
    calibration : HeightCalibration
        From :func:`calibrate_heights`.
    scale : HeightScale, optional
        The scale to use; None fits it (:func:`fit_height_scale`) on these
        lots' raw floors and ``reference_raw`` together.
    reference_raw : ndarray, shape (K,), optional
        Raw floors of buildings already standing (each from the year it was
        built): fitting on them too calibrates the whole stock, not just
        this year's buildings.
    rng : numpy.random.Generator
        Margins, then the height noise and doubling (three draws per lot).

    Returns
    -------
    LotEconomy
        ``floor_space`` is the economy's demand (Eq. 10); ``floors``,
        ``height`` (m) the building the year would put there; ``occupants``
        from the built floor space ``floors × envelope_area``.
    """
    price = lot_prices(area, luv, avgprice)
    margin = sample_margins(lut, economies=economies, rng=rng, options=options)
    demand = price * margin
    econ = floors_from_floor_space(demand, envelope_area)
    raw = raw_floors(econ, centre_dist, rng=rng, options=options)
    if scale is None:
        sample = raw if reference_raw is None else np.concatenate([raw, np.asarray(reference_raw, np.float64)])
        scale = fit_height_scale(sample, calibration, options=options)
    floors = building_floors(raw, lut, scale, economies=economies)
    built = floors * np.asarray(envelope_area, dtype=np.float64)
    return LotEconomy(price, margin, demand, floors, np.asarray(floors * calibration.storey_height, dtype=np.float64),
                      occupants(np.asarray(built, dtype=np.float64), area, lut, economies=economies), scale, raw)


# --------------------------------------------------------------------------- substitution (002 §5.4)

def substitution_probability(age: NDArray[np.float64], new_floor_space: NDArray[np.float64],
                             floor_space: NDArray[np.float64], *,
                             options: EconomyOptions = EconomyOptions()) -> NDArray[np.float64]:
    """Yearly replacement probability ``p_sub = f₁(age) + f₂(Δprice)`` (002 §5.4), clipped to [0, 1].

    002's ``Δprice = (price − floorspace / margin) / price`` compares the price
    a new building would fetch with the price the existing one pays for. With
    floor space = price · margin (Eq. 10) that is ``1 − existing floor space /
    new floor space``; computed on the floor space the buildings really have
    (this year's :class:`LotEconomy` for the new one, through the same
    :class:`HeightScale`), a brand-new building is never "worth" more or less
    than itself whatever the calibration scale.

    Parameters
    ----------
    age : ndarray, shape (L,)
        Building age (years); NaN (unknown, e.g. a real OSM building) gives
        ``f₁ = 0``.
    new_floor_space : ndarray, shape (L,)
        Floor space (m²) of the building this year's economy would put on the
        lot (``LotEconomy.floors × envelope area``; 0 for a park: Δprice = 1).
    floor_space : ndarray, shape (L,)
        Floor space (m²) of the existing building.

    Returns
    -------
    ndarray, shape (L,)
        ``f₁ = age_weight · valuate(age_kind, age, *age_bounds)``,
        ``f₂ = price_weight · valuate(price_kind, Δprice, *price_bounds)``.
    """
    age = np.asarray(age, dtype=np.float64)
    new = np.asarray(new_floor_space, dtype=np.float64)
    fs = np.asarray(floor_space, dtype=np.float64)
    gap = np.divide(new - fs, new, out=np.ones_like(new), where=new > 0)
    f1 = options.age_weight * valuate(options.age_kind, age, *options.age_bounds)
    f2 = options.price_weight * valuate(options.price_kind, gap, *options.price_bounds)
    return np.clip(f1 + f2, 0.0, 1.0)


@dataclass(frozen=True)
class Substitution:
    """Which buildings are replaced this year (L,) bool, the new build years (L,), and p_sub (L,)."""

    replaced: NDArray[np.bool_]
    year_built: NDArray[np.float64]
    probability: NDArray[np.float64]


def substitute(year_built: NDArray[np.float64], new_floor_space: NDArray[np.float64],
               floor_space: NDArray[np.float64], *, year: int, rng: np.random.Generator,
               options: EconomyOptions = EconomyOptions()) -> Substitution:
    """Sample this year's building replacements (002 §5.4).

    Parameters
    ----------
    year_built : ndarray, shape (L,)
        Year each lot's building was built; NaN for an unknown year (no age
        term). Lots with ``floor_space = 0`` have no building and are skipped.
    new_floor_space, floor_space
        As in :func:`substitution_probability`.
    year : int
        The current year; a replacement gets it.
    rng : numpy.random.Generator
        One uniform draw per lot.

    Returns
    -------
    Substitution
        The caller builds the new building from this year's
        :func:`lot_economy` on the replaced lots (0 floors: demolished).
    """
    built = np.asarray(year_built, dtype=np.float64)
    fs = np.asarray(floor_space, dtype=np.float64)
    p = substitution_probability(year - built, new_floor_space, fs, options=options)
    p = np.where(fs > 0, p, 0.0)
    replaced = rng.random(len(p)) < p
    return Substitution(replaced, np.where(replaced, float(year), built), p)
