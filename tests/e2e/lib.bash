# Shared by the end-to-end tests: paths, a scratch directory, and checks.
# Usage in a test: source "$(dirname "$0")/lib.bash" "$@"
# Every test owns its bus and its files, so tests run in parallel and in any order: the
# whole test runs in a private network namespace of its own (scripts/netns-run), its files
# are in a temporary directory of its own ($TMP, removed at the end), and every process it
# starts carries $TMP in its environment (AGVCAL_TEST_RUN), by which the test finds its own
# processes and none of another test's.
set -u
BUILD=$(cd "${1:?build dir}" && pwd)
SRC=$(cd "${2:?source dir}" && pwd)
if [ -z "${AGVCAL_TEST_NETNS:-}" ]; then
  AGVCAL_TEST_NETNS=1 exec "$SRC/scripts/netns-run" bash "$0" "$@"
fi
export AGVCAL_BIN=$BUILD
# A 4 MB receive buffer (capped by net.core.rmem_max): with the default 208 kB a
# process stalled ~0.1 s by a loaded machine loses UDP messages, and a lost IMU or
# WHEELS message changes every later live result (DESIGN.md: live = offline).
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
AGVCAL=$BUILD/agvcal
CHECK=$BUILD/tests/e2e_log_check
TMP=$(mktemp -d)
export AGVCAL_TEST_RUN=$TMP
# test_pgrep PATTERN: pgrep -f PATTERN among this test's processes only.
test_pgrep() {
  local pid
  for pid in $(pgrep -f -- "$1"); do
    [ "$pid" = $$ ] && continue
    tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qxF "AGVCAL_TEST_RUN=$TMP" && echo "$pid"
  done
  return 0
}
OWN_PROCESSES="$BUILD/agvcal-|agvcal-group|lcm-logger|lcm-logplayer|supervisord|tmux"
trap 'kill -9 $(test_pgrep "$OWN_PROCESSES") 2>/dev/null; rm -rf "$TMP"' EXIT
cd "$SRC"
fails=0 passes=0
pass() { echo "PASS $*"; passes=$((passes + 1)); }
fail() { echo "FAIL $*"; fails=$((fails + 1)); }
# expect_status CODE DESCRIPTION CMD...: runs CMD, checks its exit status, keeps stderr in $TMP/stderr
expect_status() {
  local want=$1 what=$2; shift 2
  "$@" >"$TMP/stdout" 2>"$TMP/stderr"; local got=$?
  if [ "$got" -eq "$want" ]; then pass "$what (exit $got)"; else fail "$what: exit $got, expected $want; stderr: $(head -c 400 "$TMP/stderr")"; fi
}
# stderr_has TEXT: the last expect_status printed TEXT on stderr
stderr_has() { if grep -qF -- "$1" "$TMP/stderr"; then pass "message names '$1'"; else fail "message lacks '$1': $(head -c 400 "$TMP/stderr")"; fi; }
no_orphans() {
  local left
  left=$(test_pgrep "$OWN_PROCESSES")
  if [ -z "$left" ]; then pass "no process left behind"; else fail "processes left behind: $(ps -o pid=,args= -p "$(echo $left | tr " " ,)")"; kill -9 $left; fi
}
# wait_for SECONDS WHAT CMD...: waits until CMD succeeds (tried every 0.2 s); after SECONDS a
# failed check naming WHAT. Tests wait for states, not for times: load changes only how long.
wait_for() {
  local limit=$1 what=$2; shift 2
  local until=$((SECONDS + limit))
  until "$@" >/dev/null 2>&1; do
    if [ "$SECONDS" -ge "$until" ]; then fail "waited $limit s for $what"; return 1; fi
    sleep 0.2
  done
}
# recorded CHANNEL LOG: the messages on CHANNEL that LOG holds so far (0 if none, or no LOG)
recorded() {
  local n
  n=$("$BUILD/agvcal-recording" count "$2" 2>/dev/null | grep -oE "(: |, )$1 [0-9]+" | grep -oE '[0-9]+$')
  echo "${n:-0}"
}
# at_least N CMD...: CMD prints a number >= N
at_least() { [ "$("${@:2}")" -ge "$1" ]; }
# group_pid RUN_DIR PROCESS: the pid of PROCESS in the group of RUN_DIR (supervisorctl), or nothing
group_pid() {
  local pid
  pid=$(supervisorctl -c "$1/supervisord.conf" pid "$2" 2>/dev/null)
  [[ "$pid" =~ ^[1-9][0-9]*$ ]] && echo "$pid"
}
# start_logger LOG CHANNELS: lcm-logger records CHANNELS (a regex) and HEARTBEAT into LOG, in
# the background (its pid in $logger); returns once it records (agvcal-recording drain: a mark
# it publishes is in LOG). The processes' HEARTBEATs in LOG tell when they have subscribed.
# Without LCM's 30-message queue limit (as the group's logger): a logger stalled by a loaded
# machine would drop messages from the middle of a fast stream.
start_logger() {
  LD_PRELOAD=$BUILD/libagvcal-lcm-unbounded-queue.so lcm-logger -f "$1" -c "$2|HEARTBEAT" >/dev/null 2>&1 & logger=$!
  "$BUILD/agvcal-recording" drain "$1" --timeout 60 >/dev/null 2>&1 ||
    { fail "lcm-logger did not record into $1 within 60 s"; return 1; }
}
# stop_logger LOG: everything published so far is in LOG (drained), then the logger stops.
stop_logger() {
  "$BUILD/agvcal-recording" drain "$1" --timeout 60 >/dev/null 2>&1 || fail "the logger of $1 did not drain within 60 s"
  kill -INT "$logger"; wait "$logger"
}
# replay_into OUT CHANNELS SPEED RECORDING PROCESS CMD...: CMD (agvcal-PROCESS; its stderr in
# $TMP/PROCESS.err) in the background while OUT records CHANNELS; RECORDING replayed at SPEED once
# PROCESS has subscribed; then PROCESS stopped (SIGINT) and OUT drained. A check of its exit 0.
replay_into() {
  local out=$1 channels=$2 speed=$3 recording=$4 process=$5 pid status; shift 5
  start_logger "$out" "$channels"
  "$@" 2>"$TMP/$process.err" & pid=$!
  wait_ready "$out" "$process" && timeout 120 lcm-logplayer -s "$speed" "$recording"
  stop $pid "agvcal-$process"; status=$?
  stop_logger "$out"
  [ $status -eq 0 ] && pass "replay into agvcal-$process, stopped with SIGINT (exit 0)" ||
    fail "agvcal-$process exit $status: $(tail -c 400 "$TMP/$process.err")"
}
# beat_seen LOG PROCESS [STATE_REGEX]: LOG holds a HEARTBEAT of PROCESS (whose state matches)
beat_seen() { python3 "$SRC/tests/tools/heartbeats.py" "$1" "$2" | grep -qE -- "${3:-.}"; }
# beat_now LOG PROCESS STATE_REGEX: PROCESS's last HEARTBEAT in LOG matches
beat_now() { python3 "$SRC/tests/tools/heartbeats.py" "$1" "$2" | tail -1 | grep -qE -- "$3"; }
# wait_ready LOG PROCESS...: waits until LOG holds a HEARTBEAT of each PROCESS; a process beats
# first after it has subscribed, so a replay started then reaches it whole.
wait_ready() {
  local log=$1 process; shift
  for process; do wait_for 60 "agvcal-$process's first HEARTBEAT (subscribed)" beat_seen "$log" "$process" || return 1; done
}
# stop PID NAME: SIGINT to PID and its exit status, once it has ended; a failed check naming
# NAME if it is still running 60 s later (then killed).
# Polled from this shell: a watchdog subshell killed before it had reset its traps would run
# this test's EXIT trap (bash does), which kills the test's processes and removes $TMP.
stop() {
  kill -INT "$1" 2>/dev/null
  local until=$((SECONDS + 60))
  while kill -0 "$1" 2>/dev/null && [ "$SECONDS" -lt "$until" ]; do sleep 0.1; done
  kill -0 "$1" 2>/dev/null && { kill -9 "$1"; fail "$2 still running 60 s after SIGINT (killed)"; }
  wait "$1"
}
finish() { echo "checks: $passes passed, $fails failed"; [ "$fails" -eq 0 ]; exit $?; }
