#!/usr/bin/env bash
# The measured fabrics' figures of docs/materials.md: for each of the ten, the pull along 0, 45 and 90
# degrees from the warp (grid, held across; and triangles at 1/6) and the cantilever cut along the
# warp and along the weft. Writes OUT/<fabric>_*.txt (default /tmp/measured_fabrics).
set -euo pipefail
out=${1:-/tmp/measured_fabrics}; bin=${RAYCLOTH:-$(dirname "$0")/../build/raycloth}
mkdir -p "$out"
for f in ivory_rib_knit pink_ribbon_brown white_dots_on_blk navy_sparkle_sweat camel_ponte_roma gray_interlock \
         denim_11oz white_swim_solid tango_red_jet_set royal_target; do
  "$bin" fabric-test tensile --fabric $f --settle 0.1 > "$out/${f}_grid.txt"
  "$bin" fabric-test tensile --fabric $f --settle 0.1 --triangles > "$out/${f}_triangles.txt"
  for w in 0 90; do "$bin" fabric-test cantilever --fabric $f --warp $w -q > "$out/${f}_cantilever_$w.txt" || true; done
  echo "$f done"
done
