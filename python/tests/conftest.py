"""Fixtures: a DATA folder made by minos itself (generate, ingest, bake, episodes) in a
temporary folder, and the `minos` binary for comparisons with the command line (MINOS_BIN, set
by tests/python_api.rs; tests that need it skip without it)."""

import os
import shutil
import subprocess
from pathlib import Path
from types import SimpleNamespace

import pytest

import minos


@pytest.fixture(scope="session")
def world(tmp_path_factory) -> SimpleNamespace:
    d = tmp_path_factory.mktemp("minos")
    gen, data = d / "gen", d / "DATA"
    generated = minos.generate(gen, houses=2, seed=3, rooms=(2, 3), levels=(1, 1))
    ingested = minos.ingest(gen, data)
    baked = minos.bake(data, previews=False)
    point = d / "point.parquet"
    minos.sample_episodes(data, "pointgoal", point, per_scene=3, seed=1, max_steps=300)
    objects = d / "object.parquet"
    minos.sample_episodes(data, "objectgoal", objects, per_scene=2, seed=1, max_steps=300)
    episodes = minos.read_episodes(point)
    return SimpleNamespace(
        root=d, gen=gen, data=data, point=point, objects=objects, episodes=episodes,
        scenes=sorted({e.scene_id for e in episodes}), generated=generated,
        ingested=ingested, baked=baked,
    )


@pytest.fixture(scope="session")
def minos_bin() -> Path:
    candidates = [os.environ.get("MINOS_BIN"), shutil.which("minos")]
    for c in candidates:
        if c and Path(c).is_file():
            return Path(c)
    pytest.skip("the minos binary was not found (set MINOS_BIN); CLI comparisons skipped")


def cli(minos_bin: Path, *args, ok: bool = True) -> subprocess.CompletedProcess:
    """Runs the binary; with ok=False expects a failure and returns it."""
    p = subprocess.run([str(minos_bin), "-q", *map(str, args)], capture_output=True, text=True)
    if ok:
        assert p.returncode == 0, p.stderr
    else:
        assert p.returncode != 0, p.stdout
    return p


def cli_error(p: subprocess.CompletedProcess) -> str:
    """The one-line message of a failed command (`error: MESSAGE`)."""
    lines = [l for l in p.stderr.splitlines() if l.startswith("error: ")]
    assert lines, p.stderr
    return lines[-1][len("error: "):]
