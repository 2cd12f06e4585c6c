#!/usr/bin/env bash
# Runs on a GPU machine from the repository root: unpacks .gpu/rc.tar.xz (scripts/gpu_pack.sh) and
# runs the GPU tests, the benchmark on both devices and GPU runs of shipped scenes with the exact
# check, each under a time limit, appending every step's whole output to $OUT/all.log (default
# /tmp/gpu_out), the runs' run.json files to $OUT/runs.tar.gz, and a summary to stdout. STEPS="tests bench ..." picks steps (default: all, in the order below).
# With .gpu/before.tar.xz (an earlier pack), step `ab` runs SCENES_AB with the earlier and the new
# command line in turn, twice, for a before/after on the same GPU.
set -u
cd "$(dirname "$0")/.."
out=${OUT:-/tmp/gpu_out}; mkdir -p "$out"
rc=/tmp/rc; rm -rf "$rc"; mkdir -p "$rc"; tar -xJf .gpu/rc.tar.xz -C "$rc" || exit 1
src=$(cat "$rc/source_dir")
[ -e "$src" ] || { mkdir -p "$(dirname "$src")" && ln -s "$PWD" "$src"; }
export LD_LIBRARY_PATH=$rc/lib
B=$rc/bin
if [ -f .gpu/before.tar.xz ]; then rm -rf /tmp/rc_before; mkdir -p /tmp/rc_before; tar -xJf .gpu/before.tar.xz -C /tmp/rc_before; fi
logs=/tmp/gpu_logs; rm -rf "$logs"; mkdir -p "$logs"
steps=${STEPS:-"info tests seed_cuda bench walking_skirt garment implicit drape seed_cpu sanitize"}
step() {  # name limit command...
  local name=$1 limit=$2; shift 2
  local t0; t0=$(date +%s%N)
  timeout "$limit" "$@" >"$logs/$name.log" 2>&1
  local code=$?
  { echo "=== $name: exit $code, $(( ($(date +%s%N) - t0) / 1000000 )) ms: $*"; cat "$logs/$name.log"; } >>"$out/all.log"
  echo "=== $name: exit $code, $(( ($(date +%s%N) - t0) / 1000000 )) ms"
  grep -E "${PICK:-^}" "$logs/$name.log" | tail -n "${TAILN:-12}"
}
for s in $steps; do case $s in
  info) step info 30 nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv ;;
  tests) PICK='FAILED|PASSED|SKIPPED|Failure|error|Expected|Which|actual|  [0-9]' TAILN=40 \
         step tests 120 "$B/raycloth_tests" --gtest_filter='*Cuda*' ;;
  bench) step bench_cuda 60 "$B/raycloth" bench --device cuda --sizes 65,129,257,513
         step bench_cpu 45 "$B/raycloth" bench --device cpu --sizes 65,129,257 ;;
  seed_cuda) step seed_cuda 60 "$B/raycloth" run --device cuda -o /tmp/seed_cuda ;;
  seed_cpu) step seed_cpu 45 "$B/raycloth" run --device cpu -o /tmp/seed_cpu
            [ -d /tmp/seed_cuda ] && step seed_compare 60 python3 scripts/compare_runs.py /tmp/seed_cpu /tmp/seed_cuda ;;
  walking_skirt) step walking_skirt 60 "$B/raycloth" run scenes/walking_skirt.json --device cuda --duration 0.3 -o /tmp/skirt_cuda ;;
  garment) step garment 60 "$B/raycloth" run scenes/garment_on_man.json --device cuda --duration 0.2 -o /tmp/garment_cuda ;;
  implicit) step implicit_cuda 60 "$B/raycloth" run bench/walking_skirt_implicit.json --device cuda --duration 0.3 -o /tmp/implicit_cuda
            step implicit_cpu 60 "$B/raycloth" run bench/walking_skirt_implicit.json --device cpu --duration 0.3 -o /tmp/implicit_cpu ;;
  drape) step drape_cuda 60 "$B/raycloth" run scenes/fabric/drape_denim.json --device cuda --duration 0.05 -o /tmp/drape_cuda ;;
  ab) for round in 1 2; do for scene in ${SCENES_AB:-bench/walking_skirt_implicit.json}; do
        name=$(basename "$scene" .json)
        PICK='steps/s|stages per step|exact check' step "before_${name}_$round" 90 /tmp/rc_before/bin/raycloth run "$scene" --device cuda --duration "${AB_DURATION:-0.3}" -o "/tmp/before_${name}_$round"
        PICK='steps/s|stages per step|exact check' step "after_${name}_$round" 90 "$B/raycloth" run "$scene" --device cuda --duration "${AB_DURATION:-0.3}" -o "/tmp/after_${name}_$round"
      done; done ;;
  targets) TAILN=20 step vs_bullet 200 "$B/raycloth_vs_bullet" --device cuda --also bench/peers_drape_implicit.json --no-blender \
              --json "$out/vs_bullet.json"
           for scene in scenes/walking_dress_gc.json scenes/garment_on_man.json scenes/walking_skirt.json bench/walking_skirt_implicit.json; do
             PICK='steps/s|stages per step|exact check' step "full_$(basename "$scene" .json)" 120 "$B/raycloth" run "$scene" --device cuda \
               -o "/tmp/full_$(basename "$scene" .json)"
           done ;;
  sweeps) for it in ${SWEEPS:-60 100}; do  # the peers' implicit drape with more sweeps (time.iterations)
            sed "s/\"iterations\": 30/\"iterations\": $it/" bench/peers_drape_implicit.json > "/tmp/peers_it$it.json"
            TAILN=8 step "vs_bullet_$it" 120 "$B/raycloth_vs_bullet" --device cuda --scene "/tmp/peers_it$it.json" --no-bullet-self \
              --no-blender --json "$out/vs_bullet_$it.json"
          done ;;
  garments) TAILN=30 step garments "${GARMENTS_LIMIT:-400}" "$B/raycloth" batch scenes/sweeps/garmentcode_all.json --out /tmp/garments \
              --jobs "${GARMENT_JOBS:-4}" --device cuda --table -q
            (cd /tmp/garments && tar -czf "$out/garments.tar.gz" results.* cases/*/run.json cases/*/*.log 2>/dev/null) ;;
  sanitize) TAILN=25 step sanitize 120 compute-sanitizer --tool memcheck --leak-check no \
            "$B/raycloth_tests" --gtest_filter='CudaParity.DefaultSceneMatchesCpuCloselyBeforeContact:CudaParity.MovingObstacleMatchesCpu:CudaParity.ImplicitStepMatchesCpuBeforeContact:CudaParity.MeasuredFabricMembranesAndHingesMatchCpu' ;;
esac; done
if ls /tmp/*/run.json >/dev/null 2>&1; then tar -czf "$out/runs.tar.gz" /tmp/*/run.json 2>/dev/null; fi
