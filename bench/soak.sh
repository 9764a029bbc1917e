#!/usr/bin/env bash
# Soak benchmark (issue 17, docs/live.md "Memory over long runs"): a long simulated recording
# replayed at high speed through the live group, the memory of every process of the group sampled
# from /proc, and the group's final RESULT.json compared with `agvcal solve` on the same recording.
#
#   bench/soak.sh [--minutes M] [--sim SIM.yaml] [--speed X] [--interval S] [--dir DIR] [--time-offset]
#
#   --minutes M    robot time of the recording (default 60)
#   --sim SIM      simulation config (default config/sims/forklift.yaml): its default trajectory
#                  again and again (agvcal-bench-long-recording)
#   --speed X      replay speed (lcm-logplayer -s, default 8)
#   --interval S   sampling period, wall seconds (default 1)
#   --dir DIR      where the recording (kept and reused), the run directory, the offline result and
#                  the samples (samples.csv) go (default /tmp/agvcal-soak); keep it out of the repository
#   --time-offset  solve with the time offset, offline and live (agvcal-solver --time-offset: its
#                  final solve matches the recording's scans a second time)
# Prints per process (the group's programs, restarted ones under one name), in MB: RSS after the
# first minute of data, at the end of the data (the replay's last sample), the growth between
# them, at its last sample (the solver: during its final solve), and the peak (VmHWM); then
# whether RESULT.json equals the offline solve's.
# Exit status: 0 the results are equal, 1 they differ or the group failed, 2 bad arguments.
set -u
usage() { sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "soak.sh: $*" >&2; exit 2; }
here=$(cd "$(dirname "$0")/.." && pwd)
bin=${AGVCAL_BIN:-$here/build}
minutes=60 sim=$here/config/sims/forklift.yaml speed=8 interval=1 dir=/tmp/agvcal-soak offset=()
while [ $# -gt 0 ]; do
  case "$1" in
    --minutes) minutes=${2:-}; shift 2 || die "--minutes needs a value" ;;
    --sim) sim=${2:-}; shift 2 || die "--sim needs a value" ;;
    --speed) speed=${2:-}; shift 2 || die "--speed needs a value" ;;
    --interval) interval=${2:-}; shift 2 || die "--interval needs a value" ;;
    --dir) dir=${2:-}; shift 2 || die "--dir needs a value" ;;
    --time-offset) offset=(--time-offset); shift ;;
    -h|--help) usage; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
[ -r "$sim" ] || die "$sim: cannot read simulation config"
mkdir -p "$dir" || die "$dir: cannot create"
dir=$(cd "$dir" && pwd)
sim=$(cd "$(dirname "$sim")" && pwd)/$(basename "$sim")
cd "$here" || exit 2
name=$(basename "$sim" .yaml)-${minutes}min
log=$dir/$name.log
result=$name${offset:+-offset}  # the results' names: the recording is the same either way
robot=$("$bin/agvcal-sim" "$sim" --print-robot) || die "$sim: no robot file"
if [ ! -s "$log" ]; then
  "$bin/bench/agvcal-bench-long-recording" "$sim" "$minutes" "$log" || exit 1
fi
start=$(date +%s)
"$bin/agvcal" solve "$robot" "$log" "${offset[@]}" --quiet --out "$dir/$result.offline.json" >/dev/null || exit 1
echo "offline agvcal solve: $(( $(date +%s) - start )) s"

run=$dir/run-$result-$(date +%Y%m%d-%H%M%S)
"$here/scripts/netns-run" "$here/scripts/agvcal-group" --replay "$log" --robot "$robot" --speed "$speed" \
  --run-dir "$run" --solver-args "${offset[*]}" >"$run.out" 2>&1 &
group=$!
# Samples every process under the group's supervisord: wall s since the group started, program
# (argv[0]'s name; the player's shell wrapper counts as the player), pid, VmRSS and VmHWM in kB.
python3 - "$run/supervisord.conf" "$group" "$interval" >"$dir/$result.samples.csv" <<'PY'
import os, sys, time
conf, group, interval = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
t0 = time.time()
def children():
    table = {}
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                with open(f"/proc/{pid}/stat") as f: table.setdefault(int(f.read().rsplit(")", 1)[1].split()[1]), []).append(int(pid))
            except OSError: pass
    return table
def status(pid):
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f: argv = f.read().split(b"\0")
        with open(f"/proc/{pid}/status") as f: fields = dict(l.split(":", 1) for l in f if ":" in l)
    except OSError: return None
    name = os.path.basename(argv[0].decode())
    if name in ("python3", "python") and len(argv) > 1: name = os.path.basename(argv[1].decode())
    if name == "sh" and b"lcm-logplayer" in b" ".join(argv): name = "lcm-logplayer"
    if "VmRSS" not in fields: return None
    return name, int(fields["VmRSS"].split()[0]), int(fields["VmHWM"].split()[0])
print("t,process,pid,rss_kb,hwm_kb")
while os.path.exists(f"/proc/{group}"):
    table, todo, now = children(), [group], time.time() - t0
    while todo:
        pid = todo.pop()
        todo += table.get(pid, [])
        s = status(pid)
        if s and s[0] not in ("netns-run", "unshare", "bash", "agvcal-group", "sleep"):
            print(f"{now:.1f},{s[0]},{pid},{s[1]},{s[2]}")
    sys.stdout.flush()
    time.sleep(interval)
PY
wait "$group"; code=$?
echo "group: exit $code after $(( $(date +%s) - start )) s (run directory $run)"
python3 - "$dir/$result.samples.csv" "$speed" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
speed = float(sys.argv[2])
players = [float(r["t"]) for r in rows if r["process"] == "lcm-logplayer"]
t_start = (players[0] if players else 0.0) + 60.0 / speed  # after the first minute of data
t_data_end = players[-1] if players else float("inf")     # the replay's last sample
print(f"{'process':<20}{'start MB':>9}{'end of data':>12}{'growth':>8}{'last MB':>9}{'peak MB':>9}{'pids':>5}")
for name in sorted({r["process"] for r in rows}):
    mine = [r for r in rows if r["process"] == name]
    after = [r for r in mine if float(r["t"]) >= t_start] or mine[-1:]
    upto = [r for r in mine if float(r["t"]) <= t_data_end] or mine[-1:]
    first, end, last = (int(x["rss_kb"]) / 1024 for x in (after[0], upto[-1], mine[-1]))
    peak = max(int(r["hwm_kb"]) for r in mine) / 1024
    pids = len({r["pid"] for r in mine})
    print(f"{name:<20}{first:>9.1f}{end:>12.1f}{end - first:>8.1f}{last:>9.1f}{peak:>9.1f}{pids:>5}")
PY
[ "$code" -eq 0 ] || { tail -5 "$run.out"; exit 1; }
python3 - "$dir/$result.offline.json" "$run/RESULT.json" <<'PY'
import json, sys
offline, live = (json.load(open(p)) for p in sys.argv[1:3])
differ = [k for k in sorted(set(offline) | set(live)) if offline.get(k) != live.get(k)]
print("RESULT.json vs agvcal solve:", "equal, value for value" if not differ else "DIFFER in " + ", ".join(differ),
      f"({live['residual']['intervals']} intervals)")
sys.exit(1 if differ else 0)
PY
