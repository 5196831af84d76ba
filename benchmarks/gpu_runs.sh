#!/usr/bin/env bash
# One training recipe on a (rented) GPU within a wall-clock budget, with every figure it
# measured in one JSON file; see `benchmarks/gpu_runs.sh --help`.
#
#   benchmarks/gpu_runs.sh RECIPE [MINUTES] [--resume CHECKPOINT] [--priors-dir DIR] [--out DIR]
#   benchmarks/gpu_runs.sh walk_fly_gpu 8 --priors-dir /data/priors
#
# The work is done by benchmarks/gpu_run.py; this wrapper only picks the Python to run it with
# (the repository's .venv when there is one, else python3). Paths are relative to the working
# directory, as given.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ -x "$root/.venv/bin/python" ]]; then
    python="$root/.venv/bin/python"
elif command -v python3 >/dev/null 2>&1; then
    python="$(command -v python3)"
else
    echo "gpu_runs.sh: error: neither $root/.venv/bin/python nor python3 found" >&2
    exit 2
fi

echo "gpu_runs.sh: $python $root/benchmarks/gpu_run.py $*" >&2
exec "$python" "$root/benchmarks/gpu_run.py" "$@"
