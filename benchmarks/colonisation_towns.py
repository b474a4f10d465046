"""Space colonisation on real towns: referee, joins, forbidden ground, buildings in its blocks, fidelity (issue 12).

    python benchmarks/colonisation_towns.py [--seeds 0 1 2] [--years N] [--draw DIR [--png NAME] [--dpi N]]
                                            [--out DIR] [TOWN ...]

For each town and seed: ``expand(city, ExpandOptions(seed=s),
pattern=Colonisation(example))`` then ``mature_result(result, example
history, MatureOptions(years=N), s)`` in-process (the town is read and learned
once), which is what ``osm-expand TOWN --pattern colonisation --seed s
--years N`` runs; without ``--years`` the history's own years (30 for the
default history ``example``), so the engine builds lots and buildings in the
district's blocks. With ``--years 0`` no engine runs, and the district's
blocks are split into lots and given buildings here by the engine's kernels
(:func:`osm_expand.engine.buildout.lots.subdivide_blocks`,
:func:`osm_expand.engine.buildout.footprints.place_buildings`; every street built,
low-density residential, widths by class from :data:`WIDTH`), a quick stand-in.

The whole city is written as ``<urbanenvironment>``
(:func:`osm_expand.export.write_urbanenvironment`, as the CLI does), checked
against the XSD, and then judged from the file by
``benchmarks/colonisation_check.py``'s :func:`check`: the independent
referee, joins, metres of colonisation streets on forbidden ground, the
district's blocks, lots and the buildings on them, and the fidelity report.

With ``--draw DIR`` a PNG per run (named by ``--png``, default
``{town}-colonisation-{seed}.png``) shows the town's streets in grey, its
buildings and the engine's in dark grey, the colonisation streets by level
(red primary, orange secondary, purple tertiary), joining streets in green,
the engine's streets thin black, joins as circles, the kernel's region dashed,
water blue, the town's blocks and unbuildable land pink and the attraction
points as dots.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
from colonisation_check import TABLE_HEAD, check, markdown_row  # noqa: E402

TOWNS = ["krems.osm.gz", "campo-grande.osm.gz", "andorra.osm.pbf"]
#: Full street widths by class (m) for the lots' shrink: typical two-lane widths (no table in the seeds).
WIDTH = {"primary": 14.0, "secondary": 12.0, "tertiary": 10.0, "unclassified": 8.0, "residential": 8.0}


def district_buildings(result, rng: np.random.Generator) -> tuple[int, int, list]:
    """Blocks of the district, lots, and building footprints placed by the engine's kernels."""
    from osm_expand.blocks import blocks
    from osm_expand.engine.buildout.footprints import place_buildings
    from osm_expand.engine.buildout.lots import block_frontage, subdivide_blocks
    from osm_expand.model import Building, Origin

    city = result.city
    net = city.network
    new_ids = {net.streets[k].id for k in city.new_streets()}
    footprint = result.growth.footprint
    mine = [b for b in blocks(net) if new_ids & set(b.street_ids)
            and footprint.contains(b.polygon.representative_point())]
    if not mine:
        return 0, 0, []
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    ids = [s.id for s in net.streets]
    widths = [s.width or WIDTH.get(s.highway, 8.0) for s in net.streets]
    polys = [b.polygon for b in mine]
    frontage = block_frontage(polys, lines, ids, widths)
    lots = subdivide_blocks(polys, frontage, ["residential_low"] * len(polys), rng=rng)
    obstacles = [g for g in (city.water_geometry(), city.unbuildable) if g is not None and not g.is_empty]
    obstacles += [b.polygon for b in city.buildings]
    fps = place_buildings(lots, traffic_per_street={}, built_streets=set(ids), rng=rng, obstacles=obstacles)
    made = [Building(rings=(np.vstack([fp.rectangle.corners, fp.rectangle.corners[:1]]),), height=9.0, levels=3,
                     origin=Origin.ENGINE, year=city.year, land_use=fp.land_use) for fp in fps]
    return len(mine), len(lots), made


