#!/usr/bin/env bash
# The terminal dashboard, used as a person would: agvcal-dashboard runs in an
# 80x24 tmux window (in a private network namespace) while a recording is replayed
# with lcm-logplayer into agvcal-scanmatch, agvcal-solver and agvcal-commander.
# The screen's text is checked: parameter names and the numbers the solver wrote,
# channel rates, staleness once the replay ends, process names, the commander's
# state; views are switched with keys, the display paused, the window resized;
# q and Ctrl-C quit with exit 0 and a restored terminal.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log
export LANG=C.UTF-8

cat > "$TMP/run.sh" <<RUN
set -u
sock="$TMP/tmux.sock"
tm() { tmux -S "\$sock" "\$@"; }
cap() { tm capture-pane -p -t dash > "$TMP/\$1.txt"; }
# wait_for NAME REGEX SECONDS: captures into NAME until the screen matches REGEX
wait_for() {
  for _ in \$(seq \$((\$3 * 10))); do cap "\$1"; grep -qE -- "\$2" "$TMP/\$1.txt" && return 0; sleep 0.1; done
  echo "timed out waiting for '\$2'" >> "$TMP/run.err"; return 1
}
# wait_until_gone NAME REGEX SECONDS: captures into NAME until the screen no longer matches REGEX
wait_until_gone() {
  for _ in \$(seq \$((\$3 * 10))); do cap "\$1"; grep -qE -- "\$2" "$TMP/\$1.txt" || return 0; sleep 0.1; done
  echo "timed out waiting for '\$2' to go" >> "$TMP/run.err"; return 1
}
# wait_changed NAME EARLIER SECONDS: captures into NAME until the screen differs from EARLIER's
wait_changed() {
  for _ in \$(seq \$((\$3 * 10))); do cap "\$1"; cmp -s "$TMP/\$1.txt" "$TMP/\$2.txt" || return 0; sleep 0.1; done
  echo "timed out waiting for the screen to change from \$2" >> "$TMP/run.err"; return 1
}
tm -f /dev/null new-session -d -s dash -x 80 -y 24 \
  "'$BUILD/agvcal-dashboard'; echo \"dashboard exit=\\\$?\"; stty -a > '$TMP/stty.txt'; exec sleep 120"
