#!/usr/bin/env bash
# Compares lumo builds on one scene: ROUNDS rounds, each running every binary once in a new
# random order, timed by lumo's own report of its render ("… spp in S s", the time the peer
# benchmarks use), then the mean, median and fastest time of each.
#
#   bash benches/ab.sh ROUNDS SCENE SPP BINARY...
#   e.g. cp target/release/lumo /tmp/new && cp /tmp/old /tmp/old-copy &&
#        bash benches/ab.sh 12 scenes/cornell.json 256 /tmp/old /tmp/old-copy /tmp/new
#
# Why shuffled, and why a copy: on the 2-core machine of docs/performance.md, binaries run in
# a fixed order (A, B, A, B, …) favoured the second by about 1.7 % (two copies of one binary
# differed by that much), more than most single changes are worth. In a new order every round
# that bias averages out; a second copy of the baseline shows what is left (differences
# between the copies are the noise floor of the run). Set LUMO_SIMD to compare widths.
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '2,9p' "$0" >&2
    exit 2
fi
rounds=$1
scene=$2
spp=$3
shift 3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for _ in $(seq "$rounds"); do
    for binary in $(printf '%s\n' "$@" | shuf); do
        report=$("$binary" render "$scene" -o "$out/image.exr" --spp "$spp" 2>&1)
        seconds=$(grep -o 'spp in [0-9.]* s' <<<"$report" | awk '{print $3}')
        if [ -z "$seconds" ]; then
            echo "$binary: no render time in its output:" >&2
            echo "$report" >&2
            exit 1
        fi
        echo "$binary $seconds"
    done
done | awk '
    { t[$1] = t[$1] " " $2; n[$1]++; s[$1] += $2 }
    END {
        for (b in t) {
            k = split(substr(t[b], 2), v, " ")
            # insertion sort: a handful of values
            for (i = 2; i <= k; i++) {
                x = v[i]; j = i - 1
                while (j > 0 && v[j] > x) { v[j + 1] = v[j]; j-- }
                v[j + 1] = x
            }
            median = (k % 2) ? v[(k + 1) / 2] : (v[k / 2] + v[k / 2 + 1]) / 2
            printf "%-40s rounds %3d  mean %.4f s  median %.4f s  fastest %.4f s\n", b, n[b], s[b] / n[b], median, v[1]
        }
    }' | sort
