#!/usr/bin/env bash
# The drape image of docs/materials.md: runs the Cusick drape test (raycloth fabric-test drape) on each of
# the ten measured fabrics, renders the draped specimen on its disk from the same camera (looking down at
# about 45 degrees) and tiles the ten images 5 x 2 into OUT.png. Prints the drape coefficients as a table.
# Usage: scripts/fabric_drape_grid.sh OUT.png [SETTLE_SECONDS]   (RAYCLOTH=path/to/raycloth to pick the binary)
set -euo pipefail
out=$1; settle=${2:-}; bin=${RAYCLOTH:-$(dirname "$0")/../build/raycloth}
fabrics="ivory_rib_knit pink_ribbon_brown white_dots_on_blk navy_sparkle_sweat camel_ponte_roma
gray_interlock denim_11oz white_swim_solid tango_red_jet_set royal_target"
work=$(mktemp -d); tiles=$work/tiles; mkdir -p "$tiles"; trap 'rm -rf "$work"' EXIT
echo "| fabric | drape coefficient | folds |"; echo "|---|---|---|"
i=0
for f in $fabrics; do
  d=$work/$f; t=$work/one_$f
  "$bin" fabric-test drape --fabric "$f" --out "$d" --scene "$d/scene" --quiet ${settle:+--settle "$settle"} >/dev/null
  # A valid one-frame run folder of the test's scene (a 10 ms run), whose cloth is then replaced by the drape.
  "$bin" run "$d/scene/scene.json" --duration 0.01 --quiet --out "$d/run" >/dev/null 2>&1
  mkdir -p "$t/frames"
  python3 - "$d" "$t" <<'EOF'
import json, sys
d, t = sys.argv[1:3]
j = json.load(open(d + '/run/run.json'))
f = j['frames'][-1]; f['index'] = 0; j['frames'] = [f]
json.dump(j, open(t + '/run.json', 'w'))
nv = lambda p: sum(1 for l in open(p) if l.startswith('v '))
last = '%s/run/frames/cloth_%04d.obj' % (d, max(int(x['index']) for x in json.load(open(d + '/run/run.json'))['frames']))
if nv(last) != nv(d + '/drape.obj'):
    sys.exit('drape.obj and the scene specimen differ in vertex count')
EOF
  cp "$d/drape.obj" "$t/frames/cloth_0000.obj"; cp "$d/run/obstacles.obj" "$t/"
  "$bin" render "$t" --quiet --threads 2 --resolution 256x256 --samples 2 \
    --camera-pos 0.2,0.8,0.32 --camera-target 0,0.44,0 >/dev/null 2>&1
  read -r dc folds < <(python3 -c "
import json;r=json.load(open('$d/result.json'));print('%.1f' % (100*r['drape_coefficient']), '%g' % r['folds'])")
  echo "| $f | $dc % | $folds |"
  label="$f  DC $dc%"
  tile=$(printf '%s/%02d.png' "$tiles" $i); i=$((i + 1))
  ffmpeg -loglevel error -y -i "$t/images/frame_0000.png" \
    -vf "drawtext=text='$label':x=6:y=6:fontsize=13:fontcolor=black:expansion=none" "$tile" 2>/dev/null \
    || cp "$t/images/frame_0000.png" "$tile"
done
ffmpeg -loglevel error -y -pattern_type glob -i "$tiles/*.png" -vf tile=5x2 -frames:v 1 "$out" && echo "grid ok: $out" >&2
