#!/usr/bin/env bash
# Download, on a machine that reaches PyPI, the wheels a GPU host needs for training when it has
# JAX (with CUDA), flax, optax, scipy and matplotlib but no internet; then on that host
# `benchmarks/gpu_runs.sh --wheels DIR RECIPE ...` installs them (no index, no dependencies)
# and runs. See `benchmarks/gpu_wheels.sh --help`.
set -euo pipefail

usage() {
    cat <<'EOF'
usage: benchmarks/gpu_wheels.sh [DIR] [--python-version X.Y] [--warp]

Downloads into DIR (default .whl) the wheels for x86-64 Linux and CPython X.Y (default 3.12)
that motionkit's training needs beyond a JAX GPU image: mujoco, mujoco-mjx and their
libraries, icub-models (the robot), mcap and its compressors, trimesh, tensorboardX and a few
small ones, at the versions the tests ran with; about 43 MB. --warp adds warp-lang for
[env] impl = "warp" (about 150 MB). Prints the wheels and their total size.

On the GPU host (DIR copied beside the repository):
  benchmarks/gpu_runs.sh --wheels DIR walk_gpu 8 --priors-dir runs/datasets
EOF
}

dir=".whl"
python_version="3.12"
warp=0
while [[ $# -gt 0 ]]; do
    case "$1" in
        -h | --help) usage; exit 0 ;;
        --python-version) python_version="${2:?--python-version needs X.Y}"; shift 2 ;;
        --warp) warp=1; shift ;;
        -*) echo "gpu_wheels.sh: error: unknown option $1 (see --help)" >&2; exit 2 ;;
        *) dir="$1"; shift ;;
    esac
done
if [[ ! "$python_version" =~ ^3\.[0-9]+$ ]]; then
    echo "gpu_wheels.sh: error: --python-version $python_version: expected 3.N" >&2
    exit 2
fi

# the versions the test suite ran with (pyproject.toml's lower bounds; mujoco-core is mujoco's)
wheels=(
    mujoco==4.0.1 mujoco-core==4.0.1 mujoco-mjx==3.17.0 icub-models==3.2.0 mcap==1.6.0
    zstandard==0.25.0 lz4==4.4.5 trimesh==5.2.0 foxglove-schemas-protobuf==0.4.0
    platformdirs==4.14.9 tensorboardX==2.6.5
)
if [[ $warp == 1 ]]; then
    wheels+=(warp-lang==1.19.0)
fi
platforms=()
for tag in manylinux_2_28 manylinux_2_27 manylinux_2_17 manylinux2014 manylinux1; do
    platforms+=(--platform "${tag}_x86_64")
done

mkdir -p "$dir"
python3 -m pip download --quiet --no-deps --only-binary=:all: --implementation cp \
    --python-version "$python_version" "${platforms[@]}" --dest "$dir" "${wheels[@]}"
ls -l "$dir"/*.whl | awk '{total += $5; print $5, $NF} END {printf "%.1f MB in all\n", total / 1e6}'
