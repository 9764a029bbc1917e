#!/usr/bin/env bash
# Outputs lose nothing (docs/bad-input.md, "Outputs"; calib/io/atomic_file.h):
#  - an output that is an input (the recording, the robot file, a config; also through a hard or
#    a symbolic link), of every command and live process, is refused with exit 2 before any
#    work, one line naming both, and the input is left as it was;
#  - on a full disk (a small tmpfs, as root, in a private mount namespace) a failed solve
#    replaces neither the previous RESULT.json nor the previous report;
#  - a FIFO, a character device or a symbolic link given as an output stays what it is (a FIFO
#    and a device are written in place, a link's target is replaced);
#  - a user's OUT.partial and .agvcal-write-check beside an output stay, and a report folder
#    holding the user's own files is refused (exit 2) and left as it was.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log
sum() { sha256sum "$@" | cut -c1-64; }
temporary='[.]agvcal-[a-z0-9]{6}[.]partial$'  # agvcal's temporaries (calib/io/atomic_file.h)

# --- An output that is an input ---
cp "$log" "$TMP/run.log"
cp "$robot" "$TMP/robot.yaml"
cp config/recal.yaml "$TMP/recal.yaml"
ln "$TMP/run.log" "$TMP/hard.log"
ln -s run.log "$TMP/soft.log"
before=$(sum "$TMP/run.log" "$TMP/robot.yaml" "$TMP/recal.yaml")
refused() {  # refused DESCRIPTION NAMED_INPUT CMD...: exit 2, one line naming the output and the input
  local what=$1 input=$2; shift 2
  expect_status 2 "$what" "$@"
  if [ "$(wc -l <"$TMP/stderr")" -eq 1 ] && grep -q "is the input $input" "$TMP/stderr"; then
    pass "$what: one line naming both"; else fail "$what: $(head -c 300 "$TMP/stderr")"; fi
}
R=$TMP/robot.yaml L=$TMP/run.log
refused "solve --out LOG" "$L" "$AGVCAL" solve "$R" "$L" --quiet --out "$L"
refused "solve --out a hard link to LOG" "$L" "$AGVCAL" solve "$R" "$L" --quiet --out "$TMP/hard.log"
refused "solve --out a symbolic link to LOG" "$L" "$AGVCAL" solve "$R" "$L" --quiet --out "$TMP/soft.log"
refused "solve --write-robot ROBOT" "$R" "$AGVCAL" solve "$R" "$L" --quiet --write-robot "$R"
refused "diagnose --out LOG" "$L" "$AGVCAL" diagnose "$R" "$L" --quiet --out "$L"
refused "diagnose --write-sim ROBOT" "$R" "$AGVCAL" diagnose "$R" "$L" --quiet --write-sim "$R"
refused "ground --out LOG" "$L" "$AGVCAL" ground "$R" "$L" --quiet --out "$L"
refused "ground --write-robot ROBOT" "$R" "$AGVCAL" ground "$R" "$L" --quiet --write-robot "$R"
refused "recal --out-robot ROBOT" "$R" "$AGVCAL" recal "$R" "$L" --config "$TMP/recal.yaml" --out-robot "$R"
refused "recal --decisions CONFIG" "$TMP/recal.yaml" "$AGVCAL" recal "$R" "$L" --config "$TMP/recal.yaml" --decisions "$TMP/recal.yaml"
refused "fuse --out LOG" "$L" "$AGVCAL" fuse "$R" "$L" --out "$L"
refused "import OUT.log = INPUT" "$L" "$AGVCAL" import carmen "$L" "$TMP/hard.log" --quiet
cp config/sims/forklift.yaml "$TMP/sim.yaml"
sed -i "s|^robot: .*|robot: $TMP/robot.yaml|" "$TMP/sim.yaml"
refused "simulate OUT.log = the sim's robot file" "$R" "$AGVCAL" simulate "$TMP/sim.yaml" "$R" --quiet
refused "agvcal-solver --out LOG of --catch-up" "$L" timeout 60 "$BUILD/agvcal-solver" "$R" --catch-up "$L" --out "$L"
refused "agvcal-ground --out ROBOT" "$R" timeout 60 "$BUILD/agvcal-ground" "$R" --out "$R"
refused "agvcal-recal --out-robot ROBOT" "$R" timeout 60 "$BUILD/agvcal-recal" "$R" --config "$TMP/recal.yaml" --out-robot "$R"
expect_status 2 "solve: two outputs into one file" "$AGVCAL" solve "$R" "$L" --quiet --out "$TMP/same" --write-robot "$TMP/same"
stderr_has "is also the output of --out"
[ "$(sum "$TMP/run.log" "$TMP/robot.yaml" "$TMP/recal.yaml")" = "$before" ] && pass "every input as it was" ||
  fail "an input was changed"
