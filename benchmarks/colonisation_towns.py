"""Space colonisation on real towns: joins, referee verdict, buildable blocks and fidelity (issue 12).

    python benchmarks/colonisation_towns.py [--seeds 0 1 2] [--draw DIR [--dpi N]] [--out DIR] [TOWN ...]

For each town and seed: ``expand(city, ExpandOptions(seed=s), pattern=Colonisation(example))``
in-process (the town is read and learned once), then

* the district's blocks (faces of the expanded network with a grown or
  joining street on their edge, inside the district's footprint) are split
  into lots and given buildings by the engine's kernels
  (:func:`osm_expand.engine.lots.subdivide_blocks`,
  :func:`osm_expand.engine.footprints.place_buildings`; every street built,
  low-density residential, widths by class from :data:`WIDTH`), which stand
  in for the year loop the lead is wiring;
* the whole city with those buildings is written as ``<urbanenvironment>``
  (:func:`osm_expand.export.write_urbanenvironment`), checked against the XSD
  and by the independent referee (``/work/shared/tools/referee.py urban``);
* the fidelity verdict of the pipeline is reported (measures off, the median
  real part's, street density in range).

With ``--draw DIR`` a PNG per run shows the town's streets in grey, the
colonisation streets by level (red primary, orange secondary, purple
tertiary), joining streets in green, joins as circles, the kernel's region
dashed and its attraction points as dots.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely

REPO = Path(__file__).resolve().parent.parent
TOWNS = ["krems.osm.gz", "campo-grande.osm.gz", "andorra.osm.pbf"]
REFEREE = Path("/work/shared/tools/referee.py")
#: Full street widths by class (m) for the lots' shrink: typical two-lane widths (no table in the seeds).
WIDTH = {"primary": 14.0, "secondary": 12.0, "tertiary": 10.0, "unclassified": 8.0, "residential": 8.0}


def district_buildings(result, rng: np.random.Generator) -> tuple[int, int, list]:
    """Blocks of the district, lots, and building footprints placed by the engine's kernels."""
    from osm_expand.blocks import blocks
    from osm_expand.engine.footprints import place_buildings
    from osm_expand.engine.lots import block_frontage, subdivide_blocks
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


def referee(path: Path) -> dict:
    out = subprocess.run([sys.executable, str(REFEREE), "urban", str(path)], capture_output=True, text=True)
    report = json.loads(out.stdout) if out.stdout.strip() else {}
    report["exit"] = out.returncode
    return report


def run(name: str, seeds: list[int], draw: Path | None, out_dir: Path, dpi: int = 70) -> list[dict]:
    from osm_expand.export import write_urbanenvironment
    from osm_expand.export.urban import validate
    from osm_expand.ingest import load
    from osm_expand.pipeline import ExpandOptions, expand, learn
    from synth.colonisation_pattern import Colonisation

    city = load(REPO / "fixtures" / name)
    pattern = Colonisation(learn(city).example)
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        result = expand(city, ExpandOptions(seed=seed, years=0), pattern=pattern)
        seconds = time.perf_counter() - t0
        n_blocks, n_lots, made = district_buildings(result, np.random.default_rng([seed, 0xB1D]))
        built = result.city.replace(buildings=result.city.buildings + tuple(made))
        xml = out_dir / f"{name.split('.')[0]}-colonisation-{seed}.xml"
        write_urbanenvironment(built, xml)
        ref = referee(xml)
        f = result.report.get("fidelity", {})
        d = result.growth.debug
        rows.append({"town": name, "seed": seed, "seconds": round(seconds, 1), "site": result.report["site_rank"],
                     "grown": result.report["grown_streets"], "km": result.report["grown_length_km"],
                     "joins": result.joins.joins, "kernel_joins": d["kernel_joins"], "links": result.joins.links,
                     "tees": result.joins.tees, "blocks": n_blocks, "lots": n_lots, "buildings": len(made),
                     "xsd_errors": len(validate(xml)), "referee_exit": ref["exit"],
                     "violations": {k: v for k, v in ref.get("report", ref).items()
                                    if isinstance(v, int) and k not in ("streets", "segments", "buildings", "exit")
                                    and v},
                     "off": f.get("off"), "typical_off": f.get("typical_part_off"),
                     "density_ok": f.get("density_ok"),
                     "off_measures": sorted(k for k, v in f.get("measures", {}).items() if not v["ok"]),
                     "corridor": d["corridor"], "aps": d["attraction_points"]})
        print(json.dumps(rows[-1]), flush=True)
        if draw is not None:
            picture(result, made, draw / f"{name.split('.')[0]}-colonisation-{seed}.png",
                    f"{name} seed {seed}: {rows[-1]['grown']} streets, {rows[-1]['joins']} joins, "
                    f"{len(made)} buildings, fidelity off {rows[-1]['off']} "
                    f"(median real part {rows[-1]['typical_off']})", dpi)
    return rows


