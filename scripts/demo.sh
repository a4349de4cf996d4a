#!/usr/bin/env bash
# `make demo`: the full lab loop, headless, on the digital twins. For each rig (RIG=tumbler|finger|all,
# default all): launches it with its twin, waits for the tracker to measure the twin, sends the
# infer_interior goal (infer_client prints feedback lines), writes the outputs, and prints the
# recovered features next to the twin's ground truth, then the interior against the twin's (solid
# fraction, mass, centre of mass, inertia, IoU). Ends with one verdict line per rig; exit 0 when every
# rig's features agree within 2 % of the twin's truth.
#   tumbler: demo.launch (rig_simulator, cloud_ingest filling the twin's scan, motion_tracker,
#            interior_inference), three experiments: released at 10 and at 25 deg, and hung from a
#            point on its top 4 cm off its axis; then the loop: the twin performs the experiment each
#            result suggests (rig_simulator's ~perform_experiment) and the inference runs again on all of
#            them, until the result's rule stops or the doll has TOPO_DEMO_EXPERIMENTS (5) experiments;
#   finger:  soft_finger_rig.launch (the finger twin stepping its chamber pressure 0 -> 5e5 Pa,
#            motion_tracker kind finger, interior_inference on the default finger), one bend.
#   scripts/demo.sh [BUILD_DIR] [OUTPUT_DIR]        (RIG in the environment)
set -o pipefail
BUILD=${1:-build}
OUT=${2:-$BUILD/demo}
RIG=${RIG:-all}
export PATH=/usr/bin:$PATH
case "$RIG" in
  tumbler | finger | all) ;;
  *) echo "[make demo] RIG=$RIG: use tumbler, finger or all" >&2; exit 2 ;;
esac
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
export ROS_HOME=${ROS_HOME:-$OUT/ros_home}
# A private master port, so the demo does not meet another roscore on this machine.
export ROS_MASTER_URI=http://localhost:${TOPO_DEMO_PORT:-11391}
LAUNCH=
cleanup() {
  [ -n "$LAUNCH" ] && kill -INT "$LAUNCH" 2>/dev/null && wait "$LAUNCH" 2>/dev/null
  LAUNCH=
}
trap cleanup EXIT

# run_rig NAME LAUNCH_FILE INFER_CLIENT_ARGS...
run_rig() {
  local name=$1 launch=$2
  shift 2
  local log="$OUT/demo_${name}_launch.log"
  echo "[make demo] ${name}: ${launch} started (log: $log); waiting for the tracker to measure the twin ..."
  roslaunch topo_gaussian "$launch" output_dir:="$OUT/runs" >"$log" 2>&1 &
  LAUNCH=$!
  "$BUILD/devel/lib/topo_gaussian/infer_client" _ground_truth_topic:=/rig_simulator/ground_truth \
      _wait_for_features_s:=120 _timeout_s:=900 "$@" | tee "$OUT/demo_${name}_client.log"
  local rc=${PIPESTATUS[0]}
  if [ $rc -ne 0 ]; then
    echo "[make demo] ${name}: infer_client exited $rc; last lines of $log:"
    tail -n 20 "$log"
  fi
  cleanup
  local verdict
  verdict=$(grep -a "^\[demo\] verdict:" "$OUT/demo_${name}_client.log" | tail -n 1 | sed 's/^\[demo\] verdict: //')
  VERDICTS+=("[make demo] ${name}: ${verdict:-FAIL: infer_client exited $rc before a verdict}")
  return $rc
}
VERDICTS=()

status=0
if [ "$RIG" = tumbler ] || [ "$RIG" = all ]; then
  run_rig tumbler demo.launch _experiments:="rock10=tumbler;rock25=tumbler;hang=hanging" \
      _weigh_topic:=/scale_kg _weigh_experiment:=hang _auto_experiments:="${TOPO_DEMO_EXPERIMENTS:-5}" \
      _overrides:="contact_damping_ratio=0;measured_cycles=1;density_solid=5000;rock25.initial_tilt_deg=25;hang.hanging_point=0,0.04,0.02" \
      || status=$?
fi
if [ "$RIG" = finger ] || [ "$RIG" = all ]; then
  # the twin's materials (config/rigs/finger_twin.yaml)
  run_rig finger soft_finger_rig.launch _task:=finger _overrides:="youngs_modulus_solid=2e6" || status=$?
fi
echo "[make demo] outputs under $OUT/runs"
for v in "${VERDICTS[@]}"; do echo "$v"; done
exit $status
