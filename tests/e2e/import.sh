#!/usr/bin/env bash
# agvcal import: a real CARMEN log becomes a recording that `agvcal info` reads
# (WHEELS and SCAN, one each per laser line), the import is deterministic, and
# bad input gets one line naming the file and line, exit 2, and no output file.
source "$(dirname "$0")/lib.bash" "$@"
DATA=${AGVCAL_DATA_DIR:-$SRC/../shared/data}
carmen=$DATA/mit-csail-carmen/mit-csail.clf.gz
robot=config/robots/datasets/mit_csail.yaml

if [ -f "$carmen" ]; then
  expect_status 0 "import carmen" "$AGVCAL" import carmen "$carmen" "$TMP/mit.log" --robot "$robot"
  stderr_has "WHEELS: 1988 messages"
  expect_status 0 "info on the import" "$AGVCAL" info "$TMP/mit.log"
  for channel in WHEELS SCAN; do
    if grep -Eq "^$channel +[a-z_]+ +1988 +424\.00" "$TMP/stdout"; then
      pass "info lists $channel: 1988 messages over 424 s"
    else
      fail "info lacks $channel 1988: $(cat "$TMP/stdout")"
    fi
  done
  if grep -q "out of order\|duplicated" "$TMP/stdout"; then fail "info reports problems"; else pass "no stamp problems"; fi
  "$AGVCAL" import carmen "$carmen" "$TMP/again.log" --robot "$robot" --quiet
  if cmp -s "$TMP/mit.log" "$TMP/again.log"; then pass "same input, identical bytes"; else fail "import not deterministic"; fi
else
  echo "SKIP real-data checks: no $carmen"
fi

# Bad input: a malformed line, a truncated .gz, an unknown format, a missing robot file.
printf 'ODOM 1 2 0 0 0 0 100.0 host 0.1\nODOM 1 2 zero 0 0 0 100.1 host 0.2\n' >"$TMP/bad.clf"
expect_status 2 "malformed line" "$AGVCAL" import carmen "$TMP/bad.clf" "$TMP/out.log" --robot "$robot"
stderr_has "bad.clf: line 2: field 4 (theta)"
for i in $(seq 1 400); do echo "ODOM $i 0 0 0 0 0 $i.5 host $i"; done | gzip -9 >"$TMP/full.clf.gz"
head -c $(($(stat -c %s "$TMP/full.clf.gz") - 20)) "$TMP/full.clf.gz" >"$TMP/cut.clf.gz"
expect_status 2 "truncated .gz" "$AGVCAL" import carmen "$TMP/cut.clf.gz" "$TMP/out.log" --robot "$robot"
stderr_has "cut.clf.gz: line"; stderr_has "truncated .gz"
expect_status 2 "unknown format" "$AGVCAL" import bagfile "$TMP/bad.clf" "$TMP/out.log"
stderr_has "unknown format 'bagfile'"
expect_status 2 "no robot file" "$AGVCAL" import mines "$TMP/bad.clf" "$TMP/out.log"
stderr_has "--robot config/robots/datasets/mines_rover.yaml"
expect_status 2 "robot of another drive type" "$AGVCAL" import carmen "$TMP/bad.clf" "$TMP/out.log" \
  --robot config/robots/forklift.yaml
stderr_has "forklift.yaml: drive"
if [ -e "$TMP/out.log" ] || compgen -G "$TMP/out.log*.partial" >/dev/null; then fail "an output file was left"; else pass "no output file written"; fi
expect_status 0 "agvcal import --help" "$AGVCAL" import --help
finish
