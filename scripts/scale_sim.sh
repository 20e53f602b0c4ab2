#!/usr/bin/env bash
# A simulated large run on one machine: HOUSES generated houses through the whole pipeline
# (ingest → bake → episodes → run) with every long stage split into SHARDS separate
# processes (PARALLEL at a time), merged with `minos merge`; then the unsharded pipeline on a
# SUBSET of the houses, checked equal to the merged outputs restricted to those houses.
# Prints wall time per stage and each process's peak memory (GNU time).
#
#   scripts/scale_sim.sh                       # 1000 houses, 16 shards, 100-house subset
#   HOUSES=200 SHARDS=4 SUBSET=20 scripts/scale_sim.sh
#
# Needs a release build (`cargo build --release`) and, for the subset check, a Python with
# pyarrow ($PYTHON, default python3). Work folder: $WORK (default a new temporary folder).
set -euo pipefail
cd "$(dirname "$0")/.."
HOUSES=${HOUSES:-1000}
SHARDS=${SHARDS:-16}
SUBSET=${SUBSET:-100}
PARALLEL=${PARALLEL:-$(nproc)}
PER_SCENE=${PER_SCENE:-2}
PYTHON=${PYTHON:-python3}
MINOS=${MINOS:-${CARGO_TARGET_DIR:-$PWD/target}/release/minos}
WORK=${WORK:-$(mktemp -d -t minos-scale-XXXXXX)}
mkdir -p "$WORK/logs"
echo "work folder: $WORK; $HOUSES houses, $SHARDS shards, $PARALLEL at a time"

# Runs "$@" under GNU time, appending "<label> <seconds> <peak kB>" to $WORK/logs/usage.
timed() {
    local label=$1
    shift
    /usr/bin/time -f "$label %e %M" -a -o "$WORK/logs/usage" "$@" >"$WORK/logs/$label.log" 2>&1 ||
        { echo "$label failed:"; tail -5 "$WORK/logs/$label.log"; return 1; }
}
export -f timed
export WORK MINOS

stage() { # stage NAME COMMAND-TEMPLATE (with {i} for the shard index)
    local name=$1 template=$2 start=$SECONDS
    seq 0 $((SHARDS - 1)) | xargs -P "$PARALLEL" -I{} bash -c "timed $name-{} ${template//\{n\}/$SHARDS}"
    echo "$name: $SHARDS shards in $((SECONDS - start)) s"
}

start=$SECONDS
timed generate "$MINOS" -q generate --houses "$HOUSES" --seed 1 --rooms 3..6 --out "$WORK/suncg"
timed ingest "$MINOS" -q ingest --dataset suncg --root "$WORK/suncg" --out "$WORK/DATA"
echo "generate + ingest: $((SECONDS - start)) s"
stage bake "$MINOS -q bake --no-preview --data $WORK/DATA --shard {}/{n}"
stage episodes "$MINOS -q episodes --data $WORK/DATA --task pointgoal --per-scene $PER_SCENE --seed 2 --shard {}/{n} --out $WORK/eps/part-{}.parquet"
s=$SECONDS
timed merge-episodes "$MINOS" -q merge --out "$WORK/eps/all.parquet" "$WORK"/eps/part-*.parquet
echo "merge episodes: $((SECONDS - s)) s"
stage run "$MINOS -q run --data $WORK/DATA --episodes $WORK/eps/all.parquet --agent oracle --threads 1 --shard {}/{n} --out $WORK/runs/shard-{}"
s=$SECONDS
timed merge-run "$MINOS" -q merge --out "$WORK/runs/all" "$WORK"/runs/shard-*
echo "merge run: $((SECONDS - s)) s; whole sharded pipeline: $((SECONDS - start)) s"

# The unsharded pipeline on a subset of the houses.
s=$SECONDS
ls "$WORK/suncg/house" | sort | head -n "$SUBSET" >"$WORK/subset.txt"
timed sub-ingest "$MINOS" -q ingest --dataset suncg --root "$WORK/suncg" --ids "$WORK/subset.txt" --out "$WORK/SUB"
timed sub-bake "$MINOS" -q bake --no-preview --data "$WORK/SUB"
timed sub-episodes "$MINOS" -q episodes --data "$WORK/SUB" --task pointgoal --per-scene "$PER_SCENE" --seed 2 --out "$WORK/sub-eps.parquet"
timed sub-run "$MINOS" -q run --data "$WORK/SUB" --episodes "$WORK/sub-eps.parquet" --agent oracle --out "$WORK/sub-run"
echo "unsharded subset pipeline: $((SECONDS - s)) s"

"$PYTHON" - "$WORK" <<'PY'
import sys, pyarrow.parquet as pq, pyarrow.compute as pc
work = sys.argv[1]
subset = set(open(f"{work}/subset.txt").read().split())
def restricted(path, key="scene_id"):
    t = pq.read_table(path)
    return t.filter(pc.is_in(t[key], value_set=__import__("pyarrow").array(sorted(subset))))
def check(name, merged, alone, key="scene_id"):
    a, b = restricted(merged, key), pq.read_table(alone)
    assert a.num_rows == b.num_rows > 0, f"{name}: {a.num_rows} rows vs {b.num_rows}"
    assert a.equals(b), f"{name}: rows differ"
    print(f"{name}: {b.num_rows} rows of the subset equal")
check("episodes", f"{work}/eps/all.parquet", f"{work}/sub-eps.parquet")
check("run episodes", f"{work}/runs/all/episodes.parquet", f"{work}/sub-run/episodes.parquet")
ids = set(pq.read_table(f"{work}/sub-run/episodes.parquet")["episode_id"].to_pylist())
for table in ["trajectories", "observations"]:
    t = pq.read_table(f"{work}/runs/all/{table}.parquet")
    a = t.filter(pc.is_in(t["episode_id"], value_set=__import__("pyarrow").array(sorted(ids))))
    b = pq.read_table(f"{work}/sub-run/{table}.parquet")
    assert a.num_rows == b.num_rows > 0 and a.equals(b), f"{table}: rows differ"
    print(f"{table}: {b.num_rows} rows of the subset equal")
PY

echo "peak memory per process (MB), by stage:"
awk '{ split($1, p, "-"); s = p[1]; if (p[1] == "merge" || p[1] == "sub") s = p[1] "-" p[2];
       if ($3 > m[s]) m[s] = $3; t[s] += $2; n[s]++ }
     END { for (s in m) printf "  %-16s %3d process(es), %8.1f s total, peak %6.0f MB\n", s, n[s], t[s], m[s] / 1024 }' \
    "$WORK/logs/usage" | sort
