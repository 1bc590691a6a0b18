#!/bin/bash
# The farm stage of CI (issue 27): the shipped job files on a real single-node Slurm and through
# `openjd run`, every output `cmp`-identical to a one-process render.
#
#   ci-farm.sh OBSCURA OPENJD
#
# 1. Slurm: examples/animated/boxes.gltf, 24 frames in 4 chunks (obscura submit --engine slurm). The
#    task of chunk 2 is sent SIGTERM mid-frame: that frame is left marked incomplete, the collect job
#    (afterany) names it and exits non-zero; the same submit again renders only what is missing and
#    the collect job passes. Then one RIB frame in 2×2 tiles, merged by the collect job.
# 2. OpenJD: the same 24 frames through `openjd run` of the shipped template; the chunks OpenJD hands
#    out (1-6, 7-12, 13-18, 19-24) and the openjd_progress lines it reads are checked.
# Needs slurm-wlm and munge (Debian) and an openjd-cli; runs as root (Slurm's daemons here run as root).
set -euo pipefail
obscura=$(realpath "${1:?the obscura binary}")
openjd=${2:?the openjd command}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
work=$(mktemp -d)
cluster="$work/cluster"
cleanup() {
  "$here/slurm-local.sh" stop "$cluster" || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "ci-farm: FAILED: $*" >&2; exit 1; }

boxes="$root/examples/animated/boxes.gltf"
classic="$root/examples/scenes/classic.rib"
# Small enough to be quick, large enough that one frame takes a moment (the kill lands mid-frame).
anim_args=(--format 160x90 --spp 16 --aov all)
rib_args=(--format 96x72 --spp 4 --aov all --camera-json)

t0=$(date +%s)
echo "-- one-process references"
mkdir -p "$work/ref/anim" "$work/ref/rib"
"$obscura" render "$boxes" -o "$work/ref/anim/b.####.exr" --frames 1-24 "${anim_args[@]}" --threads 2 -q
"$obscura" render "$classic" -o "$work/ref/rib/c.####.exr" --frames 1 "${rib_args[@]}" --threads 2 -q 2>/dev/null

same_as_reference() { # $1: reference dir, $2: farm output dir
  local n=0
  for f in "$1"/*; do
    cmp "$f" "$2/$(basename "$f")" || fail "$2/$(basename "$f") differs from the one-process render"
    n=$((n + 1))
  done
  [ "$n" -gt 0 ] || fail "no reference files in $1"
  echo "   $n files cmp-identical to the one-process render"
}

echo "-- Slurm: start a single node on loopback"
"$here/slurm-local.sh" start "$cluster"
export SLURM_CONF="$cluster/slurm.conf"

wait_job() { # $1: job id; waits until Slurm no longer lists it as pending or running
  for _ in $(seq 1200); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.1
  done
  fail "job $1 did not finish"
}
exit_code() { scontrol show job "$1" -o | grep -o ' ExitCode=[0-9]*' | cut -d= -f2; }

submit() { # prints the submit output; sets render_job and collect_job
  local out
  out=$("$obscura" submit --engine slurm "$@")
  echo "$out" | sed 's/^/   /'
  render_job=$(echo "$out" | sed -n 's/^render job \([0-9]*\).*/\1/p')
  collect_job=$(echo "$out" | sed -n 's/^collect job \([0-9]*\).*/\1/p')
  [ -n "$render_job" ] && [ -n "$collect_job" ] || fail "no job ids from obscura submit"
}

