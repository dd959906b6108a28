#!/usr/bin/env bash
# monohand's Levenberg-Marquardt vs Ceres Solver 2.1 on the same fitting problems
# (STB B1Counting projected to 2D, 0 and 3 px noise, from scratch and warm-started).
# Not part of .ci/run: it needs the C++ toolchain and Ceres. See docs/performance.md.
#
# Usage: bench/ceres/run.sh [--frames N] [--repeats N] [--linear-solver cholesky|qr]
# Environment: STB_DIR (default ../shared/data/stb_b1counting beside the repo),
#              OUT (default target/ceres-bench), CXX (default g++).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
STB_DIR=${STB_DIR:-$root/../shared/data/stb_b1counting}
OUT=${OUT:-$root/target/ceres-bench}
CXX=${CXX:-g++}

if [ ! -f /usr/include/ceres/ceres.h ] || [ ! -f /usr/include/eigen3/Eigen/Core ]; then
    echo "Ceres Solver headers not found. Install them (Debian/Ubuntu) with:" >&2
    echo "    sudo apt-get install -y libceres-dev" >&2
    exit 1
fi
if ! command -v "$CXX" >/dev/null; then
    echo "no C++ compiler ($CXX); install g++ (sudo apt-get install -y g++)" >&2
    exit 1
fi
if [ ! -f "$STB_DIR/labels/B1Counting_BB.mat" ]; then
    echo "STB B1Counting not found at $STB_DIR (set STB_DIR)" >&2
    exit 1
fi
mkdir -p "$OUT"

echo "== machine" >&2
lscpu | grep -E '^(Model name|CPU\(s\)|Thread|Core|Socket)' >&2 || true
ceres_version=$(dpkg-query -W -f='${Version}' libceres-dev 2>/dev/null || echo unknown)
echo "libceres-dev $ceres_version; $("$CXX" --version | head -1); $(rustc --version)" >&2

echo "== build ceres_fit (C++, -O3)" >&2
"$CXX" -std=c++17 -O3 -DNDEBUG -I/usr/include/eigen3 bench/ceres/ceres_fit.cc \
    -o "$OUT/ceres_fit" -lceres -lglog -lgflags -lpthread

echo "== build the driver (Rust, release)" >&2
CARGO_TARGET_DIR="$root/target" cargo build --release --locked \
    --manifest-path bench/ceres/driver/Cargo.toml

echo "== run" >&2
"$root/target/release/monohand-ceres-bench" --data "$STB_DIR" --ceres "$OUT/ceres_fit" \
    --out "$OUT" "$@"
echo "== wrote $OUT/report.md, $OUT/per_problem.tsv" >&2
