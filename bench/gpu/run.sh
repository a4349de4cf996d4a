#!/usr/bin/env bash
# Builds the ROS-free core with the CUDA backend on a GPU machine (no apt, ROS, PCL or Eigen there),
# runs the CUDA tests and the GPU benchmark, and profiles the step kernels with Nsight Compute.
# Eigen and GoogleTest come from Debian's .debs, extracted on a Debian machine into .deps/ (an
# ignored folder carried to the GPU machine; bench/gpu/README.md):
#   mkdir -p .deps && cd .deps && apt-get download libeigen3-dev googletest &&
#   for f in *.deb; do dpkg -x "$f" root; done && rm -f *.deb
# Usage: bench/gpu/run.sh OUT_DIR [test|bench|neural|lanes|ncu|all]...   (default: all)
set -euo pipefail
out=${1:?usage: bench/gpu/run.sh OUT_DIR [test|bench|neural|lanes|ncu|all]...}
shift
steps=${*:-all}
root=$(cd "$(dirname "$0")/../.." && pwd)
deps=$root/.deps/root
[ -d "$deps/usr/include/eigen3" ] || { echo "run.sh: $deps has no Eigen: extract libeigen3-dev and googletest first (see the header)"; exit 2; }
mkdir -p "$out"
build=${TOPO_GPU_BUILD:-/tmp/topo-gpu-build}
cmake -S "$root" -B "$build" -G Ninja -DTOPO_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
  -DEigen3_DIR="$deps/usr/share/eigen3/cmake" -DGTEST_SOURCE_DIR="$deps/usr/src/googletest" \
  -DCMAKE_CUDA_ARCHITECTURES="${CUDA_ARCH:-90}" >"$out/cmake.log" 2>&1 || { tail -30 "$out/cmake.log"; exit 1; }
grep -E "CUDA backend|no CUDA backend" "$out/cmake.log"
cmake --build "$build" -j"$(nproc)" --target core_cuda_soft_body core_cuda_neural bench_gpu_soft bench_gpu_neural >"$out/build.log" 2>&1 ||
  { grep -E "error|FAILED" "$out/build.log" | head -40; exit 1; }
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv,noheader
has() { [[ " $steps " == *" $1 "* || " $steps " == *" all "* ]]; }
if has test; then
  for t in core_cuda_soft_body core_cuda_neural; do
    "$build/$t" 2>&1 | tee -a "$out/test.log" | grep -E "parity|PASSED|FAILED|SKIPPED|Failure|error" || true
  done
fi
if has lanes; then
  for L in 1 4 8 16 32; do "$build/bench_gpu_soft" --quick --lanes $L explicit_ | tee -a "$out/lanes.jsonl"; done
fi
if has bench; then
  "$build/bench_gpu_soft" | tee "$out/bench.jsonl"
fi
if has neural; then
  "$build/bench_gpu_neural" | tee "$out/bench_neural.jsonl"
fi
if has ncu; then
  ncu --metrics gpu__time_duration.sum,dram__bytes_read.sum,dram__bytes_write.sum,lts__t_bytes.sum,dram__throughput.avg.pct_of_peak_sustained_elapsed,sm__throughput.avg.pct_of_peak_sustained_elapsed,sm__warps_active.avg.pct_of_peak_sustained_active \
    -k regex:'kickDrift|evaluate|gatherKick' -c 6 --csv "$build/bench_gpu_soft" --quick explicit_100k_h1.0_f32 \
    >"$out/ncu_100k_f32.csv" 2>"$out/ncu.err" || tail -5 "$out/ncu.err"
  ncu --metrics gpu__time_duration.sum,dram__bytes_read.sum,dram__bytes_write.sum,lts__t_bytes.sum,dram__throughput.avg.pct_of_peak_sustained_elapsed,sm__throughput.avg.pct_of_peak_sustained_elapsed,sm__warps_active.avg.pct_of_peak_sustained_active \
    -k regex:'kickDrift|evaluate|gatherKick' -c 6 --csv "$build/bench_gpu_soft" --quick explicit_100k_h1.0_f64 \
    >"$out/ncu_100k_f64.csv" 2>>"$out/ncu.err" || tail -5 "$out/ncu.err"
  ncu --metrics gpu__time_duration.sum,sm__throughput.avg.pct_of_peak_sustained_elapsed,sm__warps_active.avg.pct_of_peak_sustained_active \
    -k regex:'kickDrift|evaluate|gatherKick' -c 6 --csv "$build/bench_gpu_soft" --quick explicit_9k_h1.0_f64 \
    >"$out/ncu_9k_f64.csv" 2>>"$out/ncu.err" || tail -5 "$out/ncu.err"
  for f in "$out"/ncu_*.csv; do
    echo "== $f"; python3 - "$f" <<'PY' || true
import csv, sys
for row in csv.DictReader(open(sys.argv[1])):
    if row.get("Metric Name") in ("gpu__time_duration.sum", "dram__bytes_read.sum", "lts__t_bytes.sum", "sm__throughput.avg.pct_of_peak_sustained_elapsed", "dram__throughput.avg.pct_of_peak_sustained_elapsed"):
        print(row["ID"], row["Kernel Name"][:40], row["Metric Name"], row["Metric Value"])
PY
  done
fi
