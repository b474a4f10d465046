"""Capture the major roads' ``find_route`` calls of one run, then replay them: CPU, states searched, same route.

    PYTHONPATH=. python benchmarks/route_replay.py capture DIR -- FILE -o X.xml --seed 0 -q
    PYTHONPATH=. python benchmarks/route_replay.py replay DIR [--modes base,def] [--calls 0 5 15] [--carry]

``capture`` runs ``osm-expand`` with the given arguments and pickles each
``routing.find_route`` call (the path graph, source, target and keywords) to
``DIR/callNNN.pkl`` and its route and CPU seconds to ``DIR/resNNN.pkl``.
Campo Grande's default run: 36 calls (session 35's ``/tmp/h35w/calls``).

``replay`` runs each captured call again with this checkout's code, once per
mode, in one process, and prints per call and in total: the CPU seconds of the
call, whether the route equals the captured one field by field (vertices,
xy, kinds, segments, lengths, weights, turn cost), the states the route
search (A* with scipy's tie rule) reached, summed over its tile rounds, its
CPU seconds, the turns' bound T (``RoutingOptions.turn_bound``): its CPU,
searches and states, and the windows' exits' searches (``routing._exit_arrivals``):
their CPU, how many and how many stopped early where what they had found
settled the next window (``routing._Growth.settles``). The modes set the call's
``RoutingOptions``:

- ``base``: ``turn_bound=0`` (no T: the plain distance alone bounds the search);
- ``def``: ``turn_bound`` and ``turn_share`` at their defaults;
- ``sNN``: T over any region (``turn_bound=10**9``) with ``turn_share=NN/100``;
- ``whole``: T over any region, its corridor searched whole (``turn_share=1``).

With ``--carry`` each call takes over the map tables the last one made (its lattice's
``Lattice.handed_on``, as ``with_built_up`` hands them from one B to the next in the command)
where its B holds the last one's, instead of the tables its pickle caught: the map's directed
table (session 43) is made once per run in the command, where each call made it again without.

The CPU seconds of a loaded machine drift by ±5 %: compare modes of one run.
Session 40's numbers in ``RoutingOptions.turn_bound``'s and ``turn_share``'s
comments were taken by this script (then ``/tmp/h40t/replay.py``).
"""
from __future__ import annotations

import argparse
import dataclasses
import pickle
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import shapely

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # this checkout's packages

import osm_expand.engine.roads.expanded_search as es  # noqa: E402
import osm_expand.engine.roads.road_types as road_types  # noqa: E402
import osm_expand.engine.roads.routing as routing  # noqa: E402

ROUTE_FIELDS = ("vertices", "xy", "kind", "segment", "edge_length", "edge_weight")


def capture(out: Path, argv: list[str]) -> int:
    """Run the command ``argv`` with every ``find_route`` call pickled to ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    original = routing.find_route
    calls = [0]

    def kept(graph: Any, source: int, target: int, **kw: Any) -> Any:
        i = calls[0]
        calls[0] += 1
        with open(out / f"call{i:03d}.pkl", "wb") as f:
            pickle.dump((graph, source, target, kw), f, protocol=5)
        t0 = time.process_time()
        route = original(graph, source, target, **kw)
        dt = time.process_time() - t0
        with open(out / f"res{i:03d}.pkl", "wb") as f:
            pickle.dump((route, dt), f, protocol=5)
        print(f"find_route {i}: {dt:.2f} s CPU", file=sys.stderr)
        return route

    routing.find_route = kept
    road_types.find_route = kept
    from osm_expand.cli import main
    return int(main(argv) or 0)


def _options(base: routing.RoutingOptions, mode: str) -> routing.RoutingOptions:
    """The call's options in ``mode`` (the module docstring's list)."""
    if mode == "base":
        return dataclasses.replace(base, turn_bound=0)
    if mode == "def":
        default = routing.RoutingOptions()
        return dataclasses.replace(base, turn_bound=default.turn_bound, turn_share=default.turn_share)
    if mode == "whole":
        return dataclasses.replace(base, turn_bound=10**9, turn_share=1.0)
    if mode[0] == "s" and mode[1:].isdigit():
        return dataclasses.replace(base, turn_bound=10**9, turn_share=int(mode[1:]) / 100)
    raise SystemExit(f"unknown mode {mode!r}: base, def, whole or sNN")


def _carried(last: Any, lattice: Any) -> None:
    """``lattice`` takes over the map tables ``last`` made (``--carry``), as the command's
    ``with_built_up`` hands them on, where it is the same map with a B that holds last's."""
    if (not hasattr(last, "handed_on") or last.full_shape != lattice.full_shape
            or last.built_up.shape != lattice.built_up.shape or (last.built_up & ~lattice.built_up).any()):
        return
    tables = last.handed_on(lattice.built_up & ~last.built_up)
    if "directed" in tables:  # it replaced the unit edges in the command
        lattice._shared.pop("live", None)
    lattice._shared.update(tables)


