"""The main command's options, declared once: flags, types, choices and help (:data:`EXPAND_ARGUMENTS`).

The command line's parser adds them with :func:`add_arguments`; ``batch`` adds the same
table to its own parser as text (passed to every job), without reaching into argparse's internals.
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from osm_expand.app.files import FORMAT_SUFFIX

if TYPE_CHECKING:
    pass

PROG = "osm-expand"


def _whole_number(text: str, subject: str, unit: str) -> int:
    """``text`` as a whole number, 0 or more; argparse's one-line refusal otherwise (``subject`` starts it)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{subject}must be a whole number{unit}, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{subject}must be 0 or more, got {value}")
    return value


def seed_value(text: str) -> int:
    """``--seed``: a whole number, 0 or more (argparse's ``type``)."""
    return _whole_number(text, "--seed ", "")


def years_value(text: str) -> int:
    """``--years`` and ``--snapshot-every``: a whole number of years, 0 or more (argparse's ``type``)."""
    return _whole_number(text, "", " of years")


@dataclass(frozen=True)
class Argument:
    """One option of the main command, as ``parser.add_argument(*flags, **options)`` takes it.

    ``group`` names an argument group (its title), ``exclusive`` a mutually
    exclusive group (options with the same name share one).
    """

    flags: tuple[str, ...]
    options: dict[str, Any] = field(default_factory=dict)
    group: str | None = None
    exclusive: str | None = None

    @property
    def dest(self) -> str:
        """The attribute argparse stores the value in."""
        return self.options.get("dest") or self.flags[-1].lstrip("-").replace("-", "_")

    @property
    def flag(self) -> str:
        """The long flag (what ``batch`` passes to its jobs)."""
        return self.flags[-1]

    @property
    def takes_value(self) -> bool:
        return self.options.get("action") not in ("store_true", "store_false")


_CLIP_GROUP = "a town out of a large file (clipped at read time; docs/batch.md)"

#: The options that choose what is read (the sub-commands take them too).
INPUT_ARGUMENTS: tuple[Argument, ...] = (
    Argument(("--service",), {"action": "store_true", "help": "also keep highway=service roads"}),
    Argument(("--paths",), {"action": "store_true", "help": "also keep footways, paths, tracks and cycleways"}),
)

#: Reading a town out of a large file (``simplify`` takes them too).
CLIP_ARGUMENTS: tuple[Argument, ...] = (
    Argument(("--bbox",), {"metavar": "W,S,E,N",
                           "help": "read only this box, degrees (ways crossing its edge kept whole)"}, _CLIP_GROUP),
    Argument(("--around",), {"metavar": "LON,LAT",
                             "help": "read only the box around this point, degrees (with --radius)"}, _CLIP_GROUP),
    Argument(("--radius",), {"type": float, "metavar": "M",
                             "help": "with --around: metres from the point to the box's sides"}, _CLIP_GROUP),
    Argument(("--clip-index",), {"metavar": "INDEX",
                                 "help": "clip in one read with this node-location index (flex_mem, "
                                         "sparse_file_array,PATH, ...) instead of two reads with a node store on "
                                         "disk beside the output"}, _CLIP_GROUP),
)


