#!/usr/bin/env bash
# Builds and runs every unit test, rostest and the bounded fuzz run of a configured build dir,
# then prints the verdict from the JUnit results: a line "N passed, N failed". Exit 1 if any failed.
#   scripts/run_tests.sh [BUILD_DIR] [quick|full]
# quick (`make test`): every test binary and rostest, without the test cases listed in
#   test/slow_tests.txt (peer curves, long inferences: `make test-full` runs them) and with 10 s
#   per fuzz target;
# full (`make test-full`, what CI runs): everything, 30 s per fuzz target.
set -uo pipefail
export PATH=/usr/bin:$PATH
BUILD=${1:-build}
SCOPE=${2:-${TOPO_TEST_SCOPE:-full}}
JOBS=${JOBS:-$(nproc)}
HERE=$(cd "$(dirname "$0")/.." && pwd)
case "$SCOPE" in
  quick)
    # gtest reads GTEST_FILTER from the environment: '-A:B' runs everything but A and B
    slow=$(grep -vE '^\s*(#|$)' "$HERE/test/slow_tests.txt" | awk '{print $1}' | paste -sd: -)
    [ -n "$slow" ] && export GTEST_FILTER="-$slow"
    export TOPO_FUZZ_SECONDS=${TOPO_FUZZ_SECONDS:-10}
    echo "[run_tests] quick: $(grep -cvE '^\s*(#|$)' "$HERE/test/slow_tests.txt") slow test patterns left to make test-full (test/slow_tests.txt)"
    ;;
  full) ;;
  *) echo "[run_tests] scope '$SCOPE': use quick or full" >&2; exit 2 ;;
esac

rm -rf "$BUILD/test_results"
cmake --build "$BUILD" --target tests -j"$JOBS" || { echo "[run_tests] building the tests failed"; echo "0 passed, 1 failed"; exit 1; }
# run_tests exits 0 even when tests fail: the verdict comes from catkin_test_results below.
cmake --build "$BUILD" --target run_tests -j1 2>&1 | tee "$BUILD/run_tests.log" | grep -E "^\[( +OK|  FAILED|  PASSED|  SKIPPED|==========)|\[ROSTEST\]|FAILURE|\[fuzz\]|\[testcase\]" || true

summary=$(catkin_test_results --verbose "$BUILD/test_results" 2>&1)
echo "$summary" | grep -vE "^\s*$" | tail -n 40
line=$(echo "$summary" | grep -E "^Summary:" | tail -n 1)
tests=$(echo "$line" | sed -nE 's/.* ([0-9]+) tests.*/\1/p')
errors=$(echo "$line" | sed -nE 's/.* ([0-9]+) errors.*/\1/p')
failures=$(echo "$line" | sed -nE 's/.* ([0-9]+) failures.*/\1/p')
skipped=$(echo "$line" | sed -nE 's/.* ([0-9]+) skipped.*/\1/p')
tests=${tests:-0}; errors=${errors:-0}; failures=${failures:-0}; skipped=${skipped:-0}
# A test binary that crashed writes no result file: catkin writes a MISSING-*.xml failure for it,
# which the summary above already counts.
failed=$((errors + failures))
passed=$((tests - errors - failures - skipped))
if [ "$tests" -eq 0 ]; then failed=$((failed + 1)); echo "[run_tests] no test results were written"; fi
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]
