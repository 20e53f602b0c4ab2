"""`minos.split` and `minos.variants`: the DATA folder's splits and scene variants written
in-process by the drivers the command line calls, byte for byte as the CLI writes them."""

import shutil
from pathlib import Path

import pytest

import minos
from conftest import cli


def copy_data(world, tmp_path: Path) -> Path:
    data = tmp_path / "DATA"
    shutil.copytree(world.data, data)
    return data


def lists_of(data: Path, name: str) -> dict:
    return {s: (data / "splits" / name / f"{s}.txt").read_text() for s in ("train", "val", "test")}


def test_ratio_and_list_splits_write_what_the_cli_writes(world, tmp_path, minos_bin):
    data = copy_data(world, tmp_path)
    got = minos.split(data, "py", ratios=(0.5, 0.0, 0.5), seed=4)
    cli(minos_bin, "split", "--data", data, "--name", "cli", "--ratios", "0.5,0,0.5",
        "--seed", "4")
    assert lists_of(data, "py") == lists_of(data, "cli")
    assert Path(got["dir"]) == data / "splits" / "py"
    assert sorted(got["train"] + got["test"]) == world.scenes and got["val"] == []
    assert (data / "provenance.json").is_file()

    # Lists in memory: the listed scenes that are in DATA, the rest reported.
    a, b = world.scenes
    got = minos.split(data, "given", lists={"train": [b], "test": [a, "ghost"]})
    assert (got["train"], got["val"], got["test"]) == ([b], [], [a])
    assert got["missing"] == ["ghost"] and got["unlisted"] == 0
    assert lists_of(data, "given") == {"train": b + "\n", "val": "", "test": a + "\n"}
    # The same lists from a folder, and through the CLI's --lists.
    folder = tmp_path / "lists"
    folder.mkdir()
    for subset, text in lists_of(data, "given").items():
        (folder / f"{subset}.txt").write_text(text)
    minos.split(data, "folder", lists=folder)
    cli(minos_bin, "split", "--data", data, "--name", "cli-folder", "--lists", folder)
    assert lists_of(data, "folder") == lists_of(data, "given") == lists_of(data, "cli-folder")
    # A filter drops scenes that pass no test; `where` is the CLI's --where.
    got = minos.split(data, "none", ratios=(1, 0, 0), where="nrooms > 100")
    assert got["train"] == [] and got["filtered_out"] == len(world.scenes)


def test_bad_splits_raise_the_kind_of_their_error_and_write_nothing(world, tmp_path):
    data = copy_data(world, tmp_path)
    a = world.scenes[0]
    with pytest.raises(minos.MinosError, match="exactly one of lists= and ratios="):
        minos.split(data, "x", lists={"train": [a]}, ratios=(1, 0, 0))
    with pytest.raises(minos.MinosError, match="exactly one"):
        minos.split(data, "x")
    with pytest.raises(minos.BadInputError, match="summing to 1"):
        minos.split(data, "x", ratios=(0.5, 0.5, 0.5))
    with pytest.raises(minos.BadInputError, match=f"id `{a}` is listed in both train and test"):
        minos.split(data, "x", lists={"train": [a], "test": [a]})
    with pytest.raises(minos.MinosError, match="unknown subset `tset`"):
        minos.split(data, "x", lists={"tset": [a]})
    with pytest.raises(minos.MinosError, match="a list of scene ids, not a string"):
        minos.split(data, "x", lists={"train": a})
    with pytest.raises(minos.BadInputError, match='^lists="nolists": `nolists` is neither'):
        minos.split(data, "x", lists="nolists")
    with pytest.raises(minos.BadInputError, match="^name: split name `../x`"):
        minos.split(data, "../x", ratios=(1, 0, 0))
    with pytest.raises(minos.BadInputError, match="^where: "):
        minos.split(data, "x", ratios=(1, 0, 0), where="nrooms >")
    assert not (data / "splits" / "x").exists()
    empty = tmp_path / "EMPTY"
    empty.mkdir()
    with pytest.raises(minos.NotReadyError, match=r"call minos.ingest\(...\) first"):
        minos.split(empty, "x", ratios=(1, 0, 0))
    assert list(empty.iterdir()) == []


