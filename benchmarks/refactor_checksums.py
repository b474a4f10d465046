"""Checksums of the outputs a refactor must leave byte-identical.

Issue 23 asks that a refactor leave the default, ``--history european`` and
``--pattern colonisation`` outputs (``-o X.xml --seed 0``) of the reference
towns, and every fixture's ``osm-expand simplify F -o X.osm``, byte-identical.
This script runs those commands, each a fresh ``osm-expand`` process with the
checkout that holds this script first on ``PYTHONPATH``, and prints (or
compares against) one JSON object ``{case: sha256}``.

Usage::

    python benchmarks/refactor_checksums.py > before.json            # Krems, Monaco
    python benchmarks/refactor_checksums.py --towns krems monaco campo-grande
    python benchmarks/refactor_checksums.py --check before.json      # exit 1 on a change
    python benchmarks/refactor_checksums.py --only simplify --check before.json

Campo Grande takes about 4 min of CPU per expand run; it is left out unless
named. ``--check`` compares only the cases both sides hold.

``benchmarks/refactor_checksums.json`` holds the outputs of main after
issue 23's third refactor (one district-placing function, one segment
table, synth's, clip's, batch's, measures', the build-out year's, trips'
and trade's modules split), which left every output as it was, and after
issue 20's engine districts sized at the town's street density, which
changed the runs whose history grows districts: Krems, Monaco and Campo
Grande's three runs and every fixture's ``simplify``, and after session 31's district floor on by
default (``GrowthOptions.district_neighbourhoods`` = 5), which changed the
runs that grow districts in the engine's years: Krems' and Monaco's default
and colonisation runs and Campo Grande's three. Campo Grande's three were taken
again from main 899e714 on session 33's fresh machine (numpy 2.4.6, scipy
1.17.1, shapely 2.2.0): the same code gave other bytes there (7c258439 for
the default run), while Krems', Monaco's and every simplify output stayed. The three
``european`` runs were taken again on session 37's merge (``GrowthOptions.pattern_aim``
on: a named pattern's era keeps its town's connectedness); every other case stayed. Every expand case was
taken again in session 43 (``PatchOptions.transplant`` on by default: the district and the example pattern's
engine districts copy one whole neighbourhood); the simplify cases stayed. (Earlier baselines:
main at 25738d5 for the second refactor, c903331 for the first.)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "fixtures"
#: The expand variants of issue 23: the default run, the European history,
#: and the colonisation growth pattern; each with ``--seed 0``.
VARIANTS: dict[str, list[str]] = {
    "default": [],
    "european": ["--history", "european"],
    "colonisation": ["--pattern", "colonisation"],
}


def _osm_expand() -> list[str]:
    exe = Path(sys.executable).with_name("osm-expand")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "osm_expand.cli"]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _run(args: list[str], out: Path) -> tuple[str, float, float]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    c0 = os.times()
    proc = subprocess.run(
        [*_osm_expand(), *args, "-o", str(out), "-q"],
        env=env, capture_output=True, text=True, check=False,
    )
    c1 = os.times()
    wall = time.perf_counter() - t0
    cpu = (c1.children_user - c0.children_user) + (c1.children_system - c0.children_system)
    if proc.returncode != 0:
        msg = (proc.stderr.strip().splitlines()[-1:] or ["(no stderr)"])[0].replace(str(ROOT) + os.sep, "")
        return f"exit {proc.returncode}: {msg}", wall, cpu  # a refusal must stay the same refusal
    return _sha256(out), wall, cpu


def cases(towns: list[str], only: str | None) -> list[tuple[str, list[str], str]]:
    """Every (case name, command arguments, output suffix) to run."""
    out: list[tuple[str, list[str], str]] = []
    if only in (None, "expand"):
        for town in towns:
            src = FIXTURES / f"{town}.osm.gz"
            for name, extra in VARIANTS.items():
                out.append((f"expand/{town}/{name}", [str(src), "--seed", "0", *extra], ".xml"))
    if only in (None, "simplify"):
        for src in sorted(FIXTURES.iterdir()):
            if ".osm" in src.name:
                out.append((f"simplify/{src.name}", ["simplify", str(src)], ".osm"))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--towns", nargs="+", default=["krems", "monaco"])
    p.add_argument("--only", choices=["expand", "simplify"])
    p.add_argument("--check", type=Path, help="a JSON of earlier checksums to compare with")
    a = p.parse_args(argv)
    before = json.loads(a.check.read_text()) if a.check else None
    sums: dict[str, str] = {}
    changed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, args, suffix in cases(a.towns, a.only):
            if before is not None and name not in before:
                continue
            out = Path(tmp) / ("out" + suffix)
            digest, wall, cpu = _run(args, out)
            sums[name] = digest
            flag = ""
            if before is not None:
                same = before[name] == digest
                changed += not same
                flag = "  same" if same else "  CHANGED"
            print(f"{name}: {digest[:16]}  {wall:.1f} s wall, {cpu:.1f} s CPU{flag}", file=sys.stderr)
    print(json.dumps(sums, indent=1, sort_keys=True))
    return 1 if changed else 0


if __name__ == "__main__":
    raise SystemExit(main())
