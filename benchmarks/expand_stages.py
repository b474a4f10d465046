"""Stage times of the main command, ``osm-expand CITY``.

    python benchmarks/expand_stages.py [FILE] [--seed N] [--repeat N]

Times each stage in-process (read, the stages of :func:`osm_expand.expand`
as it reports them, then each writer and the preview), best of ``--repeat``
runs, then times the whole command in a fresh process the way a user runs
it (interpreter start and imports included). Issue 4's budget for
``osm-expand fixtures/krems.osm.gz`` is 15 s.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def stage_times(path: Path, seed: int, out: Path) -> dict[str, float]:
    from osm_expand.engine.history import load_history
    from osm_expand.export import write_geojson, write_osm, write_urbanenvironment
    from osm_expand.export.preview import write_preview
    from osm_expand.ingest import load
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand

    times: dict[str, float] = {}
    clock = [time.perf_counter(), "read"]

    def mark(next_stage: str) -> None:
        now = time.perf_counter()
        times[clock[1]] = times.get(clock[1], 0.0) + now - clock[0]  # the engine reports each era
        clock[:] = [now, next_stage]

    city = load(path)
    mark("learn the town (simplify + example)")
    stages = {"finding": "blocks, land, site", "growing": "growth + joins", "judging": "fidelity score",
              "simulating": "engine (the default history's years)"}
    staged = lambda msg: mark(stages[msg.split()[0]]) if msg.split()[0] in stages else None  # noqa: E731
    result = mature_result(expand(city, ExpandOptions(seed=seed), progress=staged), load_history("example"),
                           MatureOptions(), seed, progress=staged)
    mark("write urbanenvironment")
    write_urbanenvironment(result.city, out / "a.xml")
    mark("write osm")
    write_osm(result.city, out / "a.osm")
    mark("write geojson")
    write_geojson(result.city, out / "a.geojson")
    mark("preview png")
    write_preview(result.city, out / "a.png", result.site.region, title="benchmark")
    mark("end")
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", default=str(REPO / "fixtures" / "krems.osm.gz"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        runs = [stage_times(Path(args.file), args.seed, Path(tmp)) for _ in range(args.repeat)]
        print(f"{Path(args.file).name}: stage times, best of {args.repeat} (s)")
        best = {k: min(r[k] for r in runs) for k in runs[0]}
        for stage, t in best.items():
            print(f"  {stage:<26}{t:7.2f}")
        print(f"  {'total in-process':<26}{sum(best.values()):7.2f}")
        exe = Path(sys.executable).with_name("osm-expand")
        walls = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            subprocess.run([str(exe), args.file, "-o", str(Path(tmp) / "cli.xml"), "--preview",
                            str(Path(tmp) / "cli.png"), "--seed", str(args.seed), "-q"], check=True)
            walls.append(time.perf_counter() - start)
        print(f"  {'osm-expand CITY --preview (fresh process)':<26}{min(walls):7.2f}  (budget 15 s)")


if __name__ == "__main__":
    main()
