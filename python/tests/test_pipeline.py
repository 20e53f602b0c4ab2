"""minos.generate / ingest / bake / sample_episodes / run: the CLI's results and messages,
progress to Python."""

import hashlib
import json
import shutil
from pathlib import Path

import pytest

import minos
from conftest import cli, cli_error


class Bar:
    """A tqdm-like progress bar."""

    def __init__(self):
        self.total, self.n = None, 0

    def update(self, n):
        self.n += n

    def refresh(self):
        pass


def test_generate_resumes_and_reports_progress(world, tmp_path):
    assert len(world.generated["written"]) == 2 and world.generated["skipped"] == []
    seen = []
    again = minos.generate(world.gen, houses=2, seed=3, rooms=(2, 3), levels=(1, 1),
                           progress=lambda done, total: seen.append((done, total)))
    assert again["written"] == [] and sorted(again["skipped"]) == sorted(world.generated["written"])
    assert seen and seen[-1] == (2, 2)
    bar = Bar()
    out = tmp_path / "g"
    minos.generate(out, houses=1, seed=8, rooms=(1, 1), levels=(1, 1), progress=bar)
    assert (bar.total, bar.n) == (1, 1)
    assert (out / "house").is_dir()


def test_generate_writes_scan_like_matterport3d_houses_of_the_asked_size(tmp_path):
    # format="mp3d-scan" is `minos generate --scan`: Matterport3D's layout, the mesh a dense
    # scan of about `scan_triangles` triangles (the PLY header's face count, read here).
    out = tmp_path / "scans"
    got = minos.generate(out, houses=1, seed=2, rooms=(3, 4), levels=(1, 1),
                         format="mp3d-scan", scan_triangles=30_000)
    (house,) = got["written"]
    plys = list(out.rglob("*.ply"))
    assert plys and (out / house / "house_segmentations" / f"{house}.house").is_file()
    faces = 0
    with open(plys[0], "rb") as f:
        for line in f:
            if line.startswith(b"element face"):
                faces = int(line.split()[-1])
            if line.strip() == b"end_header":
                break
    assert 0.8 * 30_000 <= faces <= 30_000, faces
    with pytest.raises(Exception, match="mp3d-scan"):
        minos.generate(tmp_path / "x", houses=1, format="scan")


def test_generate_furnishes_densely_on_request(tmp_path):
    # furnishing="dense" is `minos generate --furnishing dense`: the same rooms' kinds of
    # furniture, more of them (house.json's Object nodes, doors and windows included).
    def objects(out):
        return sum(1 for h in out.glob("house/*/house.json")
                   for level in json.loads(h.read_text())["levels"]
                   for node in level["nodes"] if node["type"] == "Object")

    for name in ("standard", "dense"):
        minos.generate(tmp_path / name, houses=3, seed=5, rooms=(2, 2), levels=(1, 1),
                       furnishing=name)
    assert objects(tmp_path / "dense") > objects(tmp_path / "standard") + 3 * 4
    with pytest.raises(minos.BadInputError, match="standard, dense"):
        minos.generate(tmp_path / "x", houses=1, furnishing="sparse")