#: The main command's options after the input's, in the order ``--help`` lists them. ``batch`` passes all
#: but ``--output``, ``--seed`` and ``--preview`` (which it sets per job) to every job.
EXPAND_ARGUMENTS: tuple[Argument, ...] = (
    *INPUT_ARGUMENTS,
    *CLIP_ARGUMENTS,
    Argument(("-o", "--output"), {"help": "output file: .xml (urbanenvironment), .osm or .geojson "
                                          "(default: CITY.expanded.xml beside the input)"}),
    Argument(("--format",), {"choices": sorted(FORMAT_SUFFIX),
                             "help": "output format (default: from -o, else urbanenvironment)"}),
    Argument(("--preview",), {"metavar": "OUT.png|OUT.svg", "help": "also draw a map of the result"}),
    Argument(("--preview-frame",), {"choices": ["town", "all"], "default": "town",
                                    "help": "what the preview frames: the town and what grew (default) or the "
                                            "whole map"}),
    Argument(("--seed",), {"type": seed_value, "default": 0,
                           "help": "random seed (0 or more); the same seed gives the same bytes"}),
    Argument(("--direction",), {"choices": ["auto", "N", "NE", "E", "SE", "S", "SW", "W", "NW"], "default": "auto",
                                "help": "grow on this side of the town (default: the best site anywhere)"}),
    Argument(("--at",), {"metavar": "X,Y", "help": "site centre in metres of the local projection"}),
    Argument(("--at-lonlat",), {"metavar": "LON,LAT", "help": "site centre in degrees (longitude first)"}),
    Argument(("--area",), {"type": float, "metavar": "M2",
                           "help": "district area in m² (default: a quarter of the built-up area, at most a "
                                   "neighbourhood unit of 0.65 km², at least nine blocks; at most four times the "
                                   "built-up area)"}),
    Argument(("--pattern",), {"default": "example"}),  # choices and help: osm_expand.growth_patterns
    Argument(("--beyond-bounds",), {"action": "store_true", "default": None,
                                    "help": "let the district grow outside the map's bounds (land there is "
                                            "unknown; by default only when the town fills its map)"},
             exclusive="bounds"),
    Argument(("--within-bounds",), {"dest": "beyond_bounds", "action": "store_false",
                                    "help": "never grow outside the map's bounds: refuse when the town fills its "
                                            "map"}, exclusive="bounds"),
    Argument(("--unbuildable",), {"metavar": "KEY=VALUE,...",
                                  "help": "mapped areas nobody may build on, replacing the default list "
                                          "(landuse=cemetery,leisure=park,aeroway=*,...; '' for none)"}),
    Argument(("--history",), {"metavar": "NAME|FILE", "default": "example",
                              "help": "the history the city then lives through: a bundled one (example, european, "
                                      "north-american) or a TOML file (docs/histories.md); default: example"}),
    Argument(("--years",), {"type": years_value, "metavar": "N",
                            "help": "years of history to simulate (default: the history's own, 30 for example; "
                                    "0 grows the district only)"}),
    Argument(("--snapshots",), {"metavar": "DIR",
                                "help": "also draw the city at the end of each era (traffic green to red) into "
                                        "DIR"}),
    Argument(("--snapshot-every",), {"type": years_value, "metavar": "N",
                                     "help": "with --snapshots: a picture every N years instead of one per era"}),
    Argument(("--debug-layers",), {"action": "store_true",
                                   "help": "with a .geojson output: add the growth pattern's working layers "
                                           "(colonisation: attraction points, flow field and its primitives, "
                                           "region, parameters)"}),
)


def _resolved(arg: Argument) -> dict[str, Any]:
    """An argument's options, the growth patterns' choices and help filled in from their registry."""
    if arg.flag != "--pattern":
        return dict(arg.options)
    from osm_expand.growth_patterns import PATTERN_NAMES, pattern_help

    return {**arg.options, "choices": list(PATTERN_NAMES), "help": pattern_help()}


def add_arguments(parser: Any, arguments: Sequence[Argument], *, as_text: bool = False,
                  dest_prefix: str = "") -> list[Argument]:
    """Add ``arguments`` to ``parser`` (their groups made once); the arguments added, in order.

    Parameters
    ----------
    parser : argparse.ArgumentParser or an argument group of one
        Where to add them.
    arguments : sequence of Argument
        Which options, e.g. :data:`EXPAND_ARGUMENTS`.
    as_text : bool
        ``batch``'s way: every value kept as the text given (no ``type``; the
        choices still checked), flags as ``store_true``, no defaults (an option
        not given is absent from the namespace), and no exclusive groups: the
        jobs' own parsing checks them, once, before the first job.
    dest_prefix : str
        Prepended to each destination, one per flag (``--beyond-bounds`` and
        ``--within-bounds`` share one destination in the main command).
    """
    groups: dict[str, Any] = {}
    for arg in arguments:
        options = _resolved(arg)
        target: Any = parser
        if as_text:
            options = {"dest": dest_prefix + arg.flag.lstrip("-").replace("-", "_"), "help": options.get("help"),
                       "default": argparse.SUPPRESS,
                       **({"metavar": options.get("metavar") or arg.dest.upper(), "choices": options.get("choices")}
                          if arg.takes_value else {"action": "store_true"})}
        else:
            if arg.group is not None:
                target = groups.setdefault(arg.group, parser.add_argument_group(arg.group))
            if arg.exclusive is not None:
                target = groups.setdefault("exclusive:" + arg.exclusive, parser.add_mutually_exclusive_group())
            if dest_prefix:
                options["dest"] = dest_prefix + arg.dest
        target.add_argument(*arg.flags, **options)
    return list(arguments)
