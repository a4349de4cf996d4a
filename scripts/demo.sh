#!/usr/bin/env bash
# `make demo`: the full lab loop, headless. Launches demo.launch (the tumbler twin: rig_simulator,
# cloud_ingest, motion_tracker, interior_inference), waits for the tracker to measure the twin, sends
# the infer_interior goal (infer_client prints feedback lines), writes the outputs, and prints the
# recovered features next to the twin's ground truth. Exit 0 when they agree within 2 %.
#   scripts/demo.sh [BUILD_DIR] [OUTPUT_DIR]
set -o pipefail
BUILD=${1:-build}
OUT=${2:-$BUILD/demo}
export PATH=/usr/bin:$PATH
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
export ROS_HOME=${ROS_HOME:-$OUT/ros_home}
# A private master port, so the demo does not meet another roscore on this machine.
export ROS_MASTER_URI=http://localhost:${TOPO_DEMO_PORT:-11391}
LOG="$OUT/demo_launch.log"
roslaunch topo_gaussian demo.launch output_dir:="$OUT/runs" >"$LOG" 2>&1 &
LAUNCH=$!
cleanup() { kill -INT "$LAUNCH" 2>/dev/null; wait "$LAUNCH" 2>/dev/null; }
trap cleanup EXIT
echo "[make demo] demo.launch started (log: $LOG); waiting for the tracker to measure the twin ..."
"$BUILD/devel/lib/topo_gaussian/infer_client" _ground_truth_topic:=/rig_simulator/ground_truth \
    _experiments:="rock10=tumbler;rock25=tumbler" \
    _overrides:="contact_damping_ratio=0;measured_cycles=1;rock25.initial_tilt_deg=25" \
    _wait_for_features_s:=120 _timeout_s:=900
rc=$?
if [ $rc -ne 0 ]; then
  echo "[make demo] infer_client exited $rc; last lines of $LOG:"
  tail -n 20 "$LOG"
fi
echo "[make demo] outputs under $OUT/runs"
exit $rc