def run(name: str, seeds: list[int], years: int | None, draw: Path | None, png: str, out_dir: Path,
        dpi: int = 70) -> list[dict]:
    from osm_expand.engine.history import load_history
    from osm_expand.export import write_urbanenvironment
    from osm_expand.export.urban import validate
    from osm_expand.ingest import load
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand, learn
    from synth.colonisation_pattern import Colonisation

    city = load(REPO / "fixtures" / name)
    pattern = Colonisation(learn(city).example)
    stem = name.split(".")[0]
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        result = mature_result(expand(city, ExpandOptions(seed=seed), pattern=pattern), load_history("example"),
                               MatureOptions(years=years), seed)
        seconds = time.perf_counter() - t0
        built, stand_in = result.city, None
        if years == 0:
            stand_in = district_buildings(result, np.random.default_rng([seed, 0xB1D]))
            built = built.replace(buildings=built.buildings + tuple(stand_in[2]))
        xml = out_dir / f"{stem}-colonisation-{seed}.xml"
        write_urbanenvironment(built, xml)
        report = json.loads(json.dumps({"seed": seed, **result.report}, default=float))
        row = check(REPO / "fixtures" / name, xml, report)
        if stand_in is not None:  # the XML has no lots: count what was placed here
            row.update(district_blocks=stand_in[0], district_lots=stand_in[1], district_buildings=len(stand_in[2]))
        d = result.growth.debug
        row.update(seconds=round(seconds, 1), xsd_errors=len(validate(xml)), corridor=d["corridor"],
                   aps=d["attraction_points"], kernel_joins=d["kernel_joins"])
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "district"}), flush=True)
        if draw is not None:
            title = (f"{name} seed {seed}, {row['years']} years: {row['grown_streets']} colonisation streets, "
                     f"{row['joins_report']} joins, {row['district_buildings']} buildings in its "
                     f"{row['district_blocks']} blocks, fidelity off {row['fidelity_off']} "
                     f"(median real part {row['fidelity_median_part_off']})")
            picture(result, built, draw / png.format(town=stem, seed=seed), title, dpi)
    return rows


def picture(result, built, path: Path, title: str, dpi: int = 70) -> None:
    """The district and its surroundings (module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from osm_expand.model import Origin

    def fill(ax, geom, **kw):
        for p in shapely.get_parts(geom):
            if p.geom_type == "Polygon":
                ax.fill(*p.exterior.xy, **kw)

    net = built.network
    x0, y0, x1, y1 = shapely.buffer(result.growth.footprint, 250).bounds
    view = shapely.box(x0, y0, x1, y1)
    fig, ax = plt.subplots(figsize=(11, 11 * (y1 - y0) / max(x1 - x0, 1.0)))
    town_blocks = [b.polygon for b in built.blocks if b.origin == Origin.SOURCE]  # not the district's
    taken = shapely.union_all([*town_blocks, *([built.unbuildable] if built.unbuildable is not None else [])])
    fill(ax, shapely.intersection(taken, view), color="#f3e3e3", lw=0)
    fill(ax, shapely.intersection(built.water_geometry(), view), color="#a6cee3", lw=0)
    for f in result.growth.debug["features"]:
        layer = f["properties"]["layer"]
        if layer == "colonisation_region":
            fill(ax, shapely.from_geojson(json.dumps(f["geometry"])), color="none", ec="0.35", lw=1, ls="--")
        elif layer == "attraction_point":
            x, y = f["geometry"]["coordinates"]
            ax.plot(x, y, ".", ms=2, color="#1f78b4" if f["properties"]["phase"] == 1 else "#33a02c", alpha=0.4)
    for b in built.buildings:
        if b.origin == Origin.ENGINE or shapely.intersects(view, b.polygon):
            ax.fill(*b.ring.T, color="#555555" if b.origin == Origin.ENGINE else "#9a9a9a", lw=0)
    colours = {0: "#d7191c", 1: "#f29e2e", 2: "#7b3294"}
    for s in net.streets:
        xy = net.street_xy(s)
        if s.origin == Origin.SOURCE:
            ax.plot(*xy.T, color="0.6", lw=0.8)
        elif s.origin == Origin.JOIN:
            ax.plot(*xy.T, color="#1a9641", lw=2.2)
        elif s.origin == Origin.ENGINE:
            ax.plot(*xy.T, color="black", lw=0.7)
        else:
            ax.plot(*xy.T, color=colours.get(s.hierarchy, "k"), lw=2.6 if s.hierarchy == 0 else 1.8)
    at = np.asarray(result.joins.at).reshape(-1, 2)
    ax.plot(at[:, 0], at[:, 1], "o", mfc="none", mec="k", ms=7)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("towns", nargs="*", default=TOWNS)
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--years", type=int, default=None,
                    help="years of the default history (default: its own, 30); 0: no engine, stand-in buildings")
    ap.add_argument("--draw", type=Path, help="write a PNG per run into this folder")
    ap.add_argument("--png", default="{town}-colonisation-{seed}.png", help="the PNGs' names ({town}, {seed})")
    ap.add_argument("--dpi", type=int, default=70, help="resolution of the pictures")
    ap.add_argument("--out", type=Path, help="keep the XML files in this folder (default: a temporary one)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        for d in (args.draw, out_dir):
            if d is not None:
                d.mkdir(parents=True, exist_ok=True)
        rows = [r for name in args.towns
                for r in run(name, args.seeds, args.years, args.draw, args.png, out_dir, args.dpi)]
    print()
    print(TABLE_HEAD.replace("| town |", "| town | seed |").replace("|---|", "|---|---|", 1))
    for r in rows:
        print(markdown_row(r).replace(f"| {r['town']} |", f"| {r['town']} | {r['seed']} |", 1))
    print("\n| town | seed | s | XSD errors | attraction points | corridor |\n|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['town']} | {r['seed']} | {r['seconds']} | {r['xsd_errors']} | {r['aps']} | {r['corridor']} |")


if __name__ == "__main__":
    main()
