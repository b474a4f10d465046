"""Capture the engine's build-out and traffic calls of one run, then replay them: CPU per year, same outputs.

    PYTHONPATH=. python benchmarks/stage_replay.py capture OUT.pkl -- FILE -o X.xml --seed 0 -q
    PYTHONPATH=. python benchmarks/stage_replay.py replay OUT.pkl [--stage buildout|traffic|both] [--no-check] [--steps]

``capture`` runs ``osm-expand`` with the given arguments and pickles every
``buildout_year`` and ``traffic_year`` call of the engine (inputs, outputs,
the random streams' states before and after), all years in one pickle so
that objects the years share stay shared (the build-out's memos key on
identity). Campo Grande's default run: 30 years, a 330 MB file, 80 s of CPU.

``replay`` runs the calls again with this checkout's code and prints each
year's CPU seconds and whether every output equals the captured one (lots,
buildings, blocks, the memories field by field, reports, random states; the
caches ``memo``, trees and the trip graph are not compared). Traffic years
run from their captured inputs; build-out years chain their own memory, with
this run's lots, buildings and blocks put where the captured next year had
last year's (as the loop hands them on). A change meant to keep the bytes
must print ``same`` for every year; it takes 15 s instead of a whole run.
The CPU seconds of a loaded machine drift by ±5 %: compare runs back to back.
"""
from __future__ import annotations

import argparse
import copyreg
import dataclasses
import gc
import pickle
import sys
import time
import types
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from scipy import sparse

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # this checkout's packages


def _proxy(d: dict) -> types.MappingProxyType:
    return types.MappingProxyType(d)


copyreg.pickle(types.MappingProxyType, lambda m: (_proxy, (dict(m),)))  # the engine's streams and options

#: Fields left out of the comparison: caches that never decide a result (the memo's entries are each
#: checked against what they were made from; the build-out's ``signature`` does decide, and is compared).
SKIP = {"memo", "graph", "no_build_tree", "outline_tree", "people", "tree"}


def capture(out: Path, args: list[str]) -> None:
    import osm_expand.engine.loop as loop
    from osm_expand.cli import main

    calls: dict[str, list] = {"buildout": [], "traffic": []}
    cpu = {"buildout": 0.0, "traffic": 0.0}
    buildout_year, traffic_year = loop.buildout_year, loop.traffic_year

    def buildout(city, memory, history, now, rng, *, year, traffic):
        state, t = rng.bit_generator.state, time.process_time()
        result = buildout_year(city, memory, history, now, rng, year=year, traffic=traffic)
        cpu["buildout"] += time.process_time() - t
        calls["buildout"].append(dict(city=city, memory=memory, history=history, now=now, rng=state, year=year,
                                      traffic=dict(traffic), out=result, rng_after=rng.bit_generator.state))
        return result

    def trips(city, memory, rng, *, year, increase, o2, options):
        state, t = rng.bit_generator.state, time.process_time()
        result = traffic_year(city, memory, rng, year=year, increase=increase, o2=o2, options=options)
        cpu["traffic"] += time.process_time() - t
        calls["traffic"].append(dict(city=city, memory=memory, rng=state, year=year, increase=increase, o2=o2,
                                     options=options, out=result, rng_after=rng.bit_generator.state))
        return result

    loop.buildout_year, loop.traffic_year = buildout, trips
    main(args)
    print(f"captured {len(calls['buildout'])} build-out and {len(calls['traffic'])} traffic years; CPU "
          f"build-out {cpu['buildout']:.2f} s, traffic {cpu['traffic']:.2f} s")
    with open(out, "wb") as f:
        pickle.dump(calls, f, protocol=5)


