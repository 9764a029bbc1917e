# Shared by the end-to-end tests: paths, a scratch directory, and checks.
# Usage in a test: source "$(dirname "$0")/lib.bash" "$@"
set -u
BUILD=$(cd "${1:?build dir}" && pwd)
SRC=$(cd "${2:?source dir}" && pwd)
export AGVCAL_BIN=$BUILD
# A 4 MB receive buffer (capped by net.core.rmem_max): with the default 208 kB a
# process stalled ~0.1 s by a loaded machine loses UDP messages, and a lost IMU or
# WHEELS message changes every later live result (DESIGN.md: live = offline).
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
AGVCAL=$BUILD/agvcal
CHECK=$BUILD/tests/e2e_log_check
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
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
  left=$(pgrep -f "$BUILD/agvcal-(sim|commander|solver|scanmatch)|lcm-logger .*$TMP|lcm-logplayer .*($TMP|$SRC)|supervisord -n -c $TMP" || true)
  if [ -z "$left" ]; then pass "no process left behind"; else fail "processes left behind: $(ps -o pid=,args= -p "$(echo $left | tr " " ,)")"; pkill -9 -f "$BUILD/agvcal-" || true; fi
}
finish() { echo "checks: $passes passed, $fails failed"; [ "$fails" -eq 0 ]; exit $?; }
