#!/usr/bin/env bash
# Equal-time comparison of uniform and adaptive sampling (README, "adaptive sampling, equal time").
#
#   bash benches/adaptive/equal_time.sh SECONDS SEED...      e.g.  bash benches/adaptive/equal_time.sh 8 1 2 3 4
#
# For each seed and scene (scenes/cornell_glass.json at 128² against
# tests/reference/cornell_glass_4096.exr; scenes/glass_lathe.json at 128² against a 2048-spp lumo
# render made on first use in target/adaptive/), renders with `--time SECONDS --threads 1`, uniform
# then adaptive (alternated, so a changing machine load affects both alike), and appends
# scene,seconds,seed,mode,spp,render_seconds,rmse,rel_mse,load1 to target/adaptive/equal_time.csv.
# Then prints per-mode means ± standard deviation over seeds and the per-seed adaptive/uniform ratios.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
[ $# -ge 2 ] || { echo "usage: $0 SECONDS SEED..." >&2; exit 2; }
T=$1; shift
cargo build --release -q
L=target/release/lumo
OUT=target/adaptive; mkdir -p "$OUT"
LATHE_REF="$OUT/glass_lathe_128_2048.exr"
if [ ! -f "$LATHE_REF" ]; then
    echo "rendering the glass lathe reference (2048 spp, a few minutes)…" >&2
    $L render scenes/glass_lathe.json --width 128 --height 128 --spp 2048 --seed 1000000 -q -o "$LATHE_REF"
fi
CSV="$OUT/equal_time.csv"
for seed in "$@"; do
    for scene in cornell_glass glass_lathe; do
        if [ $scene = cornell_glass ]; then ref=tests/reference/cornell_glass_4096.exr; size=""; else ref=$LATHE_REF; size="--width 128 --height 128"; fi
        for mode in uniform adaptive; do
            flag=""; [ $mode = adaptive ] && flag="--adaptive"
            load=$(cut -d' ' -f1 /proc/loadavg)
            line=$($L render scenes/$scene.json $size --time "${T}s" --seed "$seed" --threads 1 -q $flag --reference "$ref" -o "$OUT/last.exr" 2>&1)
            fields=$(echo "$line" | sed -n 's/.* at \([0-9]*\) spp in \([0-9.]*\) s.*RMSE \([0-9.]*\), relMSE \([0-9.]*\).*/\1,\2,\3,\4/p')
            echo "$scene,$T,$seed,$mode,$fields,$load" | tee -a "$CSV"
        done
    done
done
python3 - "$CSV" "$T" <<'PY'
import sys, statistics as st
from collections import defaultdict
path, budget = sys.argv[1], sys.argv[2]
runs = defaultdict(dict)
for line in open(path):
    f = line.strip().split(",")
    if len(f) != 9 or f[1] != budget:
        continue
    scene, _, seed, mode, spp, secs, rmse, rel, load = f
    runs[(scene, mode)][int(seed)] = (int(spp), float(rmse), float(rel), float(load))
for (scene, mode), by_seed in sorted(runs.items()):
    v = list(by_seed.values())
    ms = lambda i: (st.mean(x[i] for x in v), st.stdev(x[i] for x in v) if len(v) > 1 else 0.0)
    print(f"{scene:14s} {budget}s {mode:9s} seeds={len(v)} spp≈{ms(0)[0]:.0f}  RMSE {ms(1)[0]:.5f} ± {ms(1)[1]:.5f}  "
          f"relMSE {ms(2)[0]:.6f} ± {ms(2)[1]:.6f}  load {min(x[3] for x in v):.2f}–{max(x[3] for x in v):.2f}")
for (scene, mode), by_seed in sorted(runs.items()):
    uniform = runs.get((scene, "uniform"), {})
    pairs = [(a[1] / uniform[s][1], a[2] / uniform[s][2]) for s, a in by_seed.items() if mode == "adaptive" and s in uniform]
    if pairs:
        print(f"{scene} {budget}s adaptive/uniform: RMSE × {st.mean(p[0] for p in pairs):.3f}, relMSE × {st.mean(p[1] for p in pairs):.3f} (mean over {len(pairs)} seeds)")
PY
