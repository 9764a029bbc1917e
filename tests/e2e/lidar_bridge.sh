#!/usr/bin/env bash
# The lidar bridge against the SICK CoLa-A emulator on loopback, in a private
# network namespace: the emulator serves the sample recording's scans with a
# device clock 100 ppm fast, starting near its 32-bit wrap, each telegram up
# to 5 ms late; agvcal-lidarbridge -> SCAN -> lcm-logger. Every scan arrives with
# the recording's geometry and ranges (0.5 mm quantum), and after 10 s of fit its
# stamp is within 0.3 ms of the recording's (plus one constant) while the
# arrival times spread by several ms. Bad input exits 2.
source "$(dirname "$0")/lib.bash" "$@"
log=logs/forklift_demo.log
config=config/bridges/sick_lms1xx.yaml

start_logger "$TMP/live.log" SCAN
"$BUILD/agvcal-sickemu" "$log" --port 2111 --jitter-ms 5 --drift-ppm 100 2> "$TMP/emu.err" & emu=$!
"$BUILD/agvcal-lidarbridge" "$config" --host 127.0.0.1 --port 2111 2> "$TMP/bridge.err" & bridge=$!
wait $emu; emu_status=$?
scans=$("$AGVCAL" info "$log" | awk '$1 == "SCAN" {print $3}')
wait_for 60 "the recording of the bridge's $scans scans (has $(recorded SCAN "$TMP/live.log"))" \
  at_least "$scans" recorded SCAN "$TMP/live.log"
stop $bridge agvcal-lidarbridge; status=$?
stop_logger "$TMP/live.log"
[ $((status + emu_status)) -eq 0 ] && pass "emulator -> agvcal-lidarbridge -> lcm-logger, bridge stopped with SIGINT (exit 0)" ||
  fail "emulator exit $emu_status, bridge exit $status: $(tail -c 300 "$TMP/emu.err") $(tail -c 300 "$TMP/bridge.err")"
if grep -q "agvcal-lidarbridge: stopped; 580 scans, 0 bad telegrams, 0 scans lost" "$TMP/bridge.err"; then
  pass "every scan decoded"
else
  fail "scans lost: $(tail -c 400 "$TMP/bridge.err")"
fi
if "$BUILD/tests/bridge_check" scans "$log" "$TMP/live.log" 10 300; then
  pass "recorded scans equal the recording's, stamps without the injected jitter"
else
  fail "recorded scans differ"
fi
left=$(test_pgrep "$BUILD/agvcal-(sickemu|lidarbridge)|lcm-logger -f $TMP")
if [ -z "$left" ]; then pass "no process left behind"; else fail "left behind: $left"; fi

# Bad input: config errors name file, line and key; options.
printf 'protocol: sick_cola_a\nrange_mx: 20\n' > "$TMP/typo.yaml"
expect_status 2 "config with a typo" "$BUILD/agvcal-lidarbridge" "$TMP/typo.yaml" --host 127.0.0.1
stderr_has "typo.yaml: line 2, key range_mx: unknown key (did you mean range_max?)"
expect_status 2 "no --host" "$BUILD/agvcal-lidarbridge" "$config"
stderr_has "--host"
expect_status 2 "missing config" "$BUILD/agvcal-lidarbridge" "$TMP/missing.yaml" --host 127.0.0.1
stderr_has "missing.yaml"
expect_status 2 "emulator without scans" "$BUILD/agvcal-sickemu" "$config"
expect_status 0 "--help" "$BUILD/agvcal-lidarbridge" --help
expect_status 0 "--help" "$BUILD/agvcal-sickemu" --help
finish