[ -L "$TMP/soft.log" ] && pass "the link is still a link" || fail "the link was replaced"

# --- A full disk: nothing previous is replaced ---
if [ "$(id -u)" -eq 0 ] && unshare -m true 2>/dev/null; then
  mkdir "$TMP/disk"
  AGVCAL=$AGVCAL D=$TMP/disk T=$TMP robot=$robot log=$log unshare -m bash -s >"$TMP/disk.out" 2>&1 <<'SH'
set -u
mount -t tmpfs -o size=4m tmpfs "$D" || exit 9
"$AGVCAL" solve "$robot" "$log" --quiet --out "$D/RESULT.json" --report "$D/report" >/dev/null || exit 10
(cd "$D" && find . -type f | sort | xargs sha256sum) >"$T/disk.before"
# Fill the disk, then leave a few kB: room for RESULT.json's temporary, not for the report.
dd if=/dev/zero of="$D/fill" bs=64k 2>/dev/null
truncate -s -8k "$D/fill"
"$AGVCAL" solve "$robot" "$log" --quiet --fit-fraction 0.5 --out "$D/RESULT.json" --report "$D/report" >/dev/null 2>"$T/disk.stderr"
echo "status $?"
rm -f "$D/fill"
(cd "$D" && find . | sort) >"$T/disk.entries"
(cd "$D" && find . -type f | sort | xargs sha256sum) >"$T/disk.after"
"$AGVCAL" solve "$robot" "$log" --quiet --fit-fraction 0.5 --out "$D/RESULT.json" --report "$D/report" >/dev/null
echo "again $?"
[ -s "$D/report/heldout_windows.svg" ] && echo "new report"
umount "$D"
SH
  grep -q "^status 2$" "$TMP/disk.out" && pass "full disk: exit 2" || fail "full disk: $(cat "$TMP/disk.out" "$TMP/disk.stderr" 2>/dev/null | head -c 400)"
  grep -q "cannot write" "$TMP/disk.stderr" 2>/dev/null && pass "full disk: says it cannot write" ||
    fail "full disk message: $(head -c 300 "$TMP/disk.stderr" 2>/dev/null)"
  if diff "$TMP/disk.before" "$TMP/disk.after" >/dev/null 2>&1; then pass "full disk: previous RESULT.json and report kept, byte for byte"
  else fail "full disk: previous outputs changed: $(diff "$TMP/disk.before" "$TMP/disk.after" 2>&1 | head -8)"; fi
  if grep -qE "$temporary" "$TMP/disk.entries" 2>/dev/null; then fail "full disk: temporaries left: $(cat "$TMP/disk.entries")"
  else pass "full disk: no temporary left"; fi
  grep -q "^again 0$" "$TMP/disk.out" && grep -q "^new report$" "$TMP/disk.out" && pass "with room again: the new outputs replace the old" ||
    fail "with room again: $(cat "$TMP/disk.out")"
else
  echo "SKIP full-disk checks: not root or no mount namespaces"
fi

