"""Reading a history from TOML: the file format of ``docs/histories.md`` into a
:class:`~osm_expand.engine.history.model.History`.

Apart from the history model (:mod:`osm_expand.engine.history.model`): the
model holds eras, time functions and the clock; this reader knows the file,
its keys and every stage's options a history may set, and turns each
problem into one :class:`~osm_expand.errors.HistoryError` line
``FILE: key.path: what is wrong``. :func:`load_history` reads a bundled
history by name (``osm_expand/histories/*.toml``) or a file by path;
:func:`history_from_mapping` reads parsed TOML.
"""
from __future__ import annotations

import difflib
import math
import os
import tomllib
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import MISSING, asdict, fields, replace
from enum import StrEnum
from importlib import resources
from inspect import signature
from pathlib import Path
from types import MappingProxyType
from typing import Any, NoReturn

from osm_expand.engine.buildout.economy import DEFAULT_ECONOMY, TypeEconomy
from osm_expand.engine.buildout.footprints import DEFAULT_FOOTPRINT_OPTIONS, FootprintOptions
from osm_expand.engine.buildout.landuse_types import (
    DEFAULT_TYPES,
    Attribute,
    LandUseType,
    Valuation,
    ValuationTerm,
    types_from_config,
)
from osm_expand.engine.buildout.lots import DEFAULT_LOT_OPTIONS, LandUse, LotOptions
from osm_expand.engine.history.model import (
    DEFAULT_AVGPRICE,
    DEFAULT_GROWTH,
    DEFAULT_HISTORY,
    DEFAULT_TRAFFIC_RATE,
    DEFAULT_YEARS,
    GROWTH_PATTERNS,
    MAX_GROWTH,
    MAX_YEARS,
    Anchor,
    Era,
    History,
    KernelOptions,
    PatternSettings,
)
from osm_expand.engine.history.timefn import TimeFunction
from osm_expand.engine.roads.lattice import LatticeOptions
from osm_expand.engine.roads.path_graph import EdgeCosts
from osm_expand.engine.roads.road_types import RoadType
from osm_expand.engine.roads.routing import RoutingOptions, choose
from osm_expand.engine.traffic.trade import TradeOptions
from osm_expand.engine.traffic.trips import TripOptions
from osm_expand.errors import HistoryError, InputError
from osm_expand.model.enums import parse_enum
from osm_expand.model.options import field_default, is_real_number
from synth.patterns import PATTERNS

__all__ = ["MAX_HISTORY_BYTES", "bundled", "history_from_mapping", "load_history"]

#: Largest history file read, bytes: the bundled ones are under 10 kB; ``--history /dev/zero`` would
#: otherwise be read until memory runs out.
MAX_HISTORY_BYTES = 1 << 20

def _narrowest_major_road() -> float:
    """A(t) when not given: the narrowest major road the trip model builds (two lanes and sidewalks, 11 m)."""
    t = TripOptions()
    return t.major_min_lanes * t.lane_width + 2.0 * t.sidewalk_width


def _pattern_names() -> list[str]:
    return [*GROWTH_PATTERNS, *PATTERNS]


#: Fields of kernel options that the history sets elsewhere: field → the key that sets it.
_SET_ELSEWHERE: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "lattice": {"slope_weight": "coefficients.o1"},
    "trade": {"o2": "coefficients.o2"},
    "routing": {"turn_centre": "roads.turn_centre_deg", "turn_width": "roads.turn_width_deg",
                "turn_height": "roads.turn_height"},
})


# ============================================================================ reading


