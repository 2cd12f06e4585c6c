#!/usr/bin/env bash
# Same behaviour before and after a change that should not alter results (a restructuring):
#   scripts/same_behaviour.sh REF_CLI NEW_CLI [OUT_DIR] [DURATION]
# runs the built-in default scene with both command lines and compares every frame file byte for
# byte, then runs each shipped scene (scenes/*.json, and the implicit integrator's bench/*_implicit.json)
# for DURATION simulated seconds (default 0.1)
# with both and compares every frame file byte for byte and run.json's "check" section.
# Exits 1 on the first difference, naming the scene and the file. SCENES="a.json b.json" runs those
# scene files instead (for a reference that cannot read a field a scene has since gained).
set -euo pipefail
cd "$(dirname "$0")/.."
ref=${1:?reference raycloth binary}; new=${2:?new raycloth binary}
out=${3:-/tmp/same_behaviour}; dur=${4:-0.1}
rm -rf "$out"; mkdir -p "$out"

compare() {  # name dirA dirB
  local name=$1 a=$2 b=$3 f
  for f in "$a"/frames/*; do
    [ -e "$f" ] || continue
    cmp -s "$f" "$b/frames/$(basename "$f")" || { echo "DIFFERENT: $name frames/$(basename "$f")"; exit 1; }
  done
  python3 - "$a/run.json" "$b/run.json" "$name" <<'EOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
if a.get("check") != b.get("check"):
    print("DIFFERENT: %s run.json check" % sys.argv[3]); sys.exit(1)
EOF
  echo "same: $name ($(ls "$a"/frames | wc -l) frame files)"
}

"$ref" run --quiet --out "$out/default_ref" >/dev/null
"$new" run --quiet --out "$out/default_new" >/dev/null
compare default "$out/default_ref" "$out/default_new"

for scene in ${SCENES:-scenes/*.json bench/*_implicit.json}; do
  name=$(basename "$scene" .json)
  "$ref" run "$scene" --quiet --duration "$dur" --out "$out/${name}_ref" >/dev/null
  "$new" run "$scene" --quiet --duration "$dur" --out "$out/${name}_new" >/dev/null
  compare "$name" "$out/${name}_ref" "$out/${name}_new"
done
echo "all the same"
