#!/usr/bin/env bash
# Runs the libFuzzer targets (bench/fuzz/*_fuzz.cc, docs/bad-input.md) under ASan and UBSan,
# each for SECONDS, and prints per target the executions, their rate and the crashes found.
#   bench/fuzz/run.sh TARGET|all SECONDS
#   bench/fuzz/run.sh --ci          all targets for 4 s each on the committed corpus (ctest fuzz_smoke;
#                                   AGVCAL_FUZZ_SECONDS=S sets the seconds per target)
#   AGVCAL_FUZZ_RUNS=N bench/fuzz/run.sh TARGET|all 0   stop each target after N executions instead
# Builds the targets it runs in build-fuzz/ first (clang++, -DAGVCAL_FUZZ=ON; AGVCAL_FUZZ_BUILD overrides
# the directory).
# New inputs go to build-fuzz/corpus/TARGET (the committed bench/fuzz/corpus/TARGET is only read),
# a crashing input to build-fuzz/artifacts/TARGET/. Exit 0 only when no target crashed.
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
build=${AGVCAL_FUZZ_BUILD:-$here/build-fuzz}
targets_all=(recording messages robot_file sim_config pcd kitti carmen mines lego optiodom pose_csv
             candump sick_cola bridge_config mcap)
usage() { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; }
ci=0
case "${1:-}" in
  -h|--help) usage; exit 0 ;;
  --ci) ci=1; which=all; seconds=${AGVCAL_FUZZ_SECONDS:-4} ;;
  "") usage >&2; exit 2 ;;
  *) which=$1; seconds=${2:?SECONDS missing}; shift 2 ;;
esac
if ! command -v clang++ >/dev/null; then
  echo "run.sh: clang++ not found (Debian: apt-get install clang libclang-rt-14-dev)" >&2
  exit 77
fi
if [ "$which" = all ]; then targets=("${targets_all[@]}"); else targets=("$which"); fi
for t in "${targets[@]}"; do
  [ -f "$here/bench/fuzz/${t}_fuzz.cc" ] || { echo "run.sh: no target $t (${targets_all[*]})" >&2; exit 2; }
done

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$here" -B "$build" -DAGVCAL_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++ \
        -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 >/dev/null
fi
# Only the targets to run (not fuzz_seeds, nor the Java types a full build makes too).
cmake --build "$build" -j"$(nproc)" --target "${targets[@]/#/fuzz_}" >/dev/null

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
failed=0
printf '%-14s %12s %10s %8s  %s\n' target executions "exec/s" crashes artifact
for t in "${targets[@]}"; do
  if [ $ci = 1 ]; then work=$(mktemp -d); else work=$build/corpus/$t; fi
  artifacts=$build/artifacts/$t/
  mkdir -p "$work" "$artifacts"
  log=$build/fuzz_$t.log
  status=0
  if [ -n "${AGVCAL_FUZZ_RUNS:-}" ]; then limit=-runs=$AGVCAL_FUZZ_RUNS; else limit=-max_total_time=$seconds; fi
  "$build/bench/fuzz/fuzz_$t" "$limit" -timeout=10 -rss_limit_mb=2048 \
      -max_len=262144 -print_final_stats=1 -artifact_prefix="$artifacts" \
      "$work" "$here/bench/fuzz/corpus/$t" > "$log" 2>&1 || status=$?
  [ $ci = 1 ] && rm -rf "$work"
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  crashes=0 artifact=-
  if [ $status -ne 0 ]; then
    crashes=1 failed=1
    artifact=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log" | tail -1)
    grep -m 3 -E 'ERROR|runtime error|uncaught|SUMMARY' "$log" | sed 's/^/    /' >&2 || true
  fi
  printf '%-14s %12s %10s %8s  %s\n' "$t" "${runs:-?}" "${rate:-?}" "$crashes" "${artifact:-$log}"
done
exit $failed