anim="$work/slurm/anim"
echo "-- Slurm: 24 frames in 4 chunks; the task of chunk 2 (frames 7-12) gets SIGTERM mid-frame"
submit "$boxes" -o "$anim/b.####.exr" --frames 1-24 --chunk 6 -- "${anim_args[@]}"
log="$anim/obscura-job/logs/render_${render_job}_1.log"
for _ in $(seq 600); do grep -q '^progress: frame' "$log" 2>/dev/null && break; sleep 0.05; done
grep -q '^progress: frame' "$log" || fail "task 1 never started a frame"
# scancel exits non-zero here although the signal is delivered (the effect is checked below).
scancel --batch --signal=TERM "${render_job}_1" || true
wait_job "$collect_job"
code=$(exit_code "$collect_job")
collect_log="$anim/obscura-job/logs/collect_${collect_job}.log"
sed 's/^/   collect: /' "$collect_log" | tail -4
[ "$code" != 0 ] || fail "the collect job passed with a killed chunk"
grep -q 'b.0007.camera.json: incomplete' "$collect_log" || fail "the collect job did not name frame 7 as incomplete"
grep -q 'frame(s) incomplete: 7' "$collect_log" || fail "the collect job did not list the missing frames"
grep -q '"complete": false' "$anim/b.0007.camera.json" || fail "frame 7 is not marked incomplete"
echo "-- Slurm: resubmitted; only the missing frames render"
submit "$boxes" -o "$anim/b.####.exr" --frames 1-24 --chunk 6 -- "${anim_args[@]}"
wait_job "$collect_job"
[ "$(exit_code "$collect_job")" = 0 ] || fail "the collect job failed after the resubmit: $(cat "$anim/obscura-job/logs/collect_${collect_job}.log")"
grep -q '24 frame(s) complete' "$anim/obscura-job/logs/collect_${collect_job}.log" || fail "collect did not report 24 frames"
grep -q '^frame 1: ' "$anim/obscura-job/logs/render_${render_job}_0.log" && fail "the resubmit rendered a complete frame again"
rm -rf "$anim/obscura-job"
same_as_reference "$work/ref/anim" "$anim"

echo "-- Slurm: one RIB frame in 2x2 tiles, merged by the collect job"
rib="$work/slurm/rib"
submit "$classic" -o "$rib/c.####.exr" --frames 1 --chunk 1 --tiles 2x2 -- "${rib_args[@]}"
wait_job "$collect_job"
[ "$(exit_code "$collect_job")" = 0 ] || fail "the tile collect job failed: $(cat "$rib/obscura-job/logs/collect_${collect_job}.log")"
rm -rf "$rib/obscura-job" "$rib"/*.tile*
same_as_reference "$work/ref/rib" "$rib"
"$here/slurm-local.sh" stop "$cluster"

echo "-- OpenJD: openjd run of the shipped template, 24 frames in chunks of 6"
oj="$work/openjd/anim"
"$obscura" submit --engine openjd --openjd "$openjd" "$boxes" -o "$oj/b.####.exr" --frames 1-24 --chunk 6 \
  -- "${anim_args[@]}" > "$work/openjd.log" 2>&1 || { cat "$work/openjd.log"; fail "openjd run failed"; }
chunks=$(grep -o 'Frame(CHUNK\[INT\]) = [0-9,:-]*' "$work/openjd.log" | sed 's/.* = //' | tr '\n' ' ')
[ "$chunks" = "1-6 7-12 13-18 19-24 " ] || fail "OpenJD handed out the chunks '$chunks'"
[ "$(grep -c 'openjd_progress: 100.0' "$work/openjd.log")" = 4 ] || fail "not one openjd_progress: 100.0 per chunk"
grep -q 'openjd_status: rendering frame 7 (1 of 6)' "$work/openjd.log" || fail "no openjd_status line"
grep -q '24 frame(s) complete' "$work/openjd.log" || fail "the Collect step did not run"
echo "   chunks: $chunks; $(grep -c 'openjd_progress:' "$work/openjd.log") openjd_progress lines"
rm -rf "$oj/obscura-job"
same_as_reference "$work/ref/anim" "$oj"

echo "-- OpenJD: the RIB frame in 2x2 tiles, the scene and output given as /farm/... paths mapped by path-mapping rules"
ojr="$work/openjd/rib"
mkdir -p "$ojr"
rules='{"version": "pathmapping-1.0", "path_mapping_rules": [
  {"source_path_format": "POSIX", "source_path": "/farm/examples", "destination_path": "'"$root/examples"'"},
  {"source_path_format": "POSIX", "source_path": "/farm/out", "destination_path": "'"$ojr"'"}]}'
"$openjd" run "$here/job.yaml" --step Collect --run-dependencies --path-mapping-rules "$rules" \
  -p "Obscura=$obscura" -p Scene=/farm/examples/scenes/classic.rib -p Output=/farm/out/c.####.exr \
  -p Frames=1 -p FramesPerTask=1 -p Tiles=2x2 -p TileIndices=0-3 -p "RenderArgs=${rib_args[*]}" \
  > "$work/openjd-rib.log" 2>&1 || { cat "$work/openjd-rib.log"; fail "openjd run of the tiles failed"; }
[ "$(grep -c 'Tile(INT) = ' "$work/openjd-rib.log")" = 4 ] || fail "OpenJD did not run 4 tile tasks"
rm -f "$ojr"/*.tile*
same_as_reference "$work/ref/rib" "$ojr"
t1=$(date +%s)
echo "ci-farm: passed in $((t1 - t0)) s"
