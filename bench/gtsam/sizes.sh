#!/usr/bin/env bash
# Solve time against graph size, ours against GTSAM's: writes synthetic grid-city pose
# graphs of 100, 1 000 and 10 000 poses (bench/gtsam/city.py, seed 1) to
# target/posegraph-sizes/ and runs bench/gtsam/compare.sh on them and on the shared
# graphs (data/posegraph/). Same environment variables as compare.sh (REPEAT).
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
out="$root/target/posegraph-sizes"
mkdir -p "$out"
for n in 100 1000 10000; do
    python3 "$root/bench/gtsam/city.py" "$n" "$out/city$n.g2o"
done
exec "$root/bench/gtsam/compare.sh" "$out"/city100.g2o "$out"/city1000.g2o \
    "$root"/data/posegraph/*.g2o.gz "$out"/city10000.g2o