def diff(a: Any, b: Any, path: str = "") -> str | None:
    """Where ``a`` and ``b`` first differ, or None."""
    if a is b:
        return None
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.dtype == object and b.dtype == object and a.shape == b.shape:
            return next((d for i, (x, y) in enumerate(zip(a.ravel().tolist(), b.ravel().tolist()))
                         if (d := diff(x, y, f"{path}[{i}]"))), None)
        same = a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        return None if same else f"{path}: arrays"
    if sparse.issparse(a):
        a, b = a.tocsr(), b.tocsr()
        a.sort_indices()
        b.sort_indices()
        same = a.shape == b.shape and all(np.array_equal(getattr(a, k), getattr(b, k))
                                          for k in ("indptr", "indices", "data"))
        return None if same else f"{path}: sparse"
    if isinstance(a, shapely.Geometry):
        same = isinstance(b, shapely.Geometry) and shapely.to_wkb(a) == shapely.to_wkb(b)
        return None if same else f"{path}: geometry"
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        if type(a) is not type(b):
            return f"{path}: {type(a).__name__} vs {type(b).__name__}"
        return next((d for f in dataclasses.fields(a) if f.name not in SKIP
                     if (d := diff(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}"))), None)
    if isinstance(a, dict):
        if not isinstance(b, dict) or list(a) != list(b):
            return f"{path}: keys"
        return next((d for k in a if (d := diff(a[k], b[k], f"{path}[{k!r}]"))), None)
    if isinstance(a, (list, tuple)):
        if type(a) is not type(b) or len(a) != len(b):
            return f"{path}: length or type"
        return next((d for i, (x, y) in enumerate(zip(a, b)) if (d := diff(x, y, f"{path}[{i}]"))), None)
    if isinstance(a, float) and isinstance(b, float) and np.isnan(a) and np.isnan(b):
        return None
    return None if a == b else f"{path}: {a!r} != {b!r}"


def _rng(state: dict) -> np.random.Generator:
    rng = np.random.default_rng()
    rng.bit_generator.state = state
    return rng


#: The build-out year's steps (names in :mod:`osm_expand.engine.buildout.year`) that ``--steps`` times.
STEPS = ("_streets", "_demolish", "_build_out_blocks", "_land_use", "_substitute", "_build", "_result")


def _timed_steps() -> dict[str, float]:
    """Wrap the build-out year's steps so that each adds its CPU seconds to the dict returned."""
    import osm_expand.engine.buildout.year as year

    spent = dict.fromkeys(STEPS, 0.0)

    def timer(name: str, step: Any) -> Any:
        def timed(*args: Any, **kwargs: Any) -> Any:
            t = time.process_time()
            try:
                return step(*args, **kwargs)
            finally:
                spent[name] += time.process_time() - t
        return timed

    for name in STEPS:
        setattr(year, name, timer(name, getattr(year, name)))
    return spent


def replay(path: Path, stage: str, check: bool, steps: bool = False) -> None:
    step_cpu = _timed_steps() if steps else None
    from osm_expand.engine.buildout.year import buildout_year
    from osm_expand.engine.traffic.simulation import traffic_year

    with open(path, "rb") as f:
        calls = pickle.load(f)
    gc.disable()  # as the command runs (osm_expand.gcpause)
    if stage in ("traffic", "both"):
        total = 0.0
        for c in calls["traffic"]:
            rng = _rng(c["rng"])
            t = time.process_time()
            out = traffic_year(c["city"], c["memory"], rng, year=c["year"], increase=c["increase"], o2=c["o2"],
                               options=c["options"])
            total += time.process_time() - t
            verdict = (diff(out[0].network, c["out"][0].network, "network") or diff(out[1], c["out"][1], "memory")
                       or diff(out[2], c["out"][2], "report") or diff(out[3], c["out"][3], "short")
                       or diff(rng.bit_generator.state, c["rng_after"], "rng") or "same") if check else ""
            print(f"traffic {c['year']}: {time.process_time() - t:.3f} s CPU {verdict}", flush=True)
        print(f"traffic: {total:.2f} s CPU")
    if stage in ("buildout", "both"):
        total = 0.0
        memory, mine, theirs = calls["buildout"][0]["memory"], None, None
        for c in calls["buildout"]:
            city = c["city"]
            if mine is not None:  # this replay's lots, buildings and blocks where the captured year had its own
                swap = {id(x): y for name in ("lots", "buildings", "blocks")
                        for x, y in zip(getattr(theirs, name), getattr(mine, name))}
                city = city.replace(**{name: getattr(mine, name) if getattr(city, name) is getattr(theirs, name)
                                       else tuple(swap.get(id(x), x) for x in getattr(city, name))
                                       for name in ("lots", "buildings", "blocks")})
            rng = _rng(c["rng"])
            t = time.process_time()
            out = buildout_year(city, memory, c["history"], c["now"], rng, year=c["year"], traffic=c["traffic"])
            spent = time.process_time() - t
            total += spent
            verdict = (diff(out[0].lots, c["out"][0].lots, "lots")
                       or diff(out[0].buildings, c["out"][0].buildings, "buildings")
                       or diff(out[0].blocks, c["out"][0].blocks, "blocks") or diff(out[1], c["out"][1], "memory")
                       or diff(out[2], c["out"][2], "report")
                       or diff(rng.bit_generator.state, c["rng_after"], "rng") or "same") if check else ""
            print(f"build-out {c['year']}: {spent:.3f} s CPU {verdict}", flush=True)
            memory, mine, theirs = out[1], out[0], c["out"][0]
        print(f"build-out: {total:.2f} s CPU")
        if step_cpu is not None:
            print("build-out steps (CPU s): " + ", ".join(f"{k} {v:.2f}" for k, v in step_cpu.items()))


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    rest = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=["capture", "replay"])
    parser.add_argument("pickle", type=Path)
    parser.add_argument("--stage", choices=["buildout", "traffic", "both"], default="both")
    parser.add_argument("--no-check", action="store_true", help="time only")
    parser.add_argument("--steps", action="store_true", help="also the build-out's CPU per step, over all years")
    args = parser.parse_args(argv)
    if args.command == "capture":
        capture(args.pickle, rest)
    else:
        replay(args.pickle, args.stage, not args.no_check, steps=args.steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