def picture(result, made: list, path: Path, title: str, dpi: int = 70) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from osm_expand.model import Origin

    def fill(ax, geom, **kw):
        for p in shapely.get_parts(geom):
            if p.geom_type == "Polygon":
                ax.fill(*p.exterior.xy, **kw)

    net = result.city.network
    x0, y0, x1, y1 = shapely.buffer(result.growth.footprint, 250).bounds
    view = shapely.box(x0, y0, x1, y1)
    fig, ax = plt.subplots(figsize=(11, 11 * (y1 - y0) / max(x1 - x0, 1.0)))
    fill(ax, shapely.intersection(result.city.occupied, view), color="#f3e3e3", lw=0)
    fill(ax, shapely.intersection(result.city.water_geometry(), view), color="#a6cee3", lw=0)
    for f in result.growth.debug["features"]:
        layer = f["properties"]["layer"]
        if layer == "colonisation_region":
            fill(ax, shapely.from_geojson(json.dumps(f["geometry"])), color="none", ec="0.35", lw=1, ls="--")
        elif layer == "attraction_point":
            x, y = f["geometry"]["coordinates"]
            ax.plot(x, y, ".", ms=2, color="#1f78b4" if f["properties"]["phase"] == 1 else "#33a02c", alpha=0.4)
    for b in made:
        ax.fill(*b.ring.T, color="#555555", lw=0)
    colours = {0: "#d7191c", 1: "#f29e2e", 2: "#7b3294"}
    for s in net.streets:
        xy = net.street_xy(s)
        if s.origin == Origin.SOURCE:
            ax.plot(*xy.T, color="0.6", lw=0.8)
        elif s.origin == Origin.JOIN:
            ax.plot(*xy.T, color="#1a9641", lw=2.2)
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
    ap.add_argument("--draw", type=Path, help="write a PNG per run into this folder")
    ap.add_argument("--dpi", type=int, default=70, help="resolution of the pictures")
    ap.add_argument("--out", type=Path, help="keep the XML files in this folder (default: a temporary one)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        for d in (args.draw, out_dir):
            if d is not None:
                d.mkdir(parents=True, exist_ok=True)
        rows = [r for name in args.towns for r in run(name, args.seeds, args.draw, out_dir, args.dpi)]
    print("\n| town | seed | site | grown streets | km | joins (kernel/links/tees) | blocks | lots | buildings "
          "| XSD errors | referee | fidelity off (median part) | density ok | off on | s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        verdict = "0 violations" if r["referee_exit"] == 0 else json.dumps(r["violations"])
        print(f"| {r['town']} | {r['seed']} | {r['site']} | {r['grown']} | {r['km']} | {r['joins']} "
              f"({r['kernel_joins']}/{r['links']}/{r['tees']}) | {r['blocks']} | {r['lots']} | {r['buildings']} "
              f"| {r['xsd_errors']} | {verdict} | {r['off']} ({r['typical_off']}) | {r['density_ok']} "
              f"| {', '.join(r['off_measures'])} | {r['seconds']} |")


if __name__ == "__main__":
    main()
