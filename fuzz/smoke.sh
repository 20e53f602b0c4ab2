#!/usr/bin/env bash
# Builds seed corpora from files minos makes itself (plus the real samples in
# ../shared/datasets when present) and runs every cargo-fuzz target briefly.
#
#   fuzz/smoke.sh                 # every target, 20 s each
#   SECONDS_PER_TARGET=600 fuzz/smoke.sh nav mscene
#   SECONDS_PER_TARGET=10800 RUNS_PER_TARGET=10000000 CPU_SECONDS_PER_TARGET=1800 fuzz/smoke.sh
#                                 # the long runs of docs/RELIABILITY.md
#   FUZZ_CORPUS_ONLY=1 FUZZ_WORK=/tmp/fz fuzz/smoke.sh   # only build the corpora
#
# Needs the nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`). Corpora and
# artifacts live under $FUZZ_WORK (default: a new temporary folder), never in the repository.
# Exit status: non-zero when a target finds a crash (its input is under $FUZZ_WORK/artifacts).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
WORK=${FUZZ_WORK:-$(mktemp -d -t minos-fuzz-XXXXXX)}
SECS=${SECONDS_PER_TARGET:-20}
SHARED=${MINOS_SHARED:-$ROOT/../shared/datasets}
# A worktree under wt/ finds shared/ one level further up.
[ -d "$SHARED" ] || SHARED=$ROOT/../../shared/datasets
ALL=(mscene nav suncg_house obj_mtl gltf gltf_scene episodes_parquet habitat_json minos_csv config_toml
     external_reply mp3d_house mp3d_ply threedfront)
TARGETS=("${@:-${ALL[@]}}")
mkdir -p "$WORK"
echo "fuzz work folder: $WORK"

# --- minos-made inputs: a few generated houses through the whole pipeline -----------------
GEN=$WORK/gen
if [ ! -f "$GEN/done" ]; then
    cargo build --quiet
    MINOS=${CARGO_TARGET_DIR:-$ROOT/target}/debug/minos
    rm -rf "$GEN" && mkdir -p "$GEN"
    "$MINOS" -q generate --houses 4 --seed 3 --rooms 1..4 --out "$GEN/suncg"
    "$MINOS" -q generate --format mp3d --houses 2 --seed 3 --rooms 1..3 --out "$GEN/mp3d"
    "$MINOS" -q ingest --dataset suncg --root "$GEN/suncg" --out "$GEN/DATA"
    "$MINOS" -q bake --data "$GEN/DATA"
    "$MINOS" -q episodes --data "$GEN/DATA" --task pointgoal --per-scene 5 --seed 1 \
        --out "$GEN/eps/points.parquet" --export habitat "$GEN/eps/habitat"
    # Small grids (one or two rooms, 0.2 m cells) for the .nav corpus: tens of kB each.
    printf 'cell_size = 0.2\n' > "$GEN/coarse.toml"
    "$MINOS" -q generate --houses 3 --seed 5 --rooms 1..2 --levels 1..1 --out "$GEN/small"
    "$MINOS" -q ingest --dataset suncg --root "$GEN/small" --out "$GEN/SMALL"
    "$MINOS" -q bake --data "$GEN/SMALL" --config "$GEN/coarse.toml"
    "$MINOS" -q export --data "$GEN/DATA" --scene "$(ls "$GEN/DATA/scenes" | head -1 | sed 's/\.mscene$//')" \
        --out "$GEN/house.glb"
    touch "$GEN/done"
fi

corpus() { # corpus TARGET FILE... : copies files (at most 256 kB each) into TARGET's corpus
    local t=$1; shift
    mkdir -p "$WORK/corpus/$t"
    for f in "$@"; do
        [ -f "$f" ] || continue
        [ "$(stat -c %s "$f")" -le 262144 ] || continue
        cp "$f" "$WORK/corpus/$t/$(sha1sum "$f" | cut -c1-16)"
    done
}
gunzip_to() { # gunzip_to DIR FILE... : plain copies of .json.gz files
    mkdir -p "$1"; local d=$1; shift
    for f in "$@"; do [ -f "$f" ] && gunzip -c "$f" | head -c 262144 > "$d/$(basename "$f" .gz)" || true; done
}