def replay(folder: Path, modes: list[str], calls: list[int], carry: bool = False) -> None:
    """Each captured call of ``folder`` again per mode: one line a call, then the totals; with ``carry``
    each call takes over the last one's map tables (:func:`_carried`)."""
    count: dict[str, float] = {}
    search = es.expanded_dijkstra
    turns = routing._turns_to_go

    def counted(graph: Any, start: int, limit: float, *args: Any, **kw: Any) -> Any:
        resume = kw.get("resume")
        before = int(np.isfinite(resume.dist).sum()) if resume is not None else 0
        t0 = time.process_time()
        dist, pred = search(graph, start, limit, *args, **kw)
        if kw.get("ties"):
            count["states"] += int(np.isfinite(dist).sum()) - before
            count["search"] += time.process_time() - t0
        return dist, pred

    def timed(*args: Any, **kw: Any) -> np.ndarray:
        t0 = time.process_time()
        T = turns(*args, **kw)
        count["T"] += time.process_time() - t0
        count["Tn"] += 1
        count["Tsize"] += T.size
        return T

    arrivals, settles = routing._exit_arrivals, routing._Growth.settles

    def exits_timed(*args: Any, **kw: Any) -> np.ndarray:
        t0 = time.process_time()
        out = arrivals(*args, **kw)
        count["exits"] += time.process_time() - t0
        count["exits_n"] += 1
        return out

    def settled(self: routing._Growth, *args: Any) -> bool:
        yes = settles(self, *args)
        count["stopped"] += yes
        return yes

    es.expanded_dijkstra = counted
    routing._turns_to_go = timed
    routing._exit_arrivals = exits_timed
    routing._Growth.settles = settled
    total = {m: [0.0, 0.0, 0.0, 0.0, 0.0] for m in modes}  # CPU, same routes, states, T's CPU, exits' CPU
    last = None  # the last call's map lattice (``carry``)
    for i in calls:
        with open(folder / f"call{i:03d}.pkl", "rb") as f:
            graph, source, target, kw = pickle.load(f)
        if carry and last is not None:
            _carried(last, graph.lattice)
        if getattr(graph.streets, "inner", None) is not None:
            shapely.prepare(graph.streets.inner)
        with open(folder / f"res{i:03d}.pkl", "rb") as f:
            want, _ = pickle.load(f)
        name = next((k for k, v in kw.items() if isinstance(v, routing.RoutingOptions)), "options")
        base = kw.get(name, routing.RoutingOptions())
        line = f"{i:3d}"
        for m in modes:
            count.update(states=0, search=0.0, T=0.0, Tn=0, Tsize=0, exits=0.0, exits_n=0, stopped=0)
            t0 = time.process_time()
            got = routing.find_route(graph, source, target, **{**kw, name: _options(base, m)})
            dt = time.process_time() - t0
            if got is None or want is None:
                same = (got is None) == (want is None)
            else:
                same = (all(np.array_equal(getattr(got, f), getattr(want, f)) for f in ROUTE_FIELDS)
                        and got.turn_cost == want.turn_cost)
            t = total[m]
            t[0] += dt
            t[1] += float(same)
            t[2] += count["states"]
            t[3] += count["T"]
            t[4] += count["exits"]
            line += (f" | {m} {dt:6.2f} s same={int(same)} states {count['states'] / 1e6:6.2f} M"
                     f" search {count['search']:.2f} s T {count['T']:.2f} s/{count['Tn']:.0f}"
                     f" x {count['Tsize'] / 1e6:.1f} M exits {count['exits']:.2f} s/{count['exits_n']:.0f}"
                     f" ({count['stopped']:.0f} stopped)")
        print(line, flush=True)
        last = graph.lattice if carry else None
        del graph
    for m in modes:
        cpu, routes, states, T, exits = total[m]
        print(f"{m}: {cpu:.2f} s CPU over {len(calls)} calls; same route {routes:.0f}/{len(calls)}; "
              f"route search states {states / 1e6:.2f} M; T {T:.2f} s CPU; exits' searches {exits:.2f} s CPU")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    cap = sub.add_parser("capture", help="run osm-expand and pickle its find_route calls")
    cap.add_argument("folder", type=Path)
    cap.add_argument("argv", nargs=argparse.REMAINDER, help="-- then osm-expand's arguments")
    rep = sub.add_parser("replay", help="run the captured calls again, per mode")
    rep.add_argument("folder", type=Path)
    rep.add_argument("--modes", default="base,def", help="comma-separated: base, def, whole, sNN")
    rep.add_argument("--calls", type=int, nargs="*", help="the call numbers (default: all)")
    rep.add_argument("--carry", action="store_true", help="each call takes over the last one's map tables")
    args = parser.parse_args()
    if args.what == "capture":
        argv = args.argv[1:] if args.argv[:1] == ["--"] else args.argv
        sys.exit(capture(args.folder, argv))
    calls = args.calls or list(range(len(list(args.folder.glob("call*.pkl")))))
    replay(args.folder, args.modes.split(","), calls, args.carry)


if __name__ == "__main__":
    main()
