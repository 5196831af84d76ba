#!/usr/bin/env bash
# One training recipe on a (rented) GPU within a wall-clock budget, with every figure it
# measured in one JSON file; see `benchmarks/gpu_runs.sh --help`.
#
#   benchmarks/gpu_runs.sh [--wheels DIR] RECIPE [MINUTES] [--resume CHECKPOINT] [--priors-dir DIR]
#   benchmarks/gpu_runs.sh walk_gpu 8 --priors-dir /data/priors
#   benchmarks/gpu_runs.sh --wheels .whl walk_gpu 8 --priors-dir runs/datasets
#
# The work is done by benchmarks/gpu_run.py; this wrapper only picks the Python to run it with
# (the repository's .venv when there is one, else python3). On a host without internet whose
# Python has JAX but not motionkit's other needs, --wheels DIR (from benchmarks/gpu_wheels.sh)
# installs DIR's wheels under a prefix in /tmp (no index, no dependencies) and runs motionkit
# from this repository with that prefix on PYTHONPATH. Paths are relative to the working
# directory, as given.
set -euo pipefail

wheels=""
args=()
while [[ $# -gt 0 ]]; do
    if [[ "$1" == "--wheels" ]]; then
        wheels="${2:-}"
        [[ -n "$wheels" ]] || { echo "gpu_runs.sh: error: --wheels needs DIR" >&2; exit 2; }
        shift 2
    else
        args+=("$1")
        shift
    fi
done

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ -x "$root/.venv/bin/python" ]]; then
    python="$root/.venv/bin/python"
elif command -v python3 >/dev/null 2>&1; then
    python="$(command -v python3)"
else
    echo "gpu_runs.sh: error: neither $root/.venv/bin/python nor python3 found" >&2
    exit 2
fi

if [[ -n "$wheels" ]]; then
    shopt -s nullglob
    files=("$wheels"/*.whl)
    if [[ ${#files[@]} == 0 ]]; then
        echo "gpu_runs.sh: error: --wheels $wheels: no .whl files there" >&2
        exit 2
    fi
    prefix="${TMPDIR:-/tmp}/motionkit-wheels"
    "$python" -m pip install --quiet --no-index --no-deps --no-compile --no-cache-dir \
        --upgrade --prefix "$prefix" "${files[@]}"
    # the folders the wheels went to (pure and platform libraries may differ)
    path="$root"
    while IFS= read -r folder; do
        path="$folder:$path"
    done < <(find "$prefix" -maxdepth 4 -type d \( -name site-packages -o -name dist-packages \))
    export PYTHONPATH="$path${PYTHONPATH:+:$PYTHONPATH}"
    echo "gpu_runs.sh: installed ${#files[@]} wheels from $wheels into $prefix" >&2
fi

echo "gpu_runs.sh: $python $root/benchmarks/gpu_run.py ${args[*]}" >&2
exec "$python" "$root/benchmarks/gpu_run.py" "${args[@]}"
