#!/usr/bin/env bash
# The GPU figures of docs/PERFORMANCE.md, with the CPU baseline measured in the same run:
# scan-like Matterport3D houses of 1 M and 3 M triangles (`minos generate --scan`), then
#   - the CPU ray caster, one core, colour + depth + semantic per size (`bench render`);
#   - the GPU (`bench render --renderer wgpu`): one observation at a time, batches of $BATCH
#     views with one submission and read-back (ids + depth), the same with colour, depth
#     and semantic images derived on all threads, and with those images derived on the GPU
#     (its second compute pass) and read back finished — every GPU figure by the wall clock;
#   - the oracle's rollout loop on all threads, CPU and wgpu (`bench run`): each thread its
#     own simulator, and $ENVS environments stepped together (one render call per step) —
#     on wgpu with the images derived on the GPU (the default) and, again, on the host
#     (MINOS_GPU_DERIVE=0);
#   - VectorNavEnv with random actions, CPU and wgpu, $VEC_ENVS environments (default
#     256,1024), where the `minos` Python package is importable.
# SIZES="" skips the rendering rows, EPISODES=0 the rollout rows.
# Prints the adapter and a Markdown table; the JSON of every bench goes to $WORK/json/.
#
#   scripts/gpu_bench.sh                      # needs a release build (cargo build --release)
#   MINOS=path/to/minos SCANS="1000000" SIZES="84 128" BATCH=256 scripts/gpu_bench.sh
#
# Without a GPU, wgpu finds lavapipe where Mesa's Vulkan drivers are installed (slow: use a
# small BATCH); with no adapter at all the GPU rows say why they are missing.
set -euo pipefail
cd "$(dirname "$0")/.."
MINOS=${MINOS:-${CARGO_TARGET_DIR:-$PWD/target}/release/minos}
WORK=${WORK:-$(mktemp -d -t minos-gpu-XXXXXX)}
SCANS=${SCANS:-"1000000 3000000"}
SIZES=${SIZES-"64 84 128 256"}
BATCH=${BATCH:-1024}
EPISODES=${EPISODES:-40}
ENVS=${ENVS:-256}
# THROUGHPUT_ONLY=1: bench run without its per-core loop (for many episodes).
RUN_FLAGS=${THROUGHPUT_ONLY:+--throughput-only}
PYTHON=${PYTHON:-python3}
mkdir -p "$WORK/json"
echo "work folder: $WORK; $(nproc) cores; batches of $BATCH views"
# wgpu loads the Vulkan loader at run time: a GPU machine with the NVIDIA driver but no
# libvulkan.so.1 (the lent H100 of 2026-11-27) gives "no GPU adapter found" and every GPU row
# missing. Say so first (the remedy: Debian's or Ubuntu's libvulkan1 and libglvnd0 packages).
if command -v ldconfig >/dev/null && ! ldconfig -p | grep -q 'libvulkan\.so\.1'; then
    echo "warning: no libvulkan.so.1 on this machine: wgpu will find no GPU (install libvulkan1 and libglvnd0)" >&2
fi

for tris in $SCANS; do
    d="$WORK/scan-$tris"
    if [ ! -f "$d/DATA/houses.parquet" ]; then
        "$MINOS" -q generate --scan --houses 1 --seed 1 --scan-triangles "$tris" --out "$d/gen"
        "$MINOS" -q ingest --dataset mp3d --root "$d/gen" --out "$d/DATA"
        "$MINOS" -q bake --data "$d/DATA" --no-preview
    fi
    for s in $SIZES; do
        "$MINOS" --threads 1 bench render --data "$d/DATA" --size "$s" --frames 200 --json \
            >"$WORK/json/render-cpu-$tris-$s.json"
        "$MINOS" bench render --data "$d/DATA" --size "$s" --frames 64 --renderer wgpu \
            --batch "$BATCH" --json >"$WORK/json/render-wgpu-$tris-$s.json" 2>"$WORK/json/render-wgpu-$tris-$s.err" ||
            echo "wgpu render $tris $s: $(tail -1 "$WORK/json/render-wgpu-$tris-$s.err")"
    done
    [ "$EPISODES" -gt 0 ] || continue
    "$MINOS" bench run --data "$d/DATA" --episodes "$EPISODES" --envs "$ENVS" $RUN_FLAGS --json >"$WORK/json/run-cpu-$tris.json"
    "$MINOS" bench run --data "$d/DATA" --episodes "$EPISODES" --renderer wgpu --envs "$ENVS" $RUN_FLAGS --json \
        >"$WORK/json/run-wgpu-$tris.json" 2>"$WORK/json/run-wgpu-$tris.err" ||
        echo "wgpu run $tris: $(tail -1 "$WORK/json/run-wgpu-$tris.err")"
    MINOS_GPU_DERIVE=0 "$MINOS" bench run --data "$d/DATA" --episodes "$EPISODES" --renderer wgpu --envs "$ENVS" $RUN_FLAGS --json \
        >"$WORK/json/run-wgpuhost-$tris.json" 2>"$WORK/json/run-wgpuhost-$tris.err" ||
        echo "wgpu run (host derivation) $tris: $(tail -1 "$WORK/json/run-wgpuhost-$tris.err")"
    # STARTS_POOL=separate: the same two wgpu runs with the episodes' starts on their own
    # thread pool (MINOS_BENCH_STARTS_POOL), an experiment.
    if [ "${STARTS_POOL:-}" = separate ]; then
        for derive in 1 0; do
            tag=$([ $derive = 1 ] && echo wgpusep || echo wgpuhostsep)
            MINOS_BENCH_STARTS_POOL=separate MINOS_GPU_DERIVE=$derive "$MINOS" bench run --data "$d/DATA" --episodes "$EPISODES" \
                --renderer wgpu --envs "$ENVS" $RUN_FLAGS --json >"$WORK/json/run-$tag-$tris.json" 2>"$WORK/json/run-$tag-$tris.err" ||
                echo "wgpu run ($tag) $tris: $(tail -1 "$WORK/json/run-$tag-$tris.err")"
        done
    fi