def test_generate_is_deterministic(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    for d in (a, b):
        minos.generate(d, houses=1, seed=4, rooms=(2, 2), levels=(1, 1))
    fa = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert fa == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert all((a / f).read_bytes() == (b / f).read_bytes() for f in fa)


def test_ingest_and_bake_report_like_the_cli(world):
    ing = world.ingested
    assert ing["compiled"] == 2 and ing["failed"] == 0
    assert sorted(s["id"] for s in ing["scenes"]) == world.scenes
    assert Path(ing["manifest"]).is_file()
    assert world.baked == {"baked": 2, "up_to_date": 0, "failed": {}, "replaced_body": {}}
    bar = Bar()
    again = minos.bake(world.data, previews=False, progress=bar)
    assert again == {"baked": 0, "up_to_date": 2, "failed": {}, "replaced_body": {}}
    assert (bar.total, bar.n) == (2, 2)
    minos.ingest(world.gen, world.data)  # generate above rewrote the category table
    up = minos.ingest(world.gen, world.data)
    assert up["up_to_date"] == 2 and up["compiled"] == 0


def test_a_bake_for_another_body_reports_the_grids_it_replaced(world, tmp_path):
    # A copy of the DATA folder (its grids are Habitat's), baked for MINOS's body: every
    # scene's grid is replaced, and the report names the body it was baked for.
    data = tmp_path / "DATA"
    shutil.copytree(world.data, data)
    rep = minos.bake(data, preset="minos", previews=False)
    assert rep["baked"] == 2 and set(rep["replaced_body"]) == set(world.scenes)
    assert all("height 1.5 m" in body and "(habitat)" in body
               for body in rep["replaced_body"].values()), rep
    assert minos.bake(data, preset="minos", previews=False)["replaced_body"] == {}


def test_errors_carry_the_cli_message(world, tmp_path, minos_bin):
    missing = tmp_path / "missing"
    with pytest.raises(minos.MinosError) as e:
        minos.ingest(missing, tmp_path / "D")
    p = cli(minos_bin, "ingest", "--root", missing, "--out", tmp_path / "D2", ok=False)
    assert str(e.value) == cli_error(p).replace("D2", "D")
    with pytest.raises(minos.MinosError) as e:
        minos.bake(tmp_path / "nodata")
    p = cli(minos_bin, "bake", "--data", tmp_path / "nodata", ok=False)
    # The same line, but the fix in each front door's words.
    assert str(e.value) == cli_error(p).replace(
        "(run `minos ingest` first)", "(call minos.ingest(...) first)")
    with pytest.raises(minos.MinosError) as e:
        minos.run(world.data, world.point, "greedy", tmp_path / "r")
    p = cli(minos_bin, "run", "--data", world.data, "--episodes", world.point,
            "--agent", "greedy", "--out", tmp_path / "r", ok=False)
    # The same library error; each door names its own spelling of the option.
    assert str(e.value) == cli_error(p).replace("--agent: ", "agent: ", 1)
    with pytest.raises(minos.MinosError) as e:
        minos.sample_episodes(world.data, "pointgoal", tmp_path / "e.parquet", split="nosplit")
    p = cli(minos_bin, "episodes", "--data", world.data, "--task", "pointgoal",
            "--split", "nosplit", "--out", tmp_path / "e.parquet", ok=False)
    assert str(e.value) == cli_error(p)


def test_episodes_equal_the_cli(world, tmp_path, minos_bin):
    out = tmp_path / "cli.parquet"
    cli(minos_bin, "episodes", "--data", world.data, "--task", "pointgoal", "--per-scene", "3",
        "--seed", "1", "--max-steps", "300", "--out", out)
    assert out.read_bytes() == world.point.read_bytes()
    stats = json.loads(Path(str(world.point) + ".stats.json").read_text())
    assert stats["total"] == len(world.episodes) == 6
    s = minos.sample_episodes(world.data, "roomgoal", tmp_path / "r.parquet", per_scene=2,
                              room_types=["bedroom", "kitchen", "living_room", "bathroom"])
    assert s["total"] == len(minos.read_episodes(tmp_path / "r.parquet"))
    assert all(e.task == "roomgoal" for e in minos.read_episodes(tmp_path / "r.parquet"))


def test_imported_minos_tables_equal_the_cli(world, tmp_path, minos_bin):
    e = world.episodes[0]
    x, y, z = e.start_position
    table = tmp_path / "states.csv"
    table.write_text(
        "split,sceneId,roomId,roomType,startX,startY,startZ,startAngle,goalObjectId,goalX,goalY,goalZ\n"
        f"test,{e.scene_id},0_2,Kitchen,{x},{y + 0.545},{z},0,,{x + 1},{y},{z}\n"
    )
    r = minos.import_episodes(table, "minos-csv", out=tmp_path / "py.parquet", task="roomgoal")
    assert (r["scenes"], r["out"], r["provenance"]) == (
        1, tmp_path / "py.parquet", tmp_path / "py.parquet.provenance.json")
    [got] = r["episodes"]
    assert (got.task, got.scene_id) == ("roomgoal", e.scene_id)
    assert abs(got.start_position[1] - y) < 1e-5
    cli(minos_bin, "episodes", "import", "--from", "minos-csv", table, "--task", "roomgoal",
        "--out", tmp_path / "cli.parquet")
    assert (tmp_path / "cli.parquet").read_bytes() == (tmp_path / "py.parquet").read_bytes()
    # Without out nothing is written; a Habitat file is not read as another task.
    assert minos.import_episodes(table, "minos-csv")["out"] is None
    assert minos.import_episodes(table, "minos-csv")["episodes"][0].task == "pointgoal"
    with pytest.raises(minos.BadInputError, match="cannot be read as roomgoal episodes"):
        minos.import_episodes(table, "habitat", task="roomgoal")
    with pytest.raises(minos.BadInputError, match="format"):
        minos.import_episodes(table, "habitat-json")


def test_vln_episodes_and_their_export_equal_the_cli_with_provenance(world, tmp_path, minos_bin):
    # One library job behind both doors: the same episode file, statistics and VLN-CE export,
    # and a provenance record whose checksums are the files' (recomputed here).
    py_out, cli_out = tmp_path / "py.parquet", tmp_path / "cli.parquet"
    s = minos.sample_episodes(world.data, "vln", py_out, per_scene=2, seed=1,
                              export_vlnce=tmp_path / "py_vlnce")
    cli(minos_bin, "episodes", "--data", world.data, "--task", "vln", "--per-scene", "2",
        "--seed", "1", "--out", cli_out, "--export", "vlnce", tmp_path / "cli_vlnce")
    assert s["total"] > 0 and py_out.read_bytes() == cli_out.read_bytes()
    assert all(e.task == "vln" for e in minos.read_episodes(py_out))
    py_files = sorted(p.relative_to(tmp_path / "py_vlnce")
                      for p in (tmp_path / "py_vlnce").rglob("*") if p.is_file())
    cli_files = sorted(p.relative_to(tmp_path / "cli_vlnce")
                       for p in (tmp_path / "cli_vlnce").rglob("*") if p.is_file())
    assert py_files and py_files == cli_files
    for rel in py_files:
        assert (tmp_path / "py_vlnce" / rel).read_bytes() == \
            (tmp_path / "cli_vlnce" / rel).read_bytes(), rel
    record = json.loads(Path(s["provenance"]).read_text())
    assert record["kind"] == "episodes" and record["seed"] == 1
    for path in (py_out, Path(s["stats"])):
        data = path.read_bytes()
        assert record["files"][path.name] == {"sha256": hashlib.sha256(data).hexdigest(),
                                              "bytes": len(data)}
    with pytest.raises(minos.MinosError, match="need task"):
        minos.sample_episodes(world.data, "pointgoal", tmp_path / "x.parquet",
                              export_r2r=tmp_path / "r2r")
    # The library's rule, with the keyword in front: more than one instance per category is
    # ObjectGoal's alone.
    with pytest.raises(minos.BadInputError, match="^min_instances: at least 2 instances"):
        minos.sample_episodes(world.data, "pointgoal", tmp_path / "x.parquet", min_instances=2)
    assert not (tmp_path / "x.parquet").exists()


def test_run_writes_what_the_cli_writes(world, tmp_path, minos_bin):
    bar = Bar()
    rep = minos.run(world.data, world.objects, "oracle", tmp_path / "py", size=16, seed=2,
                    progress=bar)
    assert rep["failures"] == [] and rep["groups"]["all"]["success"] == 1.0
    assert (bar.total, bar.n) == (rep["episodes"], rep["episodes"])
    assert rep["steps"] == sum(m["steps"] for m in rep["metrics"])
    cli(minos_bin, "run", "--data", world.data, "--episodes", world.objects, "--agent",
        "oracle", "--size", "16", "--seed", "2", "--out", tmp_path / "cli")
    for name in ["trajectories.parquet", "observations.parquet", "episodes.parquet",
                 "metrics.json"]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name


def test_run_takes_the_clis_video_and_batch_options(world, tmp_path, minos_bin):
    # `video=True, video_qp=Q` is `--format lerobot --video --video-qp Q`: the same dataset
    # files; `batch=N` is `--batch N`: lockstep batches write the bytes of one simulator per
    # thread.
    minos.run(world.data, world.point, "oracle", tmp_path / "py", size=16, format="lerobot",
              video=True, video_qp=34, batch=3)
    cli(minos_bin, "run", "--data", world.data, "--episodes", world.point, "--agent", "oracle",
        "--size", "16", "--format", "lerobot", "--video", "--video-qp", "34",
        "--out", tmp_path / "cli")
    info = json.loads((tmp_path / "py" / "lerobot" / "meta" / "info.json").read_text())
    assert info["features"]["observation.images.color"]["info"]["minos.video_qp"] == 34
    videos = sorted(p.relative_to(tmp_path / "py")
                    for p in (tmp_path / "py" / "lerobot" / "videos").rglob("*.mp4"))
    assert videos, "video=True writes the colour cameras as MP4 files"
    for name in videos + [Path("lerobot/meta/info.json"), Path("episodes.parquet"),
                          Path("trajectories.parquet")]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    with pytest.raises(minos.MinosError, match="video are a feature of the LeRobot copy"):
        minos.run(world.data, world.point, "oracle", tmp_path / "no", size=16, video=True)
    with pytest.raises(ValueError, match="not an H.264 quantiser"):
        minos.run(world.data, world.point, "oracle", tmp_path / "no", size=16, format="lerobot",
                  video=True, video_qp=52)
    with pytest.raises(ValueError, match="needs video=True"):
        minos.run(world.data, world.point, "oracle", tmp_path / "no", size=16, format="lerobot",
                  video_qp=30)


def test_verify_and_diff_report_what_the_cli_prints(world, tmp_path, minos_bin):
    # Python's run writes no sidecar record for the episode file: the sampled file is checked
    # on the grids (and its missing sidecar reported), the run folder is clean.
    minos.run(world.data, world.point, "oracle", tmp_path / "a", size=16, seed=2,
              max_steps=60)
    rep = minos.verify(tmp_path / "a")
    assert rep["clean"] and rep["kind"] == "run folder" and rep["problems"] == [], rep
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    assert minos.diff(tmp_path / "a", tmp_path / "b")["identical"]
    m = tmp_path / "b" / "metrics.json"
    metrics = json.loads(m.read_text())
    spl = metrics["groups"]["all"]["spl"]
    metrics["groups"]["all"]["spl"] = 0.125
    m.write_text(json.dumps(metrics))
    d = minos.diff(tmp_path / "a", tmp_path / "b")
    assert not d["identical"]
    # The line names the value's path and both values (a float as minos's JSON reader parses
    # it: within one unit in the last place of the file's text).
    [line] = d["differences"]
    head, tail = "metrics.json: `groups.all.spl`: ", " vs 0.125"
    assert line.startswith(head) and line.endswith(tail), line
    assert float(line[len(head):-len(tail)]) == pytest.approx(spl, rel=1e-15), line
    bad = minos.verify(tmp_path / "b")
    cli_lines = cli(minos_bin, "verify", tmp_path / "b", ok=False).stdout.splitlines()
    assert bad["problems"] == cli_lines
    assert bad["problems"][0].startswith(f"{tmp_path / 'b' / 'metrics.json'}: checksum: ")


def test_errors_raise_the_subclass_of_their_kind(world, tmp_path):
    import fcntl

    def raised(f):
        with pytest.raises(minos.MinosError) as e:
            f()
        assert "\n" not in str(e.value)
        return type(e.value)

    # A file or folder that does not exist.
    assert raised(lambda: minos.read_episodes(tmp_path / "nope.parquet")) is minos.NotFoundError
    assert raised(lambda: minos.ingest(tmp_path / "missing", tmp_path / "D")) \
        is minos.NotFoundError
    # Input that is not valid: a file that is not Parquet, a sensor file naming no modality.
    garbage = tmp_path / "garbage.parquet"
    garbage.write_bytes(b"not parquet" * 8)
    assert raised(lambda: minos.read_episodes(garbage)) is minos.BadInputError
    bad = tmp_path / "bad.toml"
    bad.write_text('[[camera]]\nname = "a"\nmodality = "smell"\nresolution = [8, 8]\n')
    scene = world.scenes[0]
    assert raised(lambda: minos.Simulator(world.data, scene, sensors=bad)) \
        is minos.BadInputError
    # Grids baked for Habitat's body, an agent with MINOS's: the fix in Python's words.
    with pytest.raises(minos.BodyMismatchError) as e:
        minos.Simulator(world.data, scene, agent="minos")
    assert 'minos.bake(data, preset="minos", force=True)' in str(e.value), e.value
    assert "allow_body_mismatch=True" in str(e.value) and " --" not in str(e.value), e.value
    # A scene that is not ingested; scenes whose grids are gone.
    assert raised(lambda: minos.Simulator(world.data, "no-such-scene")) is minos.NotReadyError
    # A scene that is not ingested: the remedy in Python's words, no command line.
    with pytest.raises(minos.NotReadyError) as e:
        minos.Simulator(world.data, "no-such-scene")
    assert "call minos.ingest(...) first" in str(e.value) and "`minos" not in str(e.value), \
        e.value
    # A split that does not exist: named as the keyword, not as the CLI's flag.
    with pytest.raises(minos.MinosError) as e:
        minos.bake(world.data, split="nosplit", previews=False)
    assert str(e.value).startswith('split="nosplit": ') and "--split" not in str(e.value), \
        e.value
    # A DATA folder nothing was ingested into: not ready (not a missing file), with the step.
    empty = tmp_path / "EMPTY"
    empty.mkdir()
    with pytest.raises(minos.NotReadyError) as e:
        minos.bake(empty, previews=False)
    assert "call minos.ingest(...) first" in str(e.value), e.value
    data = tmp_path / "DATA"
    shutil.copytree(world.data, data)
    shutil.rmtree(data / "nav")
    assert raised(lambda: minos.run(data, world.point, "oracle", tmp_path / "r")) \
        is minos.NotReadyError
    # Another writer holds the DATA folder's lock.
    with open(data / ".minos.lock", "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert raised(lambda: minos.bake(data, previews=False)) is minos.LockedError
        for call in (lambda: minos.bake(data, previews=False),
                     lambda: minos.split(data, "s", ratios=(1, 0, 0)),
                     lambda: minos.variants(data, name="e", empty=True)):
            with pytest.raises(minos.LockedError) as e:
                call()
            assert str(e.value).endswith("(or pass wait=True to wait for it)"), e.value
            assert "--wait" not in str(e.value), e.value
    # Every subclass is a MinosError, so `except minos.MinosError` still catches them all.
    for cls in (minos.BadInputError, minos.BodyMismatchError, minos.LockedError,
                minos.NotFoundError, minos.NotReadyError):
        assert issubclass(cls, minos.MinosError)


def test_ingest_and_bake_write_the_data_folders_provenance(world):
    # The library's drivers write DATA/provenance.json, so Python's ingest and bake leave the
    # record the CLI's do: every file with its sha256, the record itself left out.
    data = Path(world.data)
    record = json.loads((data / "provenance.json").read_text())
    assert record["kind"] == "data"
    files = record["files"]
    wanted = ["houses.parquet"] + [f"nav/{s}.nav" for s in world.scenes] \
        + [f"scenes/{s}.mscene" for s in world.scenes]
    for f in wanted:
        assert files[f]["sha256"] == hashlib.sha256((data / f).read_bytes()).hexdigest(), f
    assert "provenance.json" not in files