def bundled() -> list[str]:
    """Names of the bundled histories (``osm_expand/histories/*.toml``), sorted."""
    folder = resources.files("osm_expand").joinpath("histories")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_history(name_or_path: str | os.PathLike[str] = DEFAULT_HISTORY) -> History:
    """A history by bundled name (``example``, ``european``, ``north-american``) or TOML file path.

    Parameters
    ----------
    name_or_path : str or path
        A bundled name, or the path of a ``.toml`` file.

    Returns
    -------
    History

    Raises
    ------
    InputError
        One line ``FILE: key.path: what is wrong`` (``FILE`` is ``<name>.toml``
        for a bundled history, else the path as given): a missing file, bad
        TOML, a missing or unknown key, a wrong type or value.
    """
    text, label, source, stem = _read(name_or_path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise HistoryError(f"{label}: not valid TOML: {e}") from None
    return history_from_mapping(data, label=label, source=source, default_name=stem)


def _read(name_or_path: str | os.PathLike[str]) -> tuple[str, str, str, str]:
    """The file's text, its label for messages, its source and its stem."""
    given = os.fspath(name_or_path)
    if not given.strip():
        raise HistoryError(f"history {given!r}: give a bundled history ({', '.join(bundled())}) or a .toml file")
    if given in bundled():
        text = resources.files("osm_expand").joinpath("histories", f"{given}.toml").read_text(encoding="utf-8")
        return text, f"{given}.toml", f"bundled:{given}", given
    path = Path(given)
    if not path.exists():
        if path.suffix != ".toml" and os.sep not in given:
            raise HistoryError(f"history {given!r}: not a bundled history ({', '.join(bundled())}) "
                               "nor a .toml file")
        raise HistoryError(f"{given}: no such history file")
    if path.is_dir():
        raise HistoryError(f"{given}: is a directory, not a history file")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_HISTORY_BYTES + 1)
        if len(data) > MAX_HISTORY_BYTES:
            raise HistoryError(f"{given}: too large for a history file (more than {MAX_HISTORY_BYTES >> 20} MB)")
        return data.decode("utf-8-sig"), given, str(path), path.stem  # -sig: a BOM (Windows editors) is fine
    except UnicodeDecodeError:
        raise HistoryError(f"{given}: not a text file (UTF-8 TOML expected)") from None
    except OSError as e:
        raise HistoryError(f"{given}: cannot read: {e.strerror or e}") from None


def history_from_mapping(data: Mapping[str, Any], *, label: str = "<history>", source: str = "",
                         default_name: str = "history") -> History:
    """A :class:`History` from parsed TOML (``tomllib.loads``); errors start with ``label``.

    Parameters
    ----------
    data : mapping
        The file's top-level table.
    label : str
        The file's name for error messages.
    source : str
        Stored in :attr:`History.source`.
    default_name : str
        The name when the file gives none (the file's stem).

    Returns
    -------
    History
    """
    return _Reader(label).history(data, source=source or label, default_name=default_name)


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


#: Top-level keys of a history file.
_TOP = ("name", "description", "start", "anchor", "years", "rebuild_old_town", "growth", "traffic", "avgprice", "roads",
        "coefficients", "eras", "land_use", "lots", "buildings", "options")
_ROADS = ("width", "turn_centre_deg", "turn_width_deg", "turn_height", "costs")
_COEFFICIENTS = ("o1", "o2", "o3", "o4")
_ERA = ("name", "start", "description", "pattern", "pattern_options", "road_types", "land_use_interval")
#: Era keys that make up its definition (a recurring era repeats only name and start).
_ERA_DEFINITION = ("pattern", "pattern_options", "road_types", "land_use_interval", "description")
_LAND_USE = ("name", "goal", "lot_size", "terms", "economy")
#: An era's definition: pattern, options, road types, land-use interval, description.
_EraDefinition = tuple[str, PatternSettings, tuple[tuple[RoadType, float], ...], "int | None", str]


