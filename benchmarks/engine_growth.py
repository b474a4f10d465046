"""Does what the engine's years grow read as the town growing? The growth verdict and the LEI per town (issue 20).

For each town: ``osm-expand TOWN`` in-process (default options, seed 0, the
history's 30 years unless ``--years``), then the engine's street growth
(streets of origin ``engine`` but its major roads, whose length is printed
apart) judged against real neighbourhoods of the town
(:mod:`osm_expand.growth_fidelity`), with ``--refs`` reference seeds (the
verdict's ranges come from 32 random neighbourhoods, so one reference seed
moves the off count by one or two). Prints per town: the off count of 14 per
reference seed and its mean, the dead-end and 2-core shares with the
neighbourhoods' range (reference seed 0), the pieces the engine's streets
make on the map, the Landscape Expansion Index shares of new street length
(infill / edge expansion / outlying), and the times (wall and CPU) of the
run and of the judging, and the engine's streets' corners over 45° at nodes of degree two per km beside its town's
neighbourhoods' (:func:`engine_corners`: the picture's wiggles, which the verdict reads only as one of 14
measures). ``--eras`` adds a line per era; ``--measures`` a line per town and reference seed
(and per era, reference seed 0), after the tables, naming each measure off, its value against its range
and by how much. ``--discs`` judges against the reference
neighbourhoods measured in their discs (the yardstick before they were measured on their streets' land,
:func:`osm_expand.growth_fidelity.streets_land`). ``--fixed-margin`` judges with the window's margin a fixed
50 m (the yardstick before it was half the side of the town's median block,
:func:`osm_expand.growth_fidelity.town_margin`).

Issue 20's targets: off on at most 4 of 14, dead-end and 2-core shares in
range, infill + edge expansion at least 80 % of the new street length.

Usage: ``python benchmarks/engine_growth.py [--history european] [--eras] [--measures] [--where]
[--discs] [--fixed-margin] [--seed N | --seeds S ...] [--neighbourhoods K] [--option NAME=VALUE ...]
[--patch-option NAME=VALUE ...] [TOWN ...]``
(``--seeds 0-5``: a row per seed and a summary per town, the way to judge a rule; ``--neighbourhoods``:
:attr:`GrowthOptions.district_neighbourhoods` for the run; ``--option``, repeatable: any other
:class:`GrowthOptions` field, e.g. ``--option pattern_aim=false --option sites_tried=7``; ``--patch-option``,
repeatable: a :class:`~synth.patches.PatchOptions` field set for the district and every ``example`` era, e.g.
``--patch-option transplant=true``)
(default: Krems, Andorra, north-bayreuth, Monaco, Krems with ``european``, then Campo Grande;
Campo Grande takes about 5 minutes and 8 GB).
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
RUNS = [("krems.osm.gz", "example"), ("andorra.osm.pbf", "example"), ("north-bayreuth.osm.gz", "example"),
        ("monaco.osm.gz", "example"), ("krems.osm.gz", "european"), ("campo-grande.osm.gz", "example")]


def _share(report: dict, name: str) -> str:
    v = report["measures"][name]
    mark = "" if v["ok"] else " ✗"
    return f"{v['value']} [{v['low']}–{v['high']}]{mark}"


def _off_measures(report: dict) -> str:
    """The measures off in ``report``: value [range] and how far outside it, in widths of the range (for a
    distribution the KS distance against its bound, with the growth's and the town's medians).

    Where the range has no width (``high == low``) the distance is in the measure's own units, and says so.
    A value or bound that is NaN (``to_dict`` writes it as None) prints as ``n/a``: no distance is computed.
    """
    out = []
    for m, v in report["measures"].items():
        if v["ok"]:
            continue
        value, high = v["value"], v["high"]
        if v["kind"] == "distribution":
            out.append(f"{m} KS {value} > {high} (median {v['district']} vs town {v['town']})")
            continue
        low = v["low"]
        if value is None or low is None or high is None:
            out.append(f"{m} n/a [{low}–{high}]")
            continue
        beyond = low - value if value < low else value - high
        if high > low:
            out.append(f"{m} {value} [{low}–{high}] ({beyond / (high - low):+.2f} widths)")
        else:
            out.append(f"{m} {value} [{low}–{high}] ({beyond:+.3g} in the measure's units: the range has no width)")
    return "; ".join(out)


def growth_option(text: str) -> tuple[str, object]:
    """``--option NAME=VALUE``: a :class:`GrowthOptions` field and its value, read by the field's default's type
    (``true``/``false`` for a bool, ``inf`` for a float); argparse's error for an unknown field or a bad value."""
    from dataclasses import fields

    from osm_expand.engine.growth.minor_streets import GrowthOptions

    name, sep, raw = text.partition("=")
    defaults = {f.name: getattr(GrowthOptions(), f.name) for f in fields(GrowthOptions)}
    if not sep or name not in defaults:
        raise argparse.ArgumentTypeError(f"not NAME=VALUE with NAME a GrowthOptions field: {text!r}")
    kind = type(defaults[name])
    if kind is bool:
        if raw.lower() not in ("true", "false"):
            raise argparse.ArgumentTypeError(f"{name} takes true or false, got {raw!r}")
        return name, raw.lower() == "true"
    try:
        return name, kind(raw)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} takes a {kind.__name__}, got {raw!r}") from None


