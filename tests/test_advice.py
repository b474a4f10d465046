"""Every refusal's advice, followed, works; every fixture that holds a town grows by default (issue 20)."""
from __future__ import annotations

import re

import pytest

from osm_expand.cli import main
from tests.conftest import FIXTURES

#: What a refusal may advise: an option, with its value when it has one.
ADVICE = re.compile(r"(?:try|at most) (--area \d+|--beyond-bounds)")


def run(argv: list[str], capsys) -> tuple[int, str]:
    code = main(argv)
    return code, capsys.readouterr().err


@pytest.mark.parametrize("name,extra", [
    ("West-Oakland.osm.bz2", ["--area", "1000"]),  # too small: "try --area N (or more)"
    ("West-Oakland.osm.bz2", ["--within-bounds"]),  # the town fills its map: "try --area N" or "--beyond-bounds"
    ("monaco.osm.gz", ["--area", "1e9"]),  # too large: "at most --area N", then perhaps no room
])
def test_following_a_refusals_advice_makes_the_run_work(name, extra, tmp_path, capsys):
    argv = [str(FIXTURES / name), "-o", str(tmp_path / "out.xml"), "--years", "0", "-q", *extra]
    code, err = run(argv, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    for _ in range(3):  # advice may lead to more advice, never in circles
        advice = ADVICE.search(err)
        assert advice, f"a refusal without advice to follow: {err}"
        option = advice.group(1).split()
        argv = [a for a in argv if a not in ("--within-bounds",)]
        if option[0] == "--area":
            k = argv.index("--area") if "--area" in argv else None
            argv = argv[:k] + argv[k + 2:] if k is not None else argv
        argv += option
        code, err = run(argv, capsys)
        if code == 0:
            break
    assert code == 0, err
    assert (tmp_path / "out.xml").exists()


@pytest.mark.parametrize("name", ["West-Oakland.osm.bz2", "berlin-siegessaeule.osm.gz", "monaco.osm.gz"])
def test_a_town_that_fills_its_map_grows_beyond_it_and_says_so(name, tmp_path, capsys):
    code, err = run([str(FIXTURES / name), "-o", str(tmp_path / "out.xml"), "--years", "0", "-q"], capsys)
    assert code == 0, err
    lines = err.strip().splitlines()
    assert len(lines) <= 1 and all("beyond the data bounds" in line for line in lines)
