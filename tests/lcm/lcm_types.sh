#!/usr/bin/env bash
# LCM's other tools see our messages: every event of a bundled recording, and one message of
# every type of lcmtypes/ with every field set, decoded with the generated Java types the way
# lcm-spy finds them (its LCMTypeDatabase over the CLASSPATH) or with the generated Python
# types, prints the same text, field for field, as lcm-gen's C++ decoding.
#   lcm_types.sh BUILD_DIR SOURCE_DIR python
#   lcm_types.sh BUILD_DIR SOURCE_DIR java JAVA LCM_JAR
set -euo pipefail
build=$1 source=$2 language=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/tests/lcm_message_text" --write-every-type "$tmp/every_type.log"
for log in "$source/logs/forklift_demo.log" "$tmp/every_type.log"; do
  name=$(basename "$log" .log)
  "$build/tests/lcm_message_text" "$log" >"$tmp/$name.cpp.txt"
  case $language in
    java) CLASSPATH="$build/agvcal-lcmtypes.jar" "$4" -cp "$5:$build/tests/lcm-java" \
            LcmLogText "$log" >"$tmp/$name.other.txt" ;;
    python) python3 "$source/tests/lcm/lcm_log_text.py" "$build/lcmtypes-py" "$log" >"$tmp/$name.other.txt" ;;
    *) echo "lcm_types.sh: language java or python, not '$language'" >&2; exit 2 ;;
  esac
  if grep -E '^[^ ]+ (unknown|undecodable|short)$' "$tmp/$name.cpp.txt" "$tmp/$name.other.txt"; then
    echo "FAIL $name: messages of no known type (above)" >&2
    exit 1
  fi
  if ! cmp -s "$tmp/$name.cpp.txt" "$tmp/$name.other.txt"; then
    echo "FAIL $name: $language decodes differently from C++ (first differing lines, C++ then $language):" >&2
    diff "$tmp/$name.cpp.txt" "$tmp/$name.other.txt" | head -4 | cut -c1-400 >&2
    exit 1
  fi
  echo "$name: $(wc -l <"$tmp/$name.cpp.txt") events on channels" \
       "$(cut -d' ' -f1 "$tmp/$name.cpp.txt" | sort -u | tr '\n' ' ')decoded alike by C++ and $language"
done
types=$(cut -d' ' -f2 "$tmp/every_type.cpp.txt" | sort -u | wc -l)
expected=$(ls "$source"/lcmtypes/*.lcm | wc -l)
[ "$types" -eq "$expected" ] || { echo "FAIL: $types types in the sample log, lcmtypes/ has $expected" >&2; exit 1; }
