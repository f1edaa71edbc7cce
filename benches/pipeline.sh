#!/usr/bin/env bash
# The whole pipeline on generated buildings of growing size (DESIGN.md §8):
#
#   ugbuilding --faces N --messy | ugplanar | ugflip | ugvlmerge | ugcut -l LEN | ugrad --max-shots SHOTS
#
# stage by stage, with files in a temporary directory, printing a Markdown
# table: input faces, faces after ugvlmerge, patches, leaf elements after the
# solution, and per stage the wall time and peak memory (peak memory only
# with GNU time at /usr/bin/time; otherwise times from bash's `time`).
#
# Usage: benches/pipeline.sh [FACES...]          (default: 1000 10000 100000)
#
# 100000 (or any size after the first two) runs only when ten times the
# previous size's chain took under 5 minutes (BIG=1 runs it anyway).
# Environment: LEN (ugcut -l, metres; default 1), SHOTS (ugrad --max-shots;
# default 100), SEED (default 1), KEEP=1 keeps the directory of models.
#
# The models come from crates/building with Dirt::messy(): 30% flipped faces,
# 10% non-planar floor quads, half the walls with T-vertices and nearly
# coincident vertices, a ceiling light and two furniture boxes per room.

set -euo pipefail

cd "$(dirname "$0")/.."
LEN=${LEN:-1}
SHOTS=${SHOTS:-100}
SEED=${SEED:-1}
if [ $# -gt 0 ]; then sizes=("$@"); else sizes=(1000 10000 100000); fi

echo "building release binaries…" >&2
cargo build --release --quiet
bin=target/release

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugpipeline.XXXXXX")
if [ "${KEEP:-0}" = 1 ]; then
    echo "models kept in $tmp" >&2
else
    trap 'rm -rf "$tmp"' EXIT
fi

gnu_time=
if [ -x /usr/bin/time ] && /usr/bin/time -v true 2>/dev/null; then gnu_time=1; fi

# run NAME OUT_STDERR CMD… : runs CMD, sets $secs and $peak (MB, or "–").
run() {
    local name=$1 err=$2
    shift 2
    if [ -n "$gnu_time" ]; then
        /usr/bin/time -v -o "$tmp/time.$name" "$@" 2>"$err"
        local wall kb
        wall=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$tmp/time.$name")
        kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$tmp/time.$name")
        secs=$(awk -v t="$wall" 'BEGIN { n = split(t, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; printf "%.2f", s }')
        peak=$(awk -v k="$kb" 'BEGIN { printf "%.0f", k / 1024 }')
    else
        local TIMEFORMAT=%R t
        t=$({ time "$@" 2>"$err"; } 2>&1)
        secs=$(printf "%.2f" "$t")
        peak="–"
    fi
}

faces() { grep -c '^f ' "$1" || true; }

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(free -h | awk '/^Mem:/ { print $2 }') memory" >&2
echo "chain: ugbuilding --faces N --messy --seed $SEED | ugplanar | ugflip | ugvlmerge | ugcut -l $LEN | ugrad --max-shots $SHOTS" >&2
if [ -n "$gnu_time" ]; then unit="s / peak MB"; else unit="s"; fi

echo
echo "| input faces | faces after ugvlmerge | patches | elements | ugbuilding ($unit) | ugplanar | ugflip | ugvlmerge | ugcut | ugrad | chain (s) |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"

prev_chain=
k=0
for n in "${sizes[@]}"; do
    k=$((k + 1))
    if [ "$k" -gt 2 ] && [ "${BIG:-0}" != 1 ] && [ -n "$prev_chain" ]; then
        if awk -v c="$prev_chain" 'BEGIN { exit !(10 * c >= 300) }'; then
            echo "($n faces skipped: ten times the previous chain, $prev_chain s, is over 5 minutes; BIG=1 runs it)"
            continue
        fi
    fi
    d="$tmp/$n"
    mkdir -p "$d"
    cells=()
    run ugbuilding "$d/0.err" "$bin/ugbuilding" --faces "$n" --messy --seed "$SEED" -o "$d/0.ug"
    cells+=("$secs${gnu_time:+ / $peak}")
    chain=0
    i=0
    for stage in ugplanar ugflip ugvlmerge "ugcut -l $LEN" "ugrad -v --max-shots $SHOTS"; do
        read -r -a cmd <<<"$stage"
        name=${cmd[0]}
        run "$name" "$d/$((i + 1)).err" "$bin/$name" "${cmd[@]:1}" -o "$d/$((i + 1)).ug" "$d/$i.ug"
        cells+=("$secs${gnu_time:+ / $peak}")
        chain=$(awk -v a="$chain" -v b="$secs" 'BEGIN { printf "%.2f", a + b }')
        i=$((i + 1))
    done
    input=$(faces "$d/0.ug")
    merged=$(faces "$d/3.ug")
    patches=$(faces "$d/4.ug")
    elements=$(sed -n 's/.*; \([0-9]*\) leaf elements.*/\1/p' "$d/5.err" | tail -1)
    echo "| $input | $merged | $patches | ${elements:-?} | ${cells[0]} | ${cells[1]} | ${cells[2]} | ${cells[3]} | ${cells[4]} | ${cells[5]} | $chain |"
    prev_chain=$chain
    if [ "${KEEP:-0}" != 1 ]; then rm -f "$d"/[0-4].ug; fi
done
