#!/usr/bin/env bash
# ugrad against ugprobe, the independent path-traced estimate (issue #14):
# for each model (cleaned by the full chain) and each setting, `ugcut -l L |
# ugrad --converge C` and then `ugprobe --compare` at random interior
# points of the faces that do not emit (points no light reaches are left
# out: see ugprobe's README section). Prints a Markdown table: model,
# settings, rms, max, median and 90th percentile of the relative error in
# luminance, the points compared,
# the estimate's own standard error, and ugrad's wall time.
#
# Usage: benches/accuracy.sh [SETTING...]   a setting is LEN:CONVERGE[:TAIL]
#        (default: 3%:1e-3 2%:1e-3 1.5%:1e-4 2%:1e-3:0)
# Environment: POINTS (200), SAMPLES (paths per point, 16384), SEED (1),
# UGRAD_ARGS (more ugrad options, e.g. --uniform-shooters),
# MODELS (default "cornell room building"), NO_BUILD=1 uses target/release
# as it is, KEEP=1 keeps the directory.
#
# Models: cornell = fixtures/cornell-box.ug (the published geometry);
# room = `ugbuilding --rooms 1 --lights --furniture 3 --seed 1` (a furnished
# room with a ceiling light); building = `ugbuilding --rooms 3 --lights
# --furniture 2 --seed 1` (nine rooms joined by doorways).

set -euo pipefail

cd "$(dirname "$0")/.."
POINTS=${POINTS:-200}
SAMPLES=${SAMPLES:-16384}
SEED=${SEED:-1}
MODELS=${MODELS:-cornell room building}
if [ $# -gt 0 ]; then settings=("$@"); else settings=(3%:1e-3 2%:1e-3 1.5%:1e-4 2%:1e-3:0); fi

if [ "${NO_BUILD:-0}" != 1 ]; then
    echo "building release binaries…" >&2
    cargo build --release --quiet
fi
bin=target/release

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugaccuracy.XXXXXX")
if [ "${KEEP:-0}" = 1 ]; then
    echo "models kept in $tmp" >&2
else
    trap 'rm -rf "$tmp"' EXIT
fi

chain() {
    "$bin/ugplanar" -q | "$bin/ugvlmerge" -q | "$bin/ugflip" -q | "$bin/ugisect" -q \
        | "$bin/ugcopl" -q | "$bin/ugclean" -q
}

echo "| model | -l | --converge | --tail | rms | max | median | 90th pct | points | se | ugrad (s) |"
echo "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|"
for model in $MODELS; do
    case $model in
        cornell) chain < fixtures/cornell-box.ug > "$tmp/$model.ug" ;;
        room) "$bin/ugbuilding" --rooms 1 --lights --furniture 3 --seed 1 | chain > "$tmp/$model.ug" ;;
        building) "$bin/ugbuilding" --rooms 3 --lights --furniture 2 --seed 1 | chain > "$tmp/$model.ug" ;;
        *) echo "unknown model $model" >&2; exit 2 ;;
    esac
    for s in "${settings[@]}"; do
        IFS=: read -r len conv tail <<< "$s"
        tail=${tail:-default}
        "$bin/ugcut" -q -l "$len" "$tmp/$model.ug" > "$tmp/p.ug"
        targs=()
        [ "$tail" != default ] && targs=(--tail "$tail")
        # shellcheck disable=SC2206
        [ -n "${UGRAD_ARGS:-}" ] && targs+=(${UGRAD_ARGS})
        t0=$(date +%s%N)
        "$bin/ugrad" -q --converge "$conv" "${targs[@]}" "$tmp/p.ug" > "$tmp/lit.ug"
        t1=$(date +%s%N)
        "$bin/ugprobe" -q --compare "$tmp/lit.ug" "$tmp/$model.ug" --random "$POINTS" \
            --seed "$SEED" --samples "$SAMPLES" > "$tmp/cmp.txt"
        # "# |error|: median A%, 90th percentile B%, 99th percentile C%"
        read -r _ _ _ med _ _ p90 _ <<< "$(tail -2 "$tmp/cmp.txt" | head -1)"
        # "rms X% max Y% n N se Z%"
        read -r _ rms _ max _ n _ se <<< "$(tail -1 "$tmp/cmp.txt")"
        printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$model" "$len" "$conv" \
            "$tail" "$rms" "$max" "${med%,}" "${p90%,}" "$n" "$se" \
            "$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.1f", (b - a) / 1e9}')"
    done
done
