#!/usr/bin/env bash
# The grid image of docs/garments.md: renders the last frame of every case of a sweep folder and tiles them 5 x 4.
set -euo pipefail
root=$1; out=$2; bin=${RAYCLOTH:-$(dirname "$0")/../build/raycloth}
work=$(mktemp -d); tiles=$work/tiles; mkdir -p "$tiles"; trap 'rm -rf "$work"' EXIT
for c in $(ls "$root/cases" | sort); do
  [ -f "$root/cases/$c/run.json" ] && [ -d "$root/cases/$c/frames" ] || continue
  d=$root/cases/$c; t="$work/one_$c"; rm -rf $t; mkdir -p $t/frames
  last=$(python3 -c "
import json;j=json.load(open('$d/run.json'));f=j['frames'][-1];j['frames']=[f];json.dump(j,open('$t/run.json','w'));print('%04d'%f['index'])")
  cp $d/frames/cloth_$last.obj $t/frames/; cp $d/frames/obstacles_$last.obj $t/frames/ 2>/dev/null || true; cp $d/obstacles.obj $t/
  "$bin" render $t --quiet --threads 2 --resolution 256x320 --samples 2 --camera-pos 2.3,1.25,1.3 --camera-target 0,0.95,0 >/dev/null 2>&1
  cp $t/images/frame_$last.png "$tiles"/$c.png
done
ffmpeg -loglevel error -y -pattern_type glob -i "$tiles/*.png" -vf tile=5x4 -frames:v 1 $out && echo grid ok