done

# VectorNavEnv with random actions, CPU renderer against wgpu, on the first scan (where the
# `minos` Python package is importable: `pip install ./python`).
first=${SCANS%% *}
if [ "$EPISODES" -gt 0 ] && "$PYTHON" -c "import minos.gym" >/dev/null 2>&1; then
    d="$WORK/scan-$first"
    "$MINOS" -q episodes --data "$d/DATA" --task pointgoal --per-scene "$EPISODES" --seed 1 \
        --out "$d/eps.parquet"
    "$PYTHON" python/bench/vector_env_renderers.py "$d/DATA" "$d/eps.parquet" \
        --envs "${VEC_ENVS:-256,1024}" --threads "$(nproc)" >"$WORK/json/vector_env.txt" 2>&1 ||
        echo "VectorNavEnv bench: $(tail -1 "$WORK/json/vector_env.txt")"
else
    echo "VectorNavEnv rows skipped: \`$PYTHON -c 'import minos.gym'\` fails (pip install ./python)" \
        >"$WORK/json/vector_env.txt"
fi

"$PYTHON" - "$WORK/json" <<'EOF'
import json, pathlib, sys
folder = pathlib.Path(sys.argv[1])
def load(name):
    p = folder / name
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError):
        return None
def rate(report, stage):
    if report is None:
        return "–"
    for s in report["stages"]:
        if s["stage"] == stage:
            return f'{s["per_second"]:,.0f}'
    return "–"
files = sorted(folder.glob("render-cpu-*.json"))
adapter = next((r["adapter"] for f in folder.glob("render-wgpu-*.json") if (r := load(f.name)) and r.get("adapter")), None)
print(f"adapter: {adapter or 'none (wgpu rows missing)'}\n")
print("| scene | triangles | size | CPU, 1 core (fps) | GPU, one view at a time (fps, wall) | GPU batch, ids + depth (fps, wall) | GPU batch + colour, depth, semantic derived on all threads (fps, wall) | the same derived on the GPU (fps, wall) |")
print("|---|---|---|---|---|---|---|---|")
keys = sorted({tuple(map(int, f.stem.split("-")[2:4])) for f in files})
for tris, size in keys:
    cpu = load(f"render-cpu-{tris}-{size}.json")
    gpu = load(f"render-wgpu-{tris}-{size}.json")
    print(f'| scan {tris:,} | {cpu["triangles"]:,} | {size}² | {rate(cpu, "render")} | {rate(gpu, "render")} | {rate(gpu, "gpu batch: ids + depth")} | {rate(gpu, "gpu batch + colour, depth, semantic (all threads)")} | {rate(gpu, "gpu batch + colour, depth, semantic derived on the GPU")} |')
print()
print("| scene | oracle rollout, 1 core, CPU (steps/s) | all threads, CPU | all threads, wgpu | batched envs, CPU | batched envs, wgpu (images derived on the GPU) | batched envs, wgpu, images derived on the host |")
print("|---|---|---|---|---|---|---|")
for f in sorted(folder.glob("run-cpu-*.json")):
    tris = int(f.stem.split("-")[2])
    cpu, gpu, host = load(f.name), load(f"run-wgpu-{tris}.json"), load(f"run-wgpuhost-{tris}.json")
    print(f'| scan {tris:,} ({cpu["threads"]} threads, {cpu.get("envs", 0)} envs) | {rate(cpu, "rollout loop")} | {rate(cpu, "rollout loop, all threads")} | {rate(gpu, "rollout loop, all threads")} | {rate(cpu, "rollout loop, batched")} | {rate(gpu, "rollout loop, batched")} | {rate(host, "rollout loop, batched")} |')
# Where a lockstep step of the batched loop goes (ms per step of the whole batch).
runs = [(f"{label}, scan {int(f.stem.split('-')[-1]):,}", load(f.name)) for label, pattern in
        [("CPU", "run-cpu-*.json"), ("wgpu", "run-wgpu-*.json"), ("wgpu, host derivation", "run-wgpuhost-*.json"),
         ("wgpu, starts on their own pool", "run-wgpusep-*.json"),
         ("wgpu, host derivation, starts on their own pool", "run-wgpuhostsep-*.json")]
        for f in sorted(folder.glob(pattern))]
runs = [(l, r) for l, r in runs if r and any(s["stage"].startswith("batched: ") for s in r["stages"])]
if runs:
    names = [s["stage"] for s in runs[0][1]["stages"] if s["stage"].startswith("batched: ")]
    print()
    print("| batched loop (ms per lockstep step) | steps/s | lockstep steps | " + " | ".join(n[len("batched: "):] for n in names) + " | whole step |")
    print("|---" * (len(names) + 4) + "|")
    for label, r in runs:
        by = {s["stage"]: s for s in r["stages"]}
        n = by[names[0]]["count"] or 1
        cells = [f'{1000 * by[k]["seconds"] / n:.1f}' if k in by else "–" for k in names]
        whole = by.get("rollout loop, batched")
        if whole:
            print(f"| {label} | {rate(r, 'rollout loop, batched')} | {n:,} | " + " | ".join(cells) + f' | {1000 * whole["seconds"] / n:.1f} |')
vec = folder / "vector_env.txt"
if vec.exists():
    print()
    print(vec.read_text().strip())
EOF
