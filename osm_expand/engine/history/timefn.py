"""Time functions of a history: sampled (year, value) points (seed 000 appendix A.4).

000's configuration files define a function ``y = f(x)`` by a list of
``<sample x= y=>`` points, "discrete" or "continuous, where the values
between the end points are linearly interpolated". A history's G(t), t(t),
R(t) = (P, A, C1…C6) and avgprice(t) (003 §3.1, 002 table 1) are such
functions of the year:

- ``linear``: straight lines between consecutive points (000's continuous);
- ``step``: the value of the last point at or before the year, held until
  the next point (000's discrete samples, read as a piecewise constant
  function so that it is defined in every year — an era's value that holds
  until the next era changes it);

and both are **constant** before the first point (its value) and after the
last (its value): a history never extrapolates a trend beyond what it says.

In a TOML history a time function is written as

- a number: a constant, ``growth = 0.01``;
- a list of ``[year, value]`` pairs, linear: ``traffic = [[2000, 0], [2100, 1000]]``;
- a table: ``turn_height = { points = [[0, 30], [15, 150]], interpolation = "step" }``.

Years must increase strictly; every value must be a finite number.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from osm_expand.errors import InputError
from osm_expand.model.enums import parse_enum
from osm_expand.model.options import is_real_number

__all__ = ["Interpolation", "TimeFunction"]


class Interpolation(StrEnum):
    """How a time function runs between its points (000 appendix A.4: continuous or discrete)."""

    LINEAR = "linear"  #: straight lines between points
    STEP = "step"  #: the last point's value until the next point


def _number(value: Any, key: str) -> float:
    if not is_real_number(value):
        raise InputError(f"{key}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise InputError(f"{key}: expected a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class TimeFunction:
    """A function of the year from sampled points (000 appendix A.4).

    Attributes
    ----------
    years : tuple of float, shape (P,)
        Sample years, strictly increasing (P ≥ 1).
    values : tuple of float, shape (P,)
        The function's value at each sample year.
    interpolation : Interpolation
        ``linear`` or ``step`` between the points; constant outside them.

    Examples
    --------
    >>> f = TimeFunction((2000.0, 2010.0), (0.0, 10.0))
    >>> f(1990), f(2005), f(2020)
    (0.0, 5.0, 10.0)
    >>> TimeFunction((2000.0, 2010.0), (0.0, 10.0), Interpolation.STEP)([2009, 2010]).tolist()
    [0.0, 10.0]
    """

    years: tuple[float, ...]
    values: tuple[float, ...]
    interpolation: Interpolation = Interpolation.LINEAR

    def __post_init__(self) -> None:
        years = tuple(float(y) for y in self.years)
        values = tuple(float(v) for v in self.values)
        if not years or len(years) != len(values):
            raise InputError(f"time function: need as many values as years (at least one), "
                             f"got {len(years)} years and {len(values)} values")
        if not all(math.isfinite(x) for x in years + values):
            raise InputError("time function: years and values must be finite numbers")
        if any(b <= a for a, b in zip(years, years[1:])):
            raise InputError(f"time function: years must increase, got {list(years)}")
        kind = parse_enum(Interpolation, self.interpolation, "time function: interpolation")
        object.__setattr__(self, "years", years)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "interpolation", kind)

    @classmethod
    def constant(cls, value: float) -> TimeFunction:
        """The same ``value`` in every year."""
        return cls((0.0,), (float(value),))

    @overload
    def __call__(self, years: float) -> float: ...

    @overload
    def __call__(self, years: ArrayLike) -> NDArray[np.float64]: ...

    def __call__(self, years: ArrayLike) -> float | NDArray[np.float64]:
        """The function at ``years`` (a number → a float; an array → an array of the same shape).

        Parameters
        ----------
        years : float or array_like, any shape
            Years (fractional years allowed).

        Returns
        -------
        float or ndarray of float64
            ``linear``: ``numpy.interp`` over the points; ``step``: the value
            of the last point at or before each year; both the first value
            before the first point and the last value after the last point.
        """
        t = np.asarray(years, dtype=np.float64)
        xs = np.asarray(self.years)
        ys = np.asarray(self.values)
        if self.interpolation is Interpolation.LINEAR:
            out = np.interp(t, xs, ys)
        else:
            out = ys[np.clip(np.searchsorted(xs, t, side="right") - 1, 0, len(xs) - 1)]
        return float(out) if np.ndim(out) == 0 else np.asarray(out, dtype=np.float64)

    @property
    def low(self) -> float:
        """The smallest value the function takes (it never leaves its samples' range)."""
        return min(self.values)

    @property
    def high(self) -> float:
        """The largest value the function takes."""
        return max(self.values)

    def to_toml(self) -> Any:
        """The value as a history file writes it (a number, a list of pairs, or a table)."""
        if len(self.values) == 1:
            return self.values[0]
        points = [[y, v] for y, v in zip(self.years, self.values)]
        if self.interpolation is Interpolation.LINEAR:
            return points
        return {"points": points, "interpolation": self.interpolation.value}

    @classmethod
    def from_toml(cls, value: Any, key: str) -> TimeFunction:
        """A time function from a TOML value; errors name ``key``.

        Parameters
        ----------
        value : number, list of [year, value] pairs, or mapping
            A constant; linear points; or ``{points = [...], interpolation =
            "linear" | "step"}`` (``interpolation`` defaults to linear).
        key : str
            The value's key path in the file (e.g. ``"roads.costs.minor"``),
            used in error messages.

        Returns
        -------
        TimeFunction

        Raises
        ------
        InputError
            ``"<key>: <what is wrong>"``, or ``"<key>.points[i]: …"`` /
            ``"<key>[i]: …"`` for a bad point.
        """
        if isinstance(value, Mapping):
            unknown = sorted(set(value) - {"points", "interpolation"})
            if unknown:
                raise InputError(f"{key}.{unknown[0]}: unknown key (valid: points, interpolation)")
            if "points" not in value:
                raise InputError(f"{key}.points: missing (a list of [year, value] pairs)")
            kind = parse_enum(Interpolation, value.get("interpolation", Interpolation.LINEAR.value),
                              f"{key}.interpolation")
            return cls._from_points(value["points"], f"{key}.points", kind)
        if isinstance(value, (list, tuple)):
            return cls._from_points(value, key, Interpolation.LINEAR)
        if not is_real_number(value):
            raise InputError(f"{key}: expected a number, a list of [year, value] pairs or a table with "
                             f"points, got {value!r}")
        return cls.constant(_number(value, key))

    @classmethod
    def _from_points(cls, points: Any, key: str, kind: Interpolation) -> TimeFunction:
        if not isinstance(points, (list, tuple)) or not points:
            raise InputError(f"{key}: expected a non-empty list of [year, value] pairs, got {points!r}")
        years: list[float] = []
        values: list[float] = []
        for i, point in enumerate(points):
            where = f"{key}[{i}]"
            if not isinstance(point, Sequence) or isinstance(point, str) or len(point) != 2:
                raise InputError(f"{where}: expected a [year, value] pair, got {point!r}")
            year, value = _number(point[0], where), _number(point[1], where)
            if years and year <= years[-1]:
                raise InputError(f"{where}: years must increase, got {point[0]!r} after {points[i - 1][0]!r}")
            years.append(year)
            values.append(value)
        return cls(tuple(years), tuple(values), kind)
