#!/usr/bin/env bash
# Runs a fuzzer (fuzz_readers, fuzz_task_config, fuzz_ros_conversions) for a bounded time and writes a
# JUnit XML result.
# Usage: run_fuzz.sh <fuzz binary> <seed corpus dir> <junit xml out>
# The dictionary is <name without fuzz_>.dict beside this script, when there is one (readers.dict).
# Environment: TOPO_FUZZ_SECONDS (default 30); TOPO_FUZZ_RUNS=N stops after N executions instead
# (TOPO_FUZZ_SECONDS then only caps the time, default 3600). Crash inputs are kept next to the XML file in
# fuzz_artifacts/ so that they can be replayed with: <binary> <artifact>
set -u

if [ $# -ne 3 ]; then
  echo "usage: $0 <fuzz_binary> <corpus_dir> <junit_xml_out>" >&2
  exit 2
fi
bin=$1
corpus=$2
xml=$3
runs=${TOPO_FUZZ_RUNS:-}
if [ -n "$runs" ]; then
  seconds=${TOPO_FUZZ_SECONDS:-3600}
else
  seconds=${TOPO_FUZZ_SECONDS:-30}
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/topo_fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/corpus" "$work/artifacts"
# The seed corpus stays untouched: the fuzzer adds its new inputs to the copy.
if [ -d "$corpus" ]; then
  cp -r "$corpus"/. "$work/corpus/"
fi
extra_args=()
if [ -n "$runs" ]; then
  extra_args+=("-runs=$runs")
fi
name=$(basename "$bin")
dict="$(cd "$(dirname "$0")" && pwd)/${name#fuzz_}.dict"
if [ -f "$dict" ]; then
  extra_args+=("-dict=$dict")
fi

start=$(date +%s)
if [ -x "$bin" ]; then
  "$bin" "$work/corpus" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 \
    -artifact_prefix="$work/artifacts/" -print_final_stats=1 ${extra_args[@]+"${extra_args[@]}"} >"$work/log" 2>&1
  status=$?
else
  echo "fuzz binary not found or not executable: $bin" >"$work/log"
  status=127
fi
elapsed=$(( $(date +%s) - start ))

mkdir -p "$(dirname "$xml")"
if [ "$status" -ne 0 ] && [ -n "$(ls -A "$work/artifacts")" ]; then
  keep="$(dirname "$xml")/fuzz_artifacts"
  mkdir -p "$keep"
  cp "$work/artifacts"/* "$keep/"
  echo "crash inputs copied to $keep" >>"$work/log"
fi

# XML-escape the log tail and drop control characters (ANSI colours) that XML does not allow.
escape() { tr -d '\000-\010\013\014\016-\037' | sed -e 's/&/\&amp;/g' -e 's/</\&lt;/g' -e 's/>/\&gt;/g'; }
{
  echo '<?xml version="1.0" encoding="UTF-8"?>'
  failures=0
  [ "$status" -ne 0 ] && failures=1
  echo "<testsuite name=\"fuzz\" tests=\"1\" failures=\"$failures\" errors=\"0\" time=\"$elapsed\">"
  echo "  <testcase classname=\"fuzz.${name#fuzz_}\" name=\"$name\" time=\"$elapsed\">"
  if [ "$status" -ne 0 ]; then
    echo "    <failure message=\"$name exited with status $status\">"
    tail -n 80 "$work/log" | escape
    echo "    </failure>"
  fi
  echo "    <system-out>"
  tail -n 15 "$work/log" | escape
  echo "    </system-out>"
  echo "  </testcase>"
  echo "</testsuite>"
} >"$xml"

tail -n 20 "$work/log"
exit "$status"