"$BUILD/agvcal-scanmatch" "$robot" 2> "$TMP/scanmatch.err" & matcher=\$!
"$BUILD/agvcal-solver" "$robot" --every 4 --out "$TMP/live.json" 2> "$TMP/solver.err" & solver=\$!
"$BUILD/agvcal-commander" "$robot" --trajectory demo 2> "$TMP/commander.err" & commander=\$!
wait_for start "agvcal dashboard" 10
# Everything subscribed before the replay starts: each process beats first after it has
# subscribed, and the bus view lists the processes it has heard.
tm send-keys -t dash 4
wait_for start "^scanmatch .* ok\$" 20 && wait_for start "^solver .* ok\$" 20 && wait_for start "^commander .* ok\$" 20
tm send-keys -t dash 1
# Only the sensors (the commander sends its own DRIVE_CMD), at twice the recorded speed.
lcm-logplayer -s 2 -e '^(WHEELS|SCAN|IMU)\$' "$log" > /dev/null & player=\$!
wait_for live "commander running" 20 && wait_for live "Calibration: ok" 20
tm send-keys -t dash 4
wait_for bus_live "^IMU .* ok\$" 10 && wait_for bus_live "^SCAN .* ok\$" 10 && wait_for bus_live "^WHEELS .* ok\$" 10
wait \$player
wait_for bus_stale "^IMU .*STALE" 8 && wait_for bus_stale "^WHEELS .*STALE" 3 && wait_for bus_stale "^SCAN .*STALE" 3
# SIGINT: the matcher publishes its last matches as it stops; the solver handles what it has
# received before its final estimate (also in live.json).
kill -INT \$matcher; wait \$matcher
kill -INT \$solver; wait \$solver
tm send-keys -t dash 1
wait_for overview "Calibration: final" 10
tm send-keys -t dash 2; wait_for residuals "\[2 residuals\]" 10
tm send-keys -t dash 3; wait_for parameters "\[3 parameters\]" 10
tm send-keys -t dash '?'; wait_for help "pause / resume" 10
tm send-keys -t dash x; wait_until_gone help_closed "pause / resume" 10
# Paused: the screen stays as it was over 1.5 s (the observation, not a wait), then resumes.
tm send-keys -t dash p; wait_for paused_a "PAUSED" 10; sleep 1.5; cap paused_b
tm send-keys -t dash p; wait_for resumed "LIVE" 10 && wait_changed resumed paused_b 10
tm send-keys -t dash 2; tm resize-window -t dash -x 120 -y 40; wait_for big_residuals "^.{100,}" 10
tm send-keys -t dash 1; wait_for big_overview "\[1 overview\].*" 10 && wait_for big_overview "^.{100,}" 10
tm resize-window -t dash -x 80 -y 24; wait_until_gone small_again "^.{81,}" 10 && wait_for small_again "\[1 overview\]" 10
tm send-keys -t dash q
wait_for quit "dashboard exit=" 5
tm display-message -p -t dash '#{alternate_on}' > "$TMP/alternate_on.txt"
# Ctrl-C in a second window quits as cleanly.
tm new-window -d -t dash -n ctrlc "'$BUILD/agvcal-dashboard' --stale-after 1; echo \"dashboard exit=\\\$?\"; exec sleep 120"
ctrlc_screen() { tm capture-pane -p -t dash:ctrlc > "$TMP/ctrlc.txt"; grep -qE -- "\$1" "$TMP/ctrlc.txt"; }
for _ in \$(seq 100); do ctrlc_screen "agvcal dashboard" && break; sleep 0.1; done
tm send-keys -t dash:ctrlc C-c
for _ in \$(seq 100); do ctrlc_screen "dashboard exit=" && break; sleep 0.1; done
tm kill-server
kill -INT \$commander 2>/dev/null; wait \$commander
exit 0
RUN
expect_status 0 "replay with the dashboard in tmux" timeout 180 scripts/netns-run bash "$TMP/run.sh"
[ -s "$TMP/run.err" ] && fail "$(cat "$TMP/run.err")"
# The screens, for docs/live.md's text capture: AGVCAL_DASHBOARD_CAPTURES=DIR keeps them.
if [ -n "${AGVCAL_DASHBOARD_CAPTURES:-}" ]; then mkdir -p "$AGVCAL_DASHBOARD_CAPTURES" && cp "$TMP"/*.txt "$AGVCAL_DASHBOARD_CAPTURES"/; fi

python3 - "$TMP" <<'PY'
import json, os, re, sys
tmp = sys.argv[1]
fails = 0
def check(ok, what):
    global fails
    print(("PASS " if ok else "FAIL ") + what)
    fails += 0 if ok else 1
def screen(name):
    path = os.path.join(tmp, name + ".txt")
    return open(path, encoding="utf-8").read() if os.path.exists(path) else ""
def fits(name, cols, rows):
    lines = screen(name).rstrip("\n").split("\n")
    widest = max(len(l) for l in lines)
    check(len(lines) <= rows and widest <= cols and widest >= cols - 2,
          f"{name}: {len(lines)} rows, {widest} columns fit {cols}x{rows}")
def line_of(name, start):
    return next((l for l in screen(name).split("\n") if l.startswith(start)), "")

live = json.load(open(os.path.join(tmp, "live.json")))
values = {**{k: v for k, v in live["params"].items()},
          **{"lidar2d." + k: v for k, v in live["lidar2d"].items() if k != "time_offset"}}
n = live["residual"]["intervals"]
m = live["residual"]["outliers"]  # the solve's outliers (the matcher decides the data; not fixed)
# Overview at the end: each parameter's value and sigma as the solver wrote them.
for name, v in values.items():
    row = line_of("overview", name + " ").split()
    shown = row[1:3] if len(row) >= 3 else []
    check(shown == [f"{v['value']:.6f}", f"{v['std']:.6f}"],
          f"overview shows {name} {v['value']:.6f} +- {v['std']:.6f} (screen: {' '.join(shown)})")
    check("converged" in line_of("overview", name + " "), f"{name} has converged")
    check(f"{v['value']:.6f} +- {v['std']:.6f}" in line_of("parameters", name + " "),
          f"parameters view shows {name}")
ov = screen("overview")
check(f"Calibration: final tricycle  intervals {n}  outliers {m}" in ov, f"final estimate, {n} intervals, {m} outliers")
# The residual line counts each interval's residual as it was sent (its outlier flag then), not
# the last solve's outliers: the same count in the residual view.
rl = re.search(r"residual rms  x [0-9.]+ mm  y [0-9.]+ mm  yaw [0-9.e-]+ mrad  \(%d sent, ([0-9]+) flagged\)" % n, ov)
check(rl, "residual rms line")
sent_outliers = int(rl.group(1)) if rl else -1
check(sum(1 for c in ov if 0x2800 < ord(c) <= 0x28FF) > 30, "braille residual plots")
check("commander finished  demo  segment 6/6" in ov, "commander finished")
weak = live["observability"]["weak"]
check(("observability: all parameters determined" in ov) if not weak else ("weak: " + " ".join(weak) in ov),
      f"observability state (weak: {weak})")
# Rates while the replay runs at -s 2: data rates from the robot clock, bus rates about twice
# that (less when a busy machine loses messages).
def rates(channel):
    row = line_of("bus_live", channel + " ").split()
    return (float(row[3]), float(row[4]), row[-1]) if len(row) >= 7 else (0, 0, "")
for channel, hz in (("WHEELS", 100), ("SCAN", 20), ("IMU", 200)):
    bus, data, state = rates(channel)
    check(abs(data - hz) <= 0.01 * hz and 1.2 * hz <= bus <= 2.2 * hz and state == "ok",
          f"{channel}: data {data} Hz (expected {hz}), bus {bus} Hz (expected about {2 * hz}), {state}")
for process in ("commander", "scanmatch", "solver"):
    row = line_of("bus_live", process + " ")
    check(row.endswith(" ok") and re.match(process + r" +\d+ ", row), f"process {process} reported ok: {row!r}")
check("commander running, trajectory demo" in screen("bus_live"), "commander running during the replay")
check("Calibration: ok" in screen("live"), "estimates during the replay")
# After the replay: sensor channels stale, the live processes still beating.
for channel in ("WHEELS", "SCAN", "IMU"):
    check(line_of("bus_stale", channel + " ").endswith("STALE"), f"{channel} stale after the replay")
for process in ("scanmatch", "solver"):
    check(line_of("bus_stale", process + " ").endswith(" ok"), f"{process} still alive after the replay")
res = screen("residuals")
check(all(re.search(r"^" + k + r" +rms [0-9.]+ (mm|mrad)  max [0-9.]+ (mm|mrad)  n %d  outliers %d" % (n, sent_outliers), res, re.M)
          for k in ("x", "y", "yaw")), "residual view: rms, max, counts per component")
check(res.count("histogram") == 3 and sum(1 for c in res if 0x2581 <= ord(c) <= 0x2588) > 20,
      "residual view: three histograms of block bars")
check("[2 residuals]" in res and "[3 parameters]" in screen("parameters") and "[4 bus]" in screen("bus_stale"),
      "keys 2, 3, 4 switch views")
check("p  pause / resume the display" in screen("help") and "pause / resume" not in screen("help_closed"),
      "? shows the help, a key closes it")
check("PAUSED" in screen("paused_a") and screen("paused_a") == screen("paused_b"), "p freezes the screen")
check("LIVE" in screen("resumed") and screen("resumed") != screen("paused_b"), "p again resumes")
for name in ("overview", "residuals", "parameters", "bus_live", "bus_stale", "help", "small_again"):
    fits(name, 80, 24)
for name in ("big_residuals", "big_overview"):
    fits(name, 120, 40)
big = screen("big_residuals").split("\n")
yaw_row = next((i for i, l in enumerate(big) if l.startswith("yaw ")), 0)
check(yaw_row > 24, f"residual plots grow with the window (yaw block at row {yaw_row})")
check("drive_radius" in screen("big_overview") and "[1 overview]" in screen("small_again"),
      "redrawn after each resize")
check("dashboard exit=0" in screen("quit") and "agvcal dashboard" not in screen("quit"),
      "q quits with exit 0 and the screen restored")
stty = open(os.path.join(tmp, "stty.txt")).read().split() if os.path.exists(os.path.join(tmp, "stty.txt")) else []
check("icanon" in stty and "echo" in stty, "terminal modes restored (icanon, echo)")
check(open(os.path.join(tmp, "alternate_on.txt")).read().strip() == "0", "alternate screen left")
check("dashboard exit=0" in screen("ctrlc"), "Ctrl-C quits with exit 0")
sys.exit(1 if fails else 0)
PY
[ $? -eq 0 ] && pass "screen contents" || fail "screen contents (captures: see above)"
for f in overview residuals parameters bus_live; do echo "--- $f"; cat "$TMP/$f.txt"; done

for _ in 1 2 3 4 5; do  # the tmux server exits shortly after kill-server
  left=$(test_pgrep "$BUILD/agvcal-(dashboard|scanmatch|solver|commander)|tmux -S $TMP")  # the player is waited for
  [ -z "$left" ] && break; sleep 0.5
done
if [ -z "$left" ]; then pass "no process left behind"; else fail "left behind: $(ps -o pid,args -p "${left//$'\n'/,}")"; fi
expect_status 0 "--help" "$BUILD/agvcal-dashboard" --help
expect_status 2 "unknown option" "$BUILD/agvcal-dashboard" --bogus
stderr_has "--bogus"
expect_status 2 "--stale-after 0" "$BUILD/agvcal-dashboard" --stale-after 0
stderr_has "--stale-after"
expect_status 2 "not a terminal" "$BUILD/agvcal-dashboard" --lcm-url memq://
stderr_has "not a terminal"
finish