#: m between the points :func:`where_grown` measures along a street (the pathfinding lattice's spacing).
WHERE_STEP = 20.0


def where_grown(city) -> list[dict]:  # type: ignore[no-untyped-def]  # a City; imports stay inside (start-up)
    """Per year of the engine's street growth (its streets of origin ``engine`` but the major roads): km, pieces
    (30 m each side, merged, as the verdict counts them), and the median distance (m) of its street length
    (points every :data:`WHERE_STEP` m) to the town's settlement before the years
    (:func:`osm_expand.sites.settlement`: the largest piece of built-up land, 200 m gaps bridged) and to the
    growth before it (the pipeline's district, its joins and earlier years' engine streets and joins; ``inf`` when
    none).

    Why: the LEI calls growth edge expansion when its 30 m buffer touches any built-up land, so a quarter in
    the fields beside a hamlet's street counts as edge growth; these distances say whether the engine's
    years continue the town and the quarters before them (issue 20, "years that extend the town").
    """
    import shapely

    from osm_expand.blocks import blocks
    from osm_expand.growth_fidelity import before_the_years, is_major_road
    from osm_expand.measures.shape import piece_labels
    from osm_expand.model import Origin
    from osm_expand.sites import distance_maps, settlement_distance

    net = city.network
    before = before_the_years(city)
    maps = distance_maps(before.replace(blocks=tuple(blocks(before.network, year=None))), beyond_bounds=True)
    grown = [s for s in net.streets if s.origin == Origin.ENGINE and not is_major_road(s)]
    # the pipeline's district and its joins; an engine district's joins (origin ``join``, its year) join it after
    joins = [s for s in net.streets if s.origin == Origin.JOIN and s.year is not None]
    earlier = [net.street_xy(s) for s in net.streets
               if s.origin == Origin.GROWN or (s.origin == Origin.JOIN and s.year is None)]
    out = []
    for year in sorted({s.year for s in grown if s.year is not None}):
        lines = np.array([shapely.LineString(net.street_xy(s)) for s in grown if s.year == year], dtype=object)
        points = shapely.get_coordinates(shapely.segmentize(lines, WHERE_STEP))
        to_town = float(np.median(settlement_distance(maps, points)))
        to_earlier = (float(np.median(shapely.distance(shapely.MultiLineString(earlier), shapely.points(points))))
                      if earlier else math.inf)
        out.append({"year": year, "km": float(shapely.length(lines).sum()) / 1000,
                    "pieces": int(piece_labels(lines, 30.0).max()) + 1, "to_town_m": to_town,
                    "to_earlier_m": to_earlier})
        earlier += [net.street_xy(s) for s in grown + joins if s.year == year]
    return out