class _Reader:
    """Reads one history file's parsed TOML; every error is ``label: key.path: what is wrong``."""

    def __init__(self, label: str):
        self.label = label

    def fail(self, key: str, why: str) -> NoReturn:
        raise HistoryError(f"{self.label}: {key}: {why}")

    # ------------------------------------------------------------------ plain values

    def table(self, value: Any, key: str) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {value!r}")
        return value

    def known(self, table: Mapping[str, Any], key: str, valid: Iterable[str]) -> None:
        valid = list(valid)
        for name in table:
            if name not in valid:
                close = difflib.get_close_matches(name, valid, n=1)
                hint = f"did you mean {close[0]!r}?" if close else f"valid: {', '.join(valid)}"
                self.fail(_join(key, name), f"unknown key ({hint})")

    def integer(self, value: Any, key: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"expected a whole number, got {value!r}")
        return int(value)

    def boolean(self, value: Any, key: str) -> bool:
        if not isinstance(value, bool):
            self.fail(key, f"must be true or false, got {value!r}")
        return value

    def number(self, value: Any, key: str) -> float:
        if not is_real_number(value) or not math.isfinite(value):
            self.fail(key, f"expected a finite number, got {value!r}")
        return float(value)

    def text(self, value: Any, key: str) -> str:
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {value!r}")
        return value

    def choice(self, value: Any, key: str, kind: type[StrEnum]) -> Any:
        if not isinstance(value, str):  # a StrEnum takes only its text
            self.fail(key, f"expected one of {', '.join(m.value for m in kind)}, got {value!r}")
        return parse_enum(kind, value, f"{self.label}: {key}", error=HistoryError)

    def function(self, value: Any, key: str, *, low: float | None = None, strict: bool = False,
                 high: float | None = None) -> TimeFunction:
        try:
            fn = TimeFunction.from_toml(value, key)
        except InputError as e:
            raise HistoryError(f"{self.label}: {e}") from None
        if low is not None and (fn.low <= low if strict else fn.low < low):
            self.fail(key, f"values must be {'>' if strict else '≥'} {low:g}, got {fn.low:g}")
        if high is not None and fn.high > high:
            self.fail(key, f"values must be ≤ {high:g}, got {fn.high:g}")
        return fn

    # ------------------------------------------------------------------ options dataclasses

    def convert(self, value: Any, hint: Any, key: str) -> Any:
        """``value`` checked against a dataclass field's type (lists become tuples)."""
        origin = typing.get_origin(hint)
        if hint is float:
            return self.number(value, key)
        if hint is bool:
            if not isinstance(value, bool):
                self.fail(key, f"expected true or false, got {value!r}")
            return value
        if hint is int:
            return self.integer(value, key)
        if isinstance(hint, type) and issubclass(hint, StrEnum):
            return self.choice(value, key, hint)
        if hint is str:
            return self.text(value, key)
        if origin is tuple:
            args = typing.get_args(hint)
            if not isinstance(value, (list, tuple)):
                self.fail(key, f"expected a list, got {value!r}")
            if len(args) == 2 and args[1] is Ellipsis:
                return tuple(self.convert(v, args[0], f"{key}[{i}]") for i, v in enumerate(value))
            if len(value) != len(args):
                self.fail(key, f"expected a list of {len(args)} values, got {value!r}")
            return tuple(self.convert(v, a, f"{key}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
        if origin in (typing.Union, types.UnionType):
            for arg in typing.get_args(hint):
                if arg is type(None):
                    continue
                try:
                    return self.convert(value, arg, key)
                except InputError:
                    pass
            self.fail(key, f"{value!r} is not a {hint}")
        return value  # any other type: the kernel's own checks judge it

    def build(self, cls: type, value: Any, key: str, *, base: Any = None,
              elsewhere: Mapping[str, str] = MappingProxyType({}), fixed: Mapping[str, Any] = MappingProxyType({}),
              ) -> Any:
        """An options dataclass from a TOML table: ``base`` (or the class defaults) with the table's values.

        ``elsewhere`` names fields the history sets under another key;
        ``fixed`` fields are set by the reader, not the file.
        """
        table = self.table(value, key)
        names = [f.name for f in fields(cls) if f.init and f.name not in fixed]
        for name in table:
            if name in elsewhere:
                self.fail(_join(key, name), f"set by {elsewhere[name]}, not here")
        self.known(table, key, names)
        hints = typing.get_type_hints(cls)
        values = {n: self.convert(v, hints[n], _join(key, n)) for n, v in table.items()}
        if base is None:
            for f in fields(cls):
                if f.init and f.name not in values and f.name not in fixed and \
                        f.default is MISSING and f.default_factory is MISSING:
                    self.fail(_join(key, f.name), "missing")
        try:
            return cls(**fixed, **values) if base is None else replace(base, **fixed, **values)
        except InputError as e:
            self.fail(key, str(e))
        except (TypeError, ValueError) as e:
            self.fail(key, str(e))

    # ------------------------------------------------------------------ the file

    def history(self, data: Mapping[str, Any], *, source: str, default_name: str) -> History:
        self.known(data, "", _TOP)
        for required in ("start", "eras"):
            if required not in data:
                self.fail(required, "missing")
        start = self.integer(data["start"], "start")
        years = self.integer(data.get("years", DEFAULT_YEARS), "years")
        if not 0 <= years <= MAX_YEARS:
            self.fail("years", f"must be 0 to {MAX_YEARS}, got {years}")
        eras = self.eras(data["eras"])
        if start < eras[0].start:
            self.fail("start", f"{start} is before the first era (eras[0].start = {eras[0].start})")
        o = self.coefficients(data.get("coefficients", {}))
        options = self.kernel_options(data.get("options", {}))
        options = replace(options, lattice=self.checked("coefficients.o1", replace, options.lattice,
                                                        slope_weight=o["o1"]),
                          trade=self.checked("coefficients.o2", replace, options.trade, o2=o["o2"]))
        types_, economies = self.land_use(data.get("land_use"))
        default_traffic = [[start, 0.0], [start + 100, 100 * DEFAULT_TRAFFIC_RATE]]
        return History(
            name=self.text(data.get("name", default_name), "name"), source=source, start=start,
            anchor=self.choice(data.get("anchor", Anchor.MAP.value), "anchor", Anchor), years=years, eras=eras,
            growth=self.function(data.get("growth", DEFAULT_GROWTH), "growth", low=0.0, high=MAX_GROWTH),
            traffic=self.function(data.get("traffic", default_traffic), "traffic", low=0.0),
            avgprice=self.function(data.get("avgprice", DEFAULT_AVGPRICE), "avgprice", low=0.0, strict=True),
            **self.roads(data.get("roads", {}), options.routing),
            o1=o["o1"], o2=o["o2"], o3=o["o3"], o4=o["o4"], land_use_types=types_, economies=economies,
            lot_options=self.per_class(data.get("lots", {}), "lots", LotOptions, DEFAULT_LOT_OPTIONS),
            footprint_options=self.per_class(data.get("buildings", {}), "buildings", FootprintOptions,
                                             DEFAULT_FOOTPRINT_OPTIONS),
            options=options, description=self.text(data.get("description", ""), "description"),
            rebuild_old_town=self.boolean(data.get("rebuild_old_town", False), "rebuild_old_town"),
        )

    def checked(self, key: str, make: Any, *args: Any, **kwargs: Any) -> Any:
        """``make(*args, **kwargs)``, its InputError reported under ``key``."""
        try:
            return make(*args, **kwargs)
        except InputError as e:
            self.fail(key, str(e))

    def roads(self, value: Any, routing: RoutingOptions) -> dict[str, Any]:
        """R(t) = (P, A, C1…C6) (003 §3.4.2): History's road fields, defaults from the kernels."""
        roads = self.table(value, "roads")
        self.known(roads, "roads", _ROADS)
        turn = {name: self.function(roads.get(name, default), f"roads.{name}")
                for name, default in (("turn_centre_deg", math.degrees(routing.turn_centre)),
                                      ("turn_width_deg", math.degrees(routing.turn_width)),
                                      ("turn_height", routing.turn_height))}
        if not 0.0 <= turn["turn_centre_deg"].low <= turn["turn_centre_deg"].high <= 180.0:
            self.fail("roads.turn_centre_deg", "values must lie in [0, 180] degrees (180: straight on)")
        # the functions are linear or constant between their sample years, so the kernel's per-field
        # bounds hold in every year when they hold at those years
        for year in sorted({y for f in turn.values() for y in f.years}):
            self.checked(f"roads: in year {year:g}", replace, routing,
                         turn_centre=math.radians(turn["turn_centre_deg"](year)),
                         turn_width=math.radians(turn["turn_width_deg"](year)),
                         turn_height=turn["turn_height"](year))
        width = self.function(roads.get("width", _narrowest_major_road()), "roads.width", low=0.0, strict=True)
        return {**turn, "road_width": width, "costs": MappingProxyType(self.costs(roads.get("costs", {})))}

    def coefficients(self, value: Any) -> dict[str, float]:
        """O1…O4 (003 §3.1); defaults from the kernels that use them."""
        table = self.table(value, "coefficients")
        self.known(table, "coefficients", _COEFFICIENTS)
        defaults = {"o1": field_default(LatticeOptions, "slope_weight"), "o2": field_default(TradeOptions, "o2"),
                    "o3": signature(choose).parameters["o3"].default,
                    "o4": signature(choose).parameters["o4"].default}
        out = {k: self.number(table.get(k, d), f"coefficients.{k}") for k, d in defaults.items()}
        for k in ("o3", "o4"):
            if out[k] < 0:
                self.fail(f"coefficients.{k}", f"must be ≥ 0, got {out[k]:g}")
        return out

    def costs(self, value: Any) -> dict[str, TimeFunction]:
        """C1…C6 as time functions by :class:`EdgeCosts` field; each checked by the kernel at its sample years."""
        table = self.table(value, "roads.costs")
        names = [f.name for f in fields(EdgeCosts)]
        self.known(table, "roads.costs", names)
        out = {n: self.function(table.get(n, field_default(EdgeCosts, n)), f"roads.costs.{n}") for n in names}
        for n, fn in out.items():
            for v in (fn.low, fn.high):
                try:
                    EdgeCosts(**{n: v})
                except InputError as e:
                    self.fail(f"roads.costs.{n}", str(e))
        return out

    def kernel_options(self, value: Any) -> KernelOptions:
        table = self.table(value, "options")
        names = [f.name for f in fields(KernelOptions)]
        self.known(table, "options", names)
        hints = typing.get_type_hints(KernelOptions)
        built = {n: self.build(hints[n], v, f"options.{n}", elsewhere=_SET_ELSEWHERE.get(n, {}))
                 for n, v in table.items()}
        options = KernelOptions(**built)
        if options.land_use.update_interval < 1:  # LandUseOptions checks it only when the update runs
            self.fail("options.land_use.update_interval",
                      f"must be at least 1 year, got {options.land_use.update_interval}")
        return options

    def per_class(self, value: Any, key: str, cls: type, defaults: Mapping[LandUse, Any]) -> Mapping[LandUse, Any]:
        """Lot or building options per lot class (``[lots.<class>]``): the bundled ones with the file's values."""
        table = self.table(value, key)
        self.known(table, key, [u.value for u in LandUse])
        out = dict(defaults)
        for name, sub in table.items():
            out[LandUse(name)] = self.build(cls, sub, f"{key}.{name}", base=defaults.get(LandUse(name)))
        return MappingProxyType(out)

    # ------------------------------------------------------------------ eras

    def eras(self, value: Any) -> tuple[Era, ...]:
        if not isinstance(value, list) or not all(isinstance(e, Mapping) for e in value):
            self.fail("eras", "expected a list of tables ([[eras]])")
        if not value:
            self.fail("eras", "a history needs at least one era")
        definitions: dict[str, tuple[int, Mapping[str, Any]]] = {}
        for k, entry in enumerate(value):
            key = f"eras[{k}]"
            self.known(entry, key, _ERA)
            for required in ("name", "start"):
                if required not in entry:
                    self.fail(f"{key}.{required}", "missing")
            name = self.text(entry["name"], f"{key}.name")
            definition = {d: entry[d] for d in _ERA_DEFINITION if d in entry}
            if not definition:
                continue
            if name in definitions and definitions[name][1] != definition:
                self.fail(f"{key}.name", f"era {name!r} is already defined differently in "
                          f"eras[{definitions[name][0]}]; a recurring era gives only name and start")
            definitions.setdefault(name, (k, definition))
        made = {name: self.era_definition(definition, f"eras[{k}]") for name, (k, definition) in definitions.items()}
        starts: list[int] = []
        for k, entry in enumerate(value):
            start = self.integer(entry["start"], f"eras[{k}].start")
            if starts and start <= starts[-1]:
                self.fail(f"eras[{k}].start", f"{start} is not after eras[{k - 1}].start ({starts[-1]}): "
                          "eras are listed in time order, each starting in a later year")
            if entry["name"] not in made:
                self.fail(f"eras[{k}].pattern", f"missing (era {entry['name']!r} is defined nowhere in the file)")
            starts.append(start)
        eras = []
        for k, entry in enumerate(value):
            pattern, opts, road_types, interval, description = made[entry["name"]]
            eras.append(Era(name=entry["name"], start=starts[k], end=starts[k + 1] if k + 1 < len(starts) else None,
                            pattern=pattern, options=opts, road_types=road_types, land_use_interval=interval,
                            description=description))
        return tuple(eras)

    def era_definition(self, entry: Mapping[str, Any], key: str) -> _EraDefinition:
        """What an era is (000 §4.2.9): its pattern with options, road-type frequencies, land-use interval."""
        if "pattern" not in entry:
            self.fail(f"{key}.pattern", f"missing (one of {', '.join(_pattern_names())})")
        pattern = self.text(entry["pattern"], f"{key}.pattern")
        if pattern not in _pattern_names():
            self.fail(f"{key}.pattern", f"unknown pattern {pattern!r} (valid: {', '.join(_pattern_names())})")
        base = GROWTH_PATTERNS.get(pattern, PATTERNS.get(pattern))
        opts = self.build(type(base), entry.get("pattern_options", {}), f"{key}.pattern_options", base=base)
        if "road_types" not in entry:
            self.fail(f"{key}.road_types", f"missing (relative frequencies of {', '.join(t.value for t in RoadType)})")
        table = self.table(entry["road_types"], f"{key}.road_types")
        self.known(table, f"{key}.road_types", [t.value for t in RoadType])
        road_types = tuple((RoadType(n), self.number(w, f"{key}.road_types.{n}")) for n, w in table.items())
        if any(w < 0 for _, w in road_types) or sum(w for _, w in road_types) <= 0:
            self.fail(f"{key}.road_types", "frequencies must be ≥ 0 with at least one positive")
        interval = None
        if "land_use_interval" in entry:
            interval = self.integer(entry["land_use_interval"], f"{key}.land_use_interval")
            if interval < 1:
                self.fail(f"{key}.land_use_interval", f"must be at least 1 year, got {interval}")
        description = self.text(entry.get("description", ""), f"{key}.description")
        return pattern, opts, road_types, interval, description

    # ------------------------------------------------------------------ land use

    def land_use(self, value: Any) -> tuple[tuple[LandUseType, ...], tuple[TypeEconomy, ...]]:
        """002 §4's types (``[[land_use]]``): a type named like a bundled one may omit what it keeps."""
        if value is None:
            return DEFAULT_TYPES, tuple(_economy_of(t.name, t.lot_size_key) for t in DEFAULT_TYPES)
        if not isinstance(value, list) or not all(isinstance(e, Mapping) for e in value) or not value:
            self.fail("land_use", "expected a non-empty list of tables ([[land_use]])")
        bundled_types = {t.name: t for t in DEFAULT_TYPES}
        entries: list[dict[str, Any]] = []
        economies: list[TypeEconomy] = []
        seen: dict[str, int] = {}
        for k, entry in enumerate(value):
            key = f"land_use[{k}]"
            self.known(entry, key, _LAND_USE)
            if "name" not in entry:
                self.fail(f"{key}.name", "missing")
            name = self.text(entry["name"], f"{key}.name")
            if name in seen:
                self.fail(f"{key}.name", f"type {name!r} is already defined in land_use[{seen[name]}]")
            seen[name] = k
            known = bundled_types.get(name)
            for required in ("goal", "terms"):
                if known is None and required not in entry:
                    self.fail(f"{key}.{required}", f"missing (needed for a type that is not bundled: "
                              f"{', '.join(bundled_types)})")
            # below, known is None only where the entry has the key: fail() refused the rest just above
            goal = self.number(entry["goal"], f"{key}.goal") if "goal" in entry else known.goal  # type: ignore[union-attr]
            if goal < 0:
                self.fail(f"{key}.goal", f"must be ≥ 0 (a share of lot area), got {goal:g}")
            lot_size = self.text(entry.get("lot_size", known.lot_size if known else ""), f"{key}.lot_size")
            if (lot_size or name) not in {u.value for u in LandUse}:
                self.fail(f"{key}.lot_size", f"{lot_size or name!r} is not a lot class (valid: "
                          f"{', '.join(u.value for u in LandUse)}); a new type names the class it is built like")
            terms = self.terms(entry["terms"], f"{key}.terms") if "terms" in entry else known.terms  # type: ignore[union-attr]
            entries.append({"name": name, "goal": goal, "lot_size": lot_size,
                            "terms": [asdict(t) for t in terms]})
            base = _economy_of(name, lot_size or name)
            economies.append(self.build(TypeEconomy, entry.get("economy", {}), f"{key}.economy", base=base,
                                        fixed={"name": name}))
        names = [e["name"] for e in entries]
        for k, e in enumerate(entries):
            for j, t in enumerate(e["terms"]):
                if t["attribute"] == Attribute.INFLUENCE.value and t["of_type"] not in names:
                    where = f"land_use[{k}].terms[{j}].of_type" if "terms" in value[k] else f"land_use[{k}].name"
                    why = "" if "terms" in value[k] else f"the bundled terms of {e['name']!r} weigh it; "
                    self.fail(where, f"{why}type {t['of_type']!r} is not defined (types: {', '.join(names)})")
        try:
            types_ = types_from_config(entries)
        except InputError as e:
            raise HistoryError(f"{self.label}: {e}") from None
        return types_, tuple(economies)

    def terms(self, value: Any, key: str) -> tuple[ValuationTerm, ...]:
        if not isinstance(value, list) or not all(isinstance(t, Mapping) for t in value):
            self.fail(key, "expected a list of tables ([[land_use.terms]])")
        out = []
        for j, t in enumerate(value):
            where = f"{key}[{j}]"
            term = self.build(ValuationTerm, t, where)
            self.choice(term.kind, f"{where}.kind", Valuation)
            self.choice(term.attribute, f"{where}.attribute", Attribute)
            out.append(term)
        return tuple(out)


def _economy_of(name: str, lot_class: str) -> TypeEconomy:
    """The bundled economy of a type: by its name, else by its lot class, renamed."""
    by_name = {e.name: e for e in DEFAULT_ECONOMY}
    return replace(by_name.get(name) or by_name[lot_class], name=name)

