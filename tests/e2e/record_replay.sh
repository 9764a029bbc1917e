#!/usr/bin/env bash
# Offline recordings are deterministic, and a replay through lcm-logplayer
# into the group reaches its logger whole: every message of the original, on
# every channel, byte for byte, up to the last (the group drains its logger
# before it stops it). In a private network namespace.
source "$(dirname "$0")/lib.bash" "$@"
sim=config/sims/forklift.yaml
"$AGVCAL" simulate "$sim" "$TMP/a.log" --trajectory demo --quiet
"$AGVCAL" simulate "$sim" "$TMP/b.log" --trajectory demo --quiet
"$AGVCAL" simulate "$sim" "$TMP/c.log" --trajectory demo --quiet --seed 2
if cmp -s "$TMP/a.log" "$TMP/b.log"; then pass "same seed, identical bytes"; else fail "same seed gave different bytes"; fi
if cmp -s "$TMP/a.log" "$TMP/c.log"; then fail "another seed gave identical bytes"; else pass "another seed, different bytes"; fi
expect_status 0 "recording decodes with the spec types" "$AGVCAL" info "$TMP/a.log"

# Replay into the group's logger: every message arrives, byte for byte, per channel
# (the recording has the group's HEARTBEAT marks besides).
expect_status 0 "replay through the group" timeout 120 scripts/netns-run \
  scripts/agvcal-group --replay "$TMP/a.log" --speed 4 --log "$TMP/replayed.log"
if "$CHECK" same "$TMP/a.log" "$TMP/replayed.log"; then pass "replayed recording identical"; else fail "replayed recording differs"; fi
stderr_has "agvcal-group: the recording holds $(( $("$BUILD/agvcal-recording" count "$TMP/a.log" | grep -o '^[0-9]*') + $(recorded HEARTBEAT "$TMP/replayed.log") )) messages"
no_orphans
finish