def engine_corners(result) -> dict:  # type: ignore[no-untyped-def]  # an ExpandResult; imports stay inside
    """What a viewer sees beside the verdict (issue 20, session 39): the corners sharper than 45° at nodes of
    degree two of the engine's streets (origin ``engine`` but the major roads) per km, beside the same reading
    of the town's neighbourhoods (16 discs of the pipeline district's area on the yardstick's junctions, the
    town's streets as mapped in them: median and 90th percentile, :func:`synth.patches.corners.corners_in_discs`)."""
    from osm_expand.growth_fidelity import is_major_road
    from osm_expand.model import Origin, polyline_length
    from synth.patches.corners import SHARP, corner_turns, neighbourhood_corner_rates

    net = result.city.network
    mine = [s for s in net.streets if s.origin == Origin.ENGINE and not is_major_road(s)]
    km = sum(polyline_length(net.street_xy(s)) for s in mine) / 1000.0
    count = int((corner_turns(net, np.unique(np.concatenate([np.asarray(s.nodes) for s in mine])))[1] > SHARP).sum()) \
        if mine else 0
    radius = float(np.sqrt(max(result.report.get("district_area_m2", 0.0), 1.0) / np.pi))
    rates = neighbourhood_corner_rates(result.city, radius)
    return {"corners": count, "per_km": count / max(km, 1e-9), "town_median": float(np.nanmedian(rates)),
            "town_p90": float(np.nanpercentile(rates, 90))}


def run(name: str, history: str, years: int | None, refs: int, discs: bool = False,
        neighbourhoods: float | None = None, seed: int = 0, fixed_margin: bool = False,
        growth: dict[str, object] | None = None, want_where: bool = False,
        patch: dict[str, object] | None = None) -> dict:
    from osm_expand.engine.growth.minor_streets import GrowthOptions
    from osm_expand.engine.history import load_history
    from osm_expand.engine.loop import EngineOptions
    from osm_expand.growth_fidelity import GrowthFidelityOptions, before_the_years, built_up, growth_fidelity
    from osm_expand.ingest import load
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.model import Origin
    from osm_expand.pipeline import ExpandOptions, expand

    chosen = dict(growth or {})
    if neighbourhoods is not None:
        chosen["district_neighbourhoods"] = neighbourhoods
    engine = EngineOptions(growth=GrowthOptions(**chosen))  # type: ignore[arg-type]  # typed by growth_option
    t0, c0 = time.perf_counter(), time.process_time()
    city, story = load(REPO / "fixtures" / name), load_history(history)
    grower = None
    if patch:  # the district grown with the same fields (its pattern made as the pipeline makes it)
        from osm_expand.growth_patterns import make_pattern
        from osm_expand.pipeline import learn
        from synth.patches import PatchOptions

        story = with_patch_options(story, patch)
        grower = make_pattern("example", learn(city).example, PatchOptions(**patch))
    result = mature_result(expand(city, ExpandOptions(seed=seed, fidelity=False), pattern=grower),
                           story, MatureOptions(years=years, fidelity=False, engine=engine), seed)
    run_s, run_cpu = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    net = result.city.network
    town = [net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE]
    built = built_up(before_the_years(result.city))
    options = GrowthFidelityOptions(references_on_streets_land=not discs, window_margin_from_town=not fixed_margin)
    judged = [growth_fidelity(net, town, built=built, rng=ref, options=options) for ref in range(refs)]
    judge_s, judge_cpu = (time.perf_counter() - t0) / refs, (time.process_time() - c0) / refs
    eras = [(e["era"], e["districts"], e["street_length_km"]) for e in result.report["engine"]["eras"]]
    where = where_grown(result.city) if want_where else []
    return {"name": name, "history": history, "judged": judged, "eras_grown": eras, "where": where,
            "corners": engine_corners(result),
            "run_s": run_s, "run_cpu": run_cpu,
            "judge_s": judge_s, "judge_cpu": judge_cpu}


def with_patch_options(story, patch: dict[str, object]):  # type: ignore[no-untyped-def]  # a History
    """``--patch-option``: the history with ``patch`` set on every era's :class:`~synth.patches.PatchOptions`
    (the ``example`` eras); :func:`run` grows the district with the same fields, so the run is the one a
    change of those fields' defaults would make (the district and every era)."""
    from dataclasses import replace

    from synth.patches import PatchOptions

    eras = tuple(replace(e, options=replace(e.options, **patch)) if isinstance(e.options, PatchOptions) else e
                 for e in story.eras)
    return replace(story, eras=eras)


