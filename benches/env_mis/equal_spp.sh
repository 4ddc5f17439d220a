#!/usr/bin/env bash
# Environment sampling of two lumo builds at equal spp (README, "compensated environment
# sampling"; docs/environment.md): scenes/env_spheres.json (a rough-metal and a grey sphere on a
# grey floor) lit by each of ../shared/hdri/{forest,studio,sunset}.exr, invisible to the camera.
#
#   bash benches/env_mis/equal_spp.sh OLD_LUMO NEW_LUMO SPP SEED...
#       e.g.  bash benches/env_mis/equal_spp.sh /tmp/lumo-before target/release/lumo 16 1 2 3 4 5 6 7 8
#
# Renders a 2048-spp reference per HDR with NEW_LUMO (seed 999, target/env_mis/), then every seed
# with both builds, alternated, and prints each build's mean MSE over the seeds (from lumo's
# `--reference` RMSE) per HDR.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
[ $# -ge 4 ] || { echo "usage: $0 OLD_LUMO NEW_LUMO SPP SEED..." >&2; exit 2; }
OLD=$1; NEW=$2; SPP=$3; shift 3
OUT=target/env_mis; mkdir -p "$OUT"
for hdr in forest studio sunset; do
    env=../shared/hdri/$hdr.exr
    ref=$OUT/ref_$hdr.exr
    [ -f "$ref" ] || "$NEW" render scenes/env_spheres.json --env "$env" --env-strength 1 --spp 2048 --seed 999 -q -o "$ref"
    for build in old new; do echo 0 > "$OUT/$build.sum"; done
    for seed in "$@"; do
        for build in old new; do
            bin=$OLD; [ $build = new ] && bin=$NEW
            rmse=$("$bin" render scenes/env_spheres.json --env "$env" --spp "$SPP" --seed "$seed" \
                --reference "$ref" -q -o "$OUT/$build.exr" 2>&1 | sed -n 's/.*RMSE \([0-9.e-]*\).*/\1/p')
            echo "$(cat "$OUT/$build.sum") + $rmse^2" | bc -l > "$OUT/$build.sum.tmp"
            mv "$OUT/$build.sum.tmp" "$OUT/$build.sum"
        done
    done
    n=$#
    printf '%-7s MSE over %d seeds at %s spp: old %.4e, new %.4e\n' "$hdr" "$n" "$SPP" \
        "$(echo "$(cat "$OUT/old.sum") / $n" | bc -l)" "$(echo "$(cat "$OUT/new.sum") / $n" | bc -l)"
done