corpus mscene "$GEN"/DATA/scenes/*.mscene
corpus nav "$GEN"/SMALL/nav/*.nav "$GEN"/DATA/nav/*.nav
corpus suncg_house "$GEN"/suncg/house/*/house.json "$SHARED"/suncg/house/*/house.json
mkdir -p "$WORK/objmtl"
for obj in "$GEN"/suncg/object/*/*.obj "$GEN"/suncg/room/*/*.obj; do
    [ -f "$obj" ] || continue
    out="$WORK/objmtl/$(basename "$(dirname "$obj")")_$(basename "$obj")"
    { cat "$obj"; printf '\n%%%%MTL\n'; cat "${obj%.obj}.mtl" 2>/dev/null || true; } > "$out"
done
corpus obj_mtl $(ls "$WORK"/objmtl/* | head -200)
corpus gltf "$GEN/house.glb" $(find "$SHARED/gltf_habitat" -name '*.glb' -size -256k 2>/dev/null | head -20) \
    $(find "$SHARED/gltf_habitat" -name '*.gltf' -size -256k 2>/dev/null | head -20)
# A glTF scene root (gltf_scene replaces one of its files per input): a minos-made house as a
# stage with a scene instance placing an object, a semantic config, and Habitat's test dataset.
GROOT=$WORK/gltfroot
if [ ! -d "$GROOT" ]; then
    mkdir -p "$GROOT/stages" "$GROOT/objects"
    cp "$GEN/house.glb" "$GROOT/stages/house.glb"
    echo '{"render_asset": "house.glb", "up": [0, 1, 0], "front": [0, 0, -1]}' > "$GROOT/stages/house.stage_config.json"
    cp "$(find "$SHARED/gltf_habitat" -name 5boxes.glb 2>/dev/null | head -1 || true)" "$GROOT/objects/box.glb" 2>/dev/null \
        || cp "$GEN/house.glb" "$GROOT/objects/box.glb"
    echo '{"render_asset": "box.glb", "mass": 1}' > "$GROOT/objects/box.object_config.json"
    cat > "$GROOT/house.scene_instance.json" <<'JSON'
{"translation_origin": "com", "stage_instance": {"template_name": "house"},
 "object_instances": [{"template_name": "box", "translation": [1.0, 0.0, 2.0],
   "rotation": [0.7071, 0.0, 0.7071, 0.0], "non_uniform_scale": [2.0, 1.0, 1.0],
   "motion_type": "STATIC"}],
 "semantic_scene_instance": "house"}
JSON
    cat > "$GROOT/house.semantic_config.json" <<'JSON'
{"region_annotations": [{"name": "r0", "label": "bedroom",
  "poly_loop": [[0, 0, 0], [4, 0, 0], [4, 0, 4], [0, 0, 4]], "floor_height": 0.0,
  "extrusion_height": 2.5, "min_bounds": [0, 0, 0], "max_bounds": [4, 2.5, 4]}]}
JSON
    printf 'raw_category\tcategory\tmpcat40\nchair\tchair\tchair\n' > "$GROOT/fuzz_category_mappings.tsv"
    d0=$(find "$SHARED/gltf_habitat" -type d -name dataset_0 2>/dev/null | head -1 || true)
    [ -n "$d0" ] && cp -r "$d0" "$GROOT/dataset_0" && chmod -R u+w "$GROOT/dataset_0"
fi
mkdir -p "$WORK/gltfscene"
(cd "$GROOT" && find . -type f | sed 's|^\./||') | while read -r rel; do
    { printf '%s\n' "$rel"; cat "$GROOT/$rel"; } > "$WORK/gltfscene/$(echo "$rel" | tr / _)"
done
corpus gltf_scene "$WORK"/gltfscene/*
corpus episodes_parquet "$GEN"/eps/*.parquet
gunzip_to "$WORK/habitat" $(find "$GEN/eps/habitat" "$SHARED/habitat_episodes" -name '*.json.gz' 2>/dev/null | head -20)
corpus habitat_json "$WORK"/habitat/*
mkdir -p "$WORK/csv"
# (`head` closing the pipe early makes bzcat exit with SIGPIPE: not a failure here.)
for f in "$SHARED"/minos/*.csv.bz2; do
    [ -f "$f" ] && { bzcat "$f" | head -n 200 > "$WORK/csv/$(basename "$f" .bz2)" || true; }
done
printf 'sceneId,level,startX,startY,startZ,startAngle,goalX,goalY,goalZ\nh,0,1,0,2,0.5,3,0,4\n' > "$WORK/csv/tiny.csv"
corpus minos_csv "$WORK"/csv/*
mkdir -p "$WORK/cfg"
printf '\x00[[cameras]]\nname = "rgb"\nmodality = "color"\nwidth = 64\nheight = 48\nvfov = 60.0\n' > "$WORK/cfg/sensors"
printf '\x01cell_size = 0.05\nagent_radius = 0.2\nagent_height = 1.5\n' > "$WORK/cfg/params"
printf '\x02[empty]\nempty = true\n[open]\ndoors = "open"\n' > "$WORK/cfg/variants"
for v in "$GEN"/DATA/variants/*.toml; do [ -f "$v" ] && { printf '\x02'; cat "$v"; } > "$WORK/cfg/$(basename "$v")"; done
corpus config_toml "$WORK"/cfg/*
mkdir -p "$WORK/replies"
echo '{"stop": true}' > "$WORK/replies/a"; echo '{"action": "forward"}' > "$WORK/replies/b"
echo '{"actions": {"forward": 1.0, "turn_left": 0.5}}' > "$WORK/replies/c"
corpus external_reply "$WORK"/replies/*
corpus mp3d_house "$GEN"/mp3d/*/house_segmentations/*.house "$SHARED"/matterport3d/house/*.house
corpus mp3d_ply $(find "$GEN/mp3d" "$SHARED/matterport3d" -name '*.ply' -size -256k 2>/dev/null | head -10)
# 3D-FRONT scenes are pretty-printed and often over the 256 kB limit: minified copies.
mkdir -p "$WORK/3dfront"
for f in $(find "$SHARED/3dfront" -name '*.json' 2>/dev/null | head -20); do
    python3 -c 'import json, sys; json.dump(json.load(open(sys.argv[1])), open(sys.argv[2], "w"), separators=(",", ":"))' \
        "$f" "$WORK/3dfront/$(basename "$f")" 2>/dev/null || true
done
corpus threedfront $(find "$WORK/3dfront" -name '*.json' -size -256k 2>/dev/null)

[ -n "${FUZZ_CORPUS_ONLY:-}" ] && { echo "corpora in $WORK/corpus"; exit 0; }

# --- run every target ----------------------------------------------------------------------
# Each target runs for SECONDS_PER_TARGET of wall time, or stops earlier at RUNS_PER_TARGET
# executions or CPU_SECONDS_PER_TARGET of its own CPU time (a fair limit when other work
# shares the machine; libFuzzer is interrupted and prints its final statistics).
export MINOS_FUZZ_SUNCG_ROOT=$GEN/suncg MINOS_FUZZ_GLTF_ROOT=$GROOT
HOST=$(rustc -vV | sed -n 's/^host: //p')
BIN=${CARGO_TARGET_DIR:-$ROOT/fuzz/target}/$HOST/release
status=0
for t in "${TARGETS[@]}"; do
    mkdir -p "$WORK/corpus/$t" "$WORK/artifacts/$t"
    echo "== $t (${SECS}s${RUNS_PER_TARGET:+, at most $RUNS_PER_TARGET runs}${CPU_SECONDS_PER_TARGET:+, at most ${CPU_SECONDS_PER_TARGET}s of CPU})"
    cargo +nightly fuzz build -O --debug-assertions "$t"
    args=(-max_total_time="$SECS" -artifact_prefix="$WORK/artifacts/$t/" -max_len=262144
          -rss_limit_mb=4096 -print_final_stats=1)
    [ -n "${RUNS_PER_TARGET:-}" ] && args+=(-runs="$RUNS_PER_TARGET")
    "$BIN/$t" "$WORK/corpus/$t" "${args[@]}" > "$WORK/$t.log" 2>&1 &
    pid=$!
    while kill -0 "$pid" 2>/dev/null; do
        sleep 2
        if [ -n "${CPU_SECONDS_PER_TARGET:-}" ]; then
            ticks=$(awk '{print $14 + $15}' "/proc/$pid/stat" 2>/dev/null || echo 0)
            [ "${ticks:-0}" -ge $((CPU_SECONDS_PER_TARGET * $(getconf CLK_TCK))) ] && kill -INT "$pid"
        fi
    done
    # Interrupted at the CPU limit is a clean stop; anything else non-zero is a finding.
    wait "$pid" || grep -q 'run interrupted' "$WORK/$t.log" || status=1
    grep -E '^(stat::number_of_executed_units|Done)' "$WORK/$t.log" || true
    if ls "$WORK/artifacts/$t"/crash-* "$WORK/artifacts/$t"/oom-* "$WORK/artifacts/$t"/timeout-* >/dev/null 2>&1; then
        echo "!! $t: crash inputs in $WORK/artifacts/$t (log: $WORK/$t.log)"; status=1
    fi
done
exit $status