def patch_option(text: str) -> tuple[str, object]:
    """``--patch-option NAME=VALUE``: a :class:`~synth.patches.PatchOptions` field and its value (JSON: true,
    0.5, "x"), checked when the options are made."""
    import json
    from dataclasses import fields

    from synth.patches import PatchOptions

    name, sep, value = text.partition("=")
    if not sep or name not in {f.name for f in fields(PatchOptions)}:
        raise argparse.ArgumentTypeError(f"not NAME=VALUE with NAME a PatchOptions field: {text!r}")
    try:
        return name, json.loads(value)
    except json.JSONDecodeError:
        raise argparse.ArgumentTypeError(f"{name}: {value!r} is not a JSON value") from None


def _neighbourhoods(text: str) -> float:
    """--neighbourhoods as a finite number >= 0 (argparse's error otherwise, as GrowthOptions would refuse it)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number of neighbourhoods >= 0, got {text!r}")
    return value


def run_seeds(text: str) -> list[int]:
    """``--seeds``: ``0-5`` (both ends included) or ``0,2,4``; each a seed >= 0."""
    try:
        if "-" in text:
            low, high = (int(part) for part in text.split("-", 1))
            seeds = list(range(low, high + 1))
        else:
            seeds = [int(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--seeds: {text!r} is not A-B or A,B,... of whole numbers") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"--seeds: {text!r} names no seed, or a negative one")
    return seeds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("towns", nargs="*", help="fixture names (default: the five towns and Krems european)")
    ap.add_argument("--history", default="example", help="history for the towns named (default: example)")
    ap.add_argument("--years", type=int, default=None, help="years (default: the history's own, 30)")
    ap.add_argument("--refs", type=int, default=3, help="reference seeds for the verdict (default 3)")
    ap.add_argument("--eras", action="store_true", help="a line per era too")
    ap.add_argument("--fixed-margin", action="store_true",
                    help="the window's margin a fixed 50 m (the yardstick before the town's half block)")
    ap.add_argument("--discs", action="store_true", help="references measured in their discs (the yardstick before)")
    ap.add_argument("--measures", action="store_true",
                    help="per town and reference seed (and era, with --eras), the measures off: value against "
                         "range, and by how much (lines outside the tables)")
    ap.add_argument("--where", action="store_true",
                    help="per year of engine street growth: km, pieces, median distance to the town's settlement "
                         "and to the growth before it (lines outside the tables)")
    ap.add_argument("--neighbourhoods", type=_neighbourhoods, default=None,
                    help="GrowthOptions.district_neighbourhoods, the district floor in neighbourhoods (default: "
                         "the options' own)")
    ap.add_argument("--seed", type=int, default=0, help="the run's seed (default 0; one seed moves the off count "
                                                         "by up to 6)")
    ap.add_argument("--seeds", type=run_seeds, default=None, metavar="A-B|A,B,...",
                    help="several run seeds instead of --seed: a row per town and seed, then per town the mean off "
                         "over the seeds and the seeds with both shares in range (one seed moves a town's verdict "
                         "by up to 6: judge a rule on six, 0-5, against the default's own spread)")
    ap.add_argument("--option", type=growth_option, action="append", default=[], metavar="NAME=VALUE",
                    help="a GrowthOptions field for the run, e.g. pattern_aim=false (repeatable)")
    ap.add_argument("--patch-option", type=patch_option, action="append", default=[], metavar="NAME=VALUE",
                    help="a PatchOptions field set for the district and every example era, e.g. transplant=true "
                         "(repeatable)")
    args = ap.parse_args()
    if args.option:
        print("growth options: " + ", ".join(f"{k}={v}" for k, v in args.option))
    if args.patch_option:
        print("patch options: " + ", ".join(f"{k}={v}" for k, v in args.patch_option))
    runs = [(t, args.history) for t in args.towns] if args.towns else RUNS
    print("| town | history | off of 14 per reference | mean off | dead-end share [range] | 2-core share [range] "
          "| pieces | infill / edge / outlying | street growth km | major roads km | run s (CPU) | judging s (CPU) "
          "| corners > 45° per km (neighbourhoods' median, p90) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    eras: list[str] = []
    off_lines: list[str] = []  # outside the tables: a one-cell row breaks a 12-column markdown table
    era_off_lines: list[str] = []
    seeds = args.seeds if args.seeds else [args.seed]
    summary: dict[tuple[str, str], list[tuple[int, float, bool]]] = {}  # per run: (seed, mean off, shares in range)
    for (name, history), seed in ((r, s) for r in runs for s in seeds):
        row = run(name, history, args.years, args.refs, args.discs, args.neighbourhoods, seed,
                  args.fixed_margin, dict(args.option), args.where, dict(args.patch_option))
        label = name if len(seeds) == 1 else f"{name} (seed {seed})"
        first = row["judged"][0]
        if first is None or first.overall is None:
            print(f"| {label} | {history} | no engine street | | | | | | | | "
                  f"{row['run_s']:.0f} ({row['run_cpu']:.0f}) | |")
            summary.setdefault((name, history), []).append((seed, float("nan"), False))
            continue
        offs = [g.overall.off for g in row["judged"]]
        overall = first.overall.to_dict()
        lei = first.lei.to_dict()
        shares_ok = all(overall["measures"][m]["ok"] for m in ("dead_end_share", "two_core_share"))
        summary.setdefault((name, history), []).append((seed, float(np.mean(offs)), shares_ok))
        print(f"| {label} | {history} | {' '.join(map(str, offs))} | {np.mean(offs):.1f} "
              f"| {_share(overall, 'dead_end_share')} | {_share(overall, 'two_core_share')} | {overall['pieces']} "
              f"| {lei['infill']} / {lei['edge']} / {lei['outlying']} | {lei['new_length_km']} "
              f"| {first.major_roads_m / 1000:.1f} "
              f"| {row['run_s']:.0f} ({row['run_cpu']:.0f}) | {row['judge_s']:.1f} ({row['judge_cpu']:.1f}) "
              f"| {row['corners']['per_km']:.2f} "
              f"({row['corners']['town_median']:.2f}, {row['corners']['town_p90']:.2f}) |",
              flush=True)
        off_lines.append(f"- {label} {history} districts per era (count, km): "
                         + ", ".join(f"{e} {n} ({km:.1f})" for e, n, km in row["eras_grown"]))
        if args.where:
            off_lines.append(f"- {label} {history} where (year: km, pieces, median m to the town's settlement / to "
                             "the growth before): " + "; ".join(
                                 f"{w['year']}: {w['km']:.1f} km, {w['pieces']}, {w['to_town_m']:.0f} / "
                                 f"{w['to_earlier_m']:.0f}" for w in row["where"]))
        if args.measures:
            offs_by = [_off_measures(g.overall.to_dict()) for g in row["judged"]]
            off_lines += [f"- {label} {history} off (reference {ref}): {line or 'none'}"
                          for ref, line in enumerate(offs_by)]
        for era, report in first.per_era.items():
            e = first.lei_per_era[era].to_dict()
            if report is None:
                eras.append(f"| {label} | {history} | {era} | | | | | {e['infill']} / {e['edge']} / {e['outlying']} "
                            f"| {e['new_length_km']} |")
                continue
            r = report.to_dict()
            eras.append(f"| {label} | {history} | {era} | {r['off']} | {_share(r, 'dead_end_share')} "
                        f"| {_share(r, 'two_core_share')} | {r['pieces']} "
                        f"| {e['infill']} / {e['edge']} / {e['outlying']} | {e['new_length_km']} |")
            if args.measures:
                era_off_lines.append(f"- {label} {history} {era} off (reference 0): {_off_measures(r) or 'none'}")
    if len(seeds) > 1:
        print("\n| town | history | mean off per seed | mean over the seeds | seeds with both shares in range |"
              "\n|---|---|---|---|---|")
        for (name, history), got in summary.items():
            means = np.array([m for _, m, _ in got])
            overall = f"{np.nanmean(means):.1f}" if np.isfinite(means).any() else "n/a"  # n/a: nothing grew
            print(f"| {name} | {history} | {' '.join(f'{m:.1f}' for m in means)} | {overall} "
                  f"| {sum(ok for _, _, ok in got)}/{len(got)} |")
    if off_lines:
        print("\n" + "\n".join(off_lines))
    if args.eras and eras:
        print("\n| town | history | era | off of 14 | dead-end share [range] | 2-core share [range] | pieces "
              "| infill / edge / outlying | km |\n|---|---|---|---|---|---|---|---|---|")
        print("\n".join(eras))
        if era_off_lines:
            print("\n" + "\n".join(era_off_lines))


if __name__ == "__main__":
    main()
