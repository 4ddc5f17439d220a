#!/usr/bin/env bash
# Equal-time comparison of light selection by power and by the light tree (README, "light tree";
# docs/performance.md, "Light tree").
#
#   bash benches/light_tree/equal_time.sh SECONDS SEED...      e.g.  bash benches/light_tree/equal_time.sh 4 1 2 3
#
# For each seed and scene (scenes/cornell.json at 256² against
# tests/reference/cornell_mitsuba_4096.exr; scenes/many_lights.json at 128×96 against a 4096-spp
# lumo render made on first use in target/light_tree/), renders with `--time SECONDS --threads 1`
# with `--light-sampler power` then `tree` (alternated, so a changing machine load affects both
# alike), and appends scene,seconds,seed,mode,spp,rmse,rel_mse,load1 to
# target/light_tree/equal_time.csv. Then prints per-mode means over seeds and per-seed MSE ratios.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
[ $# -ge 2 ] || { echo "usage: $0 SECONDS SEED..." >&2; exit 2; }
T=$1; shift
cargo build --release -q
L=target/release/lumo
OUT=target/light_tree; mkdir -p "$OUT"
ML_REF="$OUT/many_lights_128x96_4096.exr"
if [ ! -f "$ML_REF" ]; then
    echo "rendering the many-lights reference (4096 spp, about a minute)…" >&2
    $L render scenes/many_lights.json --width 128 --height 96 --spp 4096 --seed 1000000 \
        --light-sampler tree -q -o "$ML_REF"
fi
CSV="$OUT/equal_time.csv"
[ -f "$CSV" ] || echo "scene,seconds,seed,mode,spp,rmse,rel_mse,load1" > "$CSV"
for seed in "$@"; do
    for scene in cornell many_lights; do
        if [ $scene = cornell ]; then ref=tests/reference/cornell_mitsuba_4096.exr; size=""; else ref=$ML_REF; size="--width 128 --height 96"; fi
        for mode in power tree; do
            load=$(cut -d' ' -f1 /proc/loadavg)
            line=$($L render scenes/$scene.json $size --time "$T" --threads 1 --seed "$seed" \
                --light-sampler $mode --reference "$ref" -q -o "$OUT/last.exr" 2>&1 | tail -1)
            spp=$(sed -E 's/.* at ([0-9]+) spp.*/\1/' <<<"$line")
            rmse=$(sed -E 's/.*RMSE ([0-9.e-]+),.*/\1/' <<<"$line")
            rel=$(sed -E 's/.*relMSE ([0-9.e-]+) .*/\1/' <<<"$line")
            echo "$scene,$T,$seed,$mode,$spp,$rmse,$rel,$load" | tee -a "$CSV"
        done
    done
done
python3 - "$CSV" "$T" <<'PY'
import csv, sys, statistics as st
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["seconds"] == sys.argv[2]]
for scene in ("cornell", "many_lights"):
    by = {m: {r["seed"]: r for r in rows if r["scene"] == scene and r["mode"] == m} for m in ("power", "tree")}
    seeds = sorted(set(by["power"]) & set(by["tree"]))
    if not seeds:
        continue
    for m in ("power", "tree"):
        rm = [float(by[m][s]["rmse"]) for s in seeds]
        spp = [int(by[m][s]["spp"]) for s in seeds]
        print(f"{scene} {m}: spp {min(spp)}–{max(spp)}, RMSE {st.mean(rm):.5f} (seeds {', '.join(f'{x:.5f}' for x in rm)})")
    ratios = [(float(by["tree"][s]["rmse"]) / float(by["power"][s]["rmse"])) ** 2 for s in seeds]
    print(f"{scene} tree/power MSE per seed: {', '.join(f'{x:.3f}' for x in ratios)}")
PY