# --- A FIFO, a device, a symbolic link as outputs (the inputs from here on: the repository's) ---
mkfifo "$TMP/out.fifo"
timeout 120 cat "$TMP/out.fifo" >"$TMP/fifo.json" &
reader=$!
expect_status 0 "solve --out FIFO" timeout 120 "$AGVCAL" solve "$robot" "$log" --quiet --out "$TMP/out.fifo"
if [ -p "$TMP/out.fifo" ]; then pass "the FIFO is still a FIFO"; else fail "the FIFO was replaced by a $(stat -c %F "$TMP/out.fifo")"; kill "$reader" 2>/dev/null; fi
wait "$reader" 2>/dev/null
python3 -c 'import json,sys; json.load(open(sys.argv[1]))["params"]' "$TMP/fifo.json" 2>/dev/null &&
  pass "the reader got RESULT.json through the FIFO" || fail "FIFO reader got: $(head -c 200 "$TMP/fifo.json")"
if mknod "$TMP/null" c 1 3 2>/dev/null; then
  expect_status 0 "solve --out a null device, --write-robot too" "$AGVCAL" solve "$robot" "$log" --quiet --out "$TMP/null" --write-robot "$TMP/null"
  [ -c "$TMP/null" ] && pass "the device is still a device" || fail "the device was replaced by a $(stat -c %F "$TMP/null")"
fi
"$AGVCAL" solve "$robot" "$log" --out /dev/fd/1 >"$TMP/stdout.txt" 2>"$TMP/stderr"
grep -q "^tricycle drive" "$TMP/stdout.txt" && grep -q '"params"' "$TMP/stdout.txt" &&
  pass "--out /dev/fd/1: the result follows the summary on stdout" || fail "--out /dev/fd/1: $(head -c 300 "$TMP/stderr")"
mkdir "$TMP/real"
echo previous >"$TMP/real/RESULT.json"
ln -s real/RESULT.json "$TMP/link.json"
expect_status 0 "solve --out a symbolic link" "$AGVCAL" solve "$robot" "$log" --quiet --out "$TMP/link.json"
[ -L "$TMP/link.json" ] && pass "the link is still a link" || fail "the link was replaced by a $(stat -c %F "$TMP/link.json")"
grep -q '"params"' "$TMP/real/RESULT.json" && pass "the link's target holds the result" || fail "target: $(head -c 100 "$TMP/real/RESULT.json")"

# --- The user's files beside an output and in a report folder ---
mkdir "$TMP/user"
echo mine >"$TMP/user/RESULT.json.partial"
echo mine >"$TMP/user/.agvcal-write-check"
expect_status 0 "solve --out beside the user's .partial and .agvcal-write-check" \
  "$AGVCAL" solve "$robot" "$log" --quiet --out "$TMP/user/RESULT.json" --report "$TMP/user/report"
[ "$(cat "$TMP/user/RESULT.json.partial" "$TMP/user/.agvcal-write-check" 2>/dev/null)" = "$(printf 'mine\nmine')" ] &&
  pass "the user's OUT.partial and .agvcal-write-check are kept" || fail "the user's files: $(ls -a "$TMP/user")"
echo '<svg xmlns="http://www.w3.org/2000/svg"><circle r="1"/></svg>' >"$TMP/user/report/my_plot.svg"
report_before=$(cd "$TMP/user/report" && sha256sum ./*)
expect_status 2 "--report into an old report holding the user's plot" \
  "$AGVCAL" solve "$robot" "$log" --quiet --report "$TMP/user/report"
stderr_has "my_plot.svg"
[ "$(cd "$TMP/user/report" && sha256sum ./*)" = "$report_before" ] && pass "the report folder is left as it was" ||
  fail "the report folder changed: $(ls "$TMP/user/report")"
rm "$TMP/user/report/my_plot.svg"
expect_status 0 "--report into agvcal's own report" "$AGVCAL" solve "$robot" "$log" --quiet --fit-fraction 0.5 --report "$TMP/user/report"
[ -s "$TMP/user/report/heldout_windows.svg" ] && pass "the report was replaced" || fail "no new report: $(ls "$TMP/user/report")"
if ls -a "$TMP/user" | grep -qE "$temporary"; then fail "temporaries left: $(ls -a "$TMP/user")"; else pass "no temporary left"; fi
finish