def test_variants_are_defined_as_the_cli_defines_them(world, tmp_path, minos_bin):
    data = copy_data(world, tmp_path)
    # A variant nobody defined: the remedy in Python's words.
    with pytest.raises(minos.MinosError) as e:
        minos.bake(data, variant="never-defined", previews=False)
    assert "minos.variants(data, name=NAME, ...)" in str(e.value), e.value
    assert "`minos" not in str(e.value), e.value

    got = minos.variants(data, name="py-empty", empty=True)
    v = got["variants"]["py-empty"]
    assert got["stats"] is None
    assert v["scenes"] == len(world.scenes) and v["failed"] == {}
    assert v["removed"] > 0 and v["changes_geometry"]
    assert Path(v["path"]) == data / "variants" / "py-empty.toml"
    cli(minos_bin, "variants", "--data", data, "--name", "cli-empty", "--empty")
    # The same file but for the name in its first line.
    py_file = (data / "variants" / "py-empty.toml").read_text().splitlines()
    cli_file = (data / "variants" / "cli-empty.toml").read_text().splitlines()
    assert py_file[0].replace("py-empty`", "cli-empty`") == cli_file[0]
    assert py_file[1:] == cli_file[1:] and "empty = true" in py_file
    # Baked and loaded as `<scene>@py-empty`.
    assert minos.bake(data, variant="py-empty", previews=False)["baked"] == len(world.scenes)
    assert (data / "nav" / f"{world.scenes[0]}@py-empty.nav").is_file()

    # Retexturing computes the material statistics first; a spec file defines several.
    spec = tmp_path / "variants.toml"
    spec.write_text('[tex]\nretexture = { seed = 7, texture_set = "val" }\n\n'
                    '[open]\nopen_doors = true\n')
    got = minos.variants(data, spec=spec)
    assert sorted(got["variants"]) == ["open", "tex"]
    stats = got["stats"]
    assert stats["scenes"] == len(world.scenes) and stats["materials"] > 0
    assert sum(stats["per_set"].values()) == stats["materials"]
    assert Path(stats["path"]).is_file()
    tex = got["variants"]["tex"]
    assert tex["slots_redrawn"] + tex["slots_kept"] > 0 and not tex["changes_geometry"]
    # The statistics exist now: not computed again unless asked.
    assert minos.variants(data, name="tex2", retexture_seed=1)["stats"] is None
    assert minos.variants(data, name="tex3", retexture_seed=1,
                          refresh_stats=True)["stats"] is not None


def test_bad_variants_raise_before_writing(world, tmp_path):
    data = copy_data(world, tmp_path)
    defined = sorted((data / "variants").glob("*")) if (data / "variants").exists() else []
    with pytest.raises(minos.BadInputError,
                       match=r"^variant same: no change given \(pass remove=, "):
        minos.variants(data, name="same")
    same = tmp_path / "same.toml"
    same.write_text("[open]\nopen_doors = true\n[same]\n")
    with pytest.raises(minos.BadInputError, match="^variant same: no change given$"):
        minos.variants(data, spec=same)
    with pytest.raises(minos.MinosError, match="exactly one of spec=FILE and name=NAME"):
        minos.variants(data)
    with pytest.raises(minos.BadInputError, match="^variant both: "):
        minos.variants(data, name="both", empty=True, keep_only=["chair"])
    with pytest.raises(minos.BadInputError, match="^variant a/b: "):
        minos.variants(data, name="a/b", empty=True)
    with pytest.raises(minos.MinosError, match="unknown texture set `green`"):
        minos.variants(data, name="t", retexture_seed=1, texture_set="green")
    bad = tmp_path / "bad.toml"
    bad.write_text("[x]\nempty = 3\n")
    with pytest.raises(minos.BadInputError, match=f"^spec: {bad}"):
        minos.variants(data, spec=bad)
    now = sorted((data / "variants").glob("*")) if (data / "variants").exists() else []
    assert now == defined
