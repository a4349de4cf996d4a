#!/usr/bin/env bash
# Builds the ROS-free core with the CUDA backend on a GPU machine (no apt, ROS, PCL or Eigen there),
# with the inference layer (bench_infer: the tasks end to end), runs the CUDA tests and the GPU
# benchmarks, and profiles the step kernels with Nsight Compute. Eigen, GoogleTest, and the inference
# layer's and CHOLMOD's libraries come from Debian's .debs, extracted on a Debian machine into .deps/
# and packed as .deps.tar.xz (9.7 MB; both ignored; the tarball is what is carried to the GPU machine,
# the folder is 64 MB; bench/gpu/README.md):
#   mkdir -p .deps/dl && cd .deps/dl && apt-get download libeigen3-dev googletest nlohmann-json3-dev \
#     libnlopt-dev libnlopt0 libnlopt-cxx-dev libyaml-cpp-dev libyaml-cpp0.7 libsuitesparse-dev libcholmod3 libamd2 libcamd2 \
#     libccolamd2 libcolamd2 libsuitesparseconfig5 libmetis5 libopenblas0-pthread libgfortran5 libquadmath0 &&
#   for f in *.deb; do dpkg -x "$f" ../root; done && cd .. && rm -rf dl &&
#   find root -name '*.a' -delete && rm -rf root/usr/share/doc root/usr/share/man && cd .. &&
#   tar -C .deps -cJf .deps.tar.xz root
# Usage: bench/gpu/run.sh OUT_DIR [test|bench|floor|neural|static|infer|infer-cpu|rigid|lanes|ncu|all]...   (default: all)
#   floor: bench_gpu_floor, the step's two neighbour passes alone (bench/gpu/README.md), beside bench_gpu_soft's
#   100k and 1M explicit steps in the same call.
#   infer: bench_infer's finger (9212 particles) and neural hanging (150k points, 8 x 512) with backend
#   cuda; infer-cpu: the finger with backend cpu on the same machine (CHOLMOD on its cores); rigid: the
#   tumbler inference (bench_infer tumbler_quadric_2s, its rigid simulation on one host core), 3 runs.
set -euo pipefail
out=${1:?usage: bench/gpu/run.sh OUT_DIR [test|bench|floor|neural|static|infer|infer-cpu|rigid|lanes|ncu|all]...}
shift
steps=${*:-all}
root=$(cd "$(dirname "$0")/../.." && pwd)
deps=$root/.deps/root
[ -d "$deps/usr/include/eigen3" ] || [ ! -f "$root/.deps.tar.xz" ] || { mkdir -p "$root/.deps" && tar -C "$root/.deps" -xJf "$root/.deps.tar.xz"; }
[ -d "$deps/usr/include/eigen3" ] || { echo "run.sh: $deps has no Eigen: extract libeigen3-dev and googletest first (see the header)"; exit 2; }
lib=$deps/usr/lib/x86_64-linux-gnu
export LD_LIBRARY_PATH=$lib:$lib/openblas-pthread${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
mkdir -p "$out"
build=${TOPO_GPU_BUILD:-/tmp/topo-gpu-build}
cmake -S "$root" -B "$build" -G Ninja -DTOPO_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
  -DEigen3_DIR="$deps/usr/share/eigen3/cmake" -DGTEST_SOURCE_DIR="$deps/usr/src/googletest" \
  -DCMAKE_CUDA_ARCHITECTURES="${CUDA_ARCH:-90}" -Dnlohmann_json_DIR="$deps/usr/share/cmake/nlohmann_json" \
  -DNLopt_DIR="$lib/cmake/nlopt" -Dyaml-cpp_DIR="$lib/cmake/yaml-cpp" -DCHOLMOD_INCLUDE_DIR="$deps/usr/include/suitesparse" \
  -DCHOLMOD_LIBRARY="$lib/libcholmod.so" >"$out/cmake.log" 2>&1 || { tail -30 "$out/cmake.log"; exit 1; }
grep -E "CUDA backend|no CUDA backend|CHOLMOD|core build" "$out/cmake.log"
cmake --build "$build" -j"$(nproc)" --target core_cuda_soft_body core_cuda_neural core_cuda_dense_cholesky bench_gpu_soft \
  bench_gpu_neural bench_gpu_static bench_gpu_floor inference_gpu_finger bench_infer >"$out/build.log" 2>&1 ||
  { grep -E "error|FAILED" "$out/build.log" | head -40; exit 1; }
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv,noheader
has() { [[ " $steps " == *" $1 "* || " $steps " == *" all "* ]]; }
if has test; then
  for t in core_cuda_soft_body core_cuda_neural core_cuda_dense_cholesky inference_gpu_finger; do
    "$build/$t" 2>&1 | tee -a "$out/test.log" | grep -E "parity|PASSED|FAILED|SKIPPED|Failure|error" || true
  done
fi
if has lanes; then
  for L in 1 4 8 16 32; do "$build/bench_gpu_soft" --quick --lanes $L explicit_ | tee -a "$out/lanes.jsonl"; done
fi
if has bench; then
  "$build/bench_gpu_soft" | tee "$out/bench.jsonl"
fi
if has floor; then
  for r in 1 2; do
    "$build/bench_gpu_floor" | tee -a "$out/bench_floor.jsonl"
    "$build/bench_gpu_soft" explicit_100k_h1.0 | tee -a "$out/bench_floor.jsonl"
    "$build/bench_gpu_soft" explicit_1m | tee -a "$out/bench_floor.jsonl"
  done
fi
if has static; then
  "$build/bench_gpu_static" | tee "$out/bench_static.jsonl"
fi
if has infer; then
  "$build/bench_infer" --backend cuda finger_quadric 2>"$out/infer_cuda.err" | tee "$out/bench_infer_cuda.jsonl"
  "$build/bench_infer" --backend cuda hanging_neural_8x512 2>>"$out/infer_cuda.err" | tee -a "$out/bench_infer_cuda.jsonl"
  grep -v "warning: spacing" "$out/infer_cuda.err" | tail -5
fi
if has rigid; then  # the rigid tumbler inference: its simulation runs on the host's CPU (one core)
  for k in 1 2 3; do "$build/bench_infer" tumbler_quadric_2s 2>>"$out/rigid.err" | tee -a "$out/bench_infer_rigid.jsonl"; done
fi
if [[ " $steps " == *" infer-cpu "* ]]; then
  "$build/bench_infer" --backend cpu finger_quadric 2>"$out/infer_cpu.err" | tee "$out/bench_infer_cpu.jsonl"
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
