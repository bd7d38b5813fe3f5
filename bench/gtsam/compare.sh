#!/usr/bin/env bash
# Solves each 2D g2o pose graph given (default: data/posegraph/*.g2o.gz) with
# `fastslam-stack solve` and with GTSAM's Levenberg-Marquardt (bench/gtsam/solve_gtsam.py,
# first pose anchored the same way), and prints one Markdown table: iterations, final
# chi2 over the edges, its relative difference from ours, and the solve's wall time
# (fastest of REPEAT runs, default 5).
#
# GTSAM runs twice: with its default parameters (relative and absolute error tolerance
# 1e-5, which can stop short of the minimum), and with both tolerances at 1e-12 (run to
# convergence, as ours is). GTSAM's time is that of optimize(); in brackets, with the
# optimizer's construction (its ordering) added. Ours is the whole solve: structure,
# ordering, symbolic factorisation and the iterations. Our iterations count every
# factorisation (accepted and rejected steps), GTSAM's its outer iterations.
#
# GTSAM comes from PyPI into a virtual environment at target/gtsam-venv (made on first
# use); the release binary is built first.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
venv="$root/target/gtsam-venv"
repeat=${REPEAT:-5}

if ! "$venv/bin/python" -c 'import gtsam, numpy' 2>/dev/null; then
    echo "making $venv (gtsam, numpy from PyPI)" >&2
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --upgrade pip
    "$venv/bin/pip" install --quiet gtsam numpy
fi
cargo build --release --quiet --bin fastslam-stack
binary="$root/target/release/fastslam-stack"

if [ "$#" -eq 0 ]; then
    set -- data/posegraph/*.g2o.gz
fi

# The value after KEY in a line of KEY VALUE pairs.
field() { awk -v key="$2" '{ for (i = 1; i < NF; i++) if ($i == key) { print $(i + 1); exit } }' <<<"$1"; }
# Relative difference of $1 from $2.
relative() { awk -v a="$1" -v b="$2" 'BEGIN { d = (a - b) / b; if (d < 0) d = -d; printf "%.1e", d }'; }
# $1 / $2 to one decimal.
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", a / b }'; }

echo "| graph | solver | iterations | chi2 final | rel. diff from ours | solve s | GTSAM s / ours |"
echo "|---|---|---:|---:|---:|---:|---:|"
for file in "$@"; do
    name=$(basename "$file")
    name=${name%.gz}
    name=${name%.g2o}
    best=""
    for _ in $(seq "$repeat"); do
        line=$("$binary" solve "$file")
        seconds=$(field "$line" solve_s)
        if [ -z "$best" ] || awk -v a="$seconds" -v b="$best" 'BEGIN { exit !(a < b) }'; then
            best=$seconds
        fi
    done
    ours_chi2=$(field "$line" chi2_final)
    echo "| $name | fastslam-stack solve | $(field "$line" iterations) | $ours_chi2 | – | $best | – |"
    for mode in default tight; do
        flag=""
        label="GTSAM LM, default tolerances (1e-5)"
        if [ "$mode" = tight ]; then
            flag="--tight"
            label="GTSAM LM, tolerances 1e-12"
        fi
        # shellcheck disable=SC2086
        line=$("$venv/bin/python" bench/gtsam/solve_gtsam.py "$file" --repeat "$repeat" $flag)
        chi2=$(field "$line" chi2_final)
        optimize=$(field "$line" optimize_s)
        total=$(field "$line" total_s)
        echo "| $name | $label | $(field "$line" iterations) | $chi2 | $(relative "$chi2" "$ours_chi2") | $optimize ($total) | $(ratio "$optimize" "$best") |"
    done
done
