#!/usr/bin/env bash
# The cleaning chain on dirty CAD-like buildings (issue #13):
#
#   ugbuilding --cad --faces N --storeys S --seed SEED
#     | ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean | ugcut
#
# and the user's pipeline `ugvlmerge | ugisect | ugcut -l 2`, stage by stage,
# with files in a temporary directory. Prints one Markdown table per size:
# per stage the faces in → out and the wall time in seconds (peak resident
# memory in MB with GNU time at /usr/bin/time); then the defects ugcheck
# finds after the chain (all categories, `--deny defects` passes when the
# total is 0) and after ugcut (with the faces that are not patches), and the
# growth of faces (chain output / input).
#
# Usage: benches/dirty.sh [FACES...]     (default: 8600 100000)
# Environment: SEED (default 1), STOREYS (default 2 under 20000 faces, else
# 3), OBLIQUE=1 (with an oblique wing and a pitched roof: ugbuilding --wing
# --pitched), TRIANGLES=1 (the building exported as triangles: ugbuilding
# --triangles), STAIRS=1 (stairs and ramps: ugbuilding --stairs), CURVED=1 (round
# columns, globe lamps and pipes: ugbuilding --curved), ROUND=K (every
# coordinate rounded to K decimals, as an export with a fixed precision
# writes it: 3 is whole millimetres; the tools then take 2.1 times that
# precision as their epsilon), LEN (ugcut -l; default ugcut's, 2% of the diagonal), KEEP=1 keeps the
# directory of models, NO_BUILD=1 uses target/release as it is.

set -euo pipefail

cd "$(dirname "$0")/.."
SEED=${SEED:-1}
if [ $# -gt 0 ]; then sizes=("$@"); else sizes=(8600 100000); fi

if [ "${NO_BUILD:-0}" != 1 ]; then
    echo "building release binaries…" >&2
    cargo build --release --quiet
fi
bin=target/release

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugdirty.XXXXXX")
if [ "${KEEP:-0}" = 1 ]; then
    echo "models kept in $tmp" >&2
else
    trap 'rm -rf "$tmp"' EXIT
fi

gnu_time=
if [ -x /usr/bin/time ] && /usr/bin/time -v true 2>/dev/null; then gnu_time=1; fi

faces() { grep -c '^f ' "$1" || true; }

# stage NAME IN OUT CMD… : runs CMD < IN > OUT, prints a table row.
stage() {
    local name=$1 in=$2 out=$3 t0 t1 peak="–"
    shift 3
    t0=$(date +%s%N)
    if [ -n "$gnu_time" ]; then
        /usr/bin/time -v -o "$tmp/time" "$@" -q < "$in" > "$out"
        peak=$(awk '/Maximum resident/ {printf "%.0f", $NF / 1024}' "$tmp/time")
    else
        "$@" -q < "$in" > "$out"
    fi
    t1=$(date +%s%N)
    printf '| %s | %s → %s | %s | %s |\n' "$name" "$(faces "$in")" "$(faces "$out")" \
        "$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.2f", (b - a) / 1e9}')" "$peak"
}

defects() {
    "$bin/ugcheck" --json "$1" | python3 -c '
import json, sys
r = json.load(sys.stdin)
keys = ["nonplanar", "tvertices", "intersecting", "overlapping", "coincident", "degenerate", "inconsistent"]
parts = ["%s %d" % (k, len(r[k])) for k in keys]
if sys.argv[1] == "cut":
    parts.append("not patches %d" % len(r["nonpatch"]))
print("%d (%s)" % (sum(len(r[k]) for k in keys), ", ".join(parts)))
' "$2"
}

for n in "${sizes[@]}"; do
    storeys=${STOREYS:-$([ "$n" -lt 20000 ] && echo 2 || echo 3)}
    d="$tmp/$n"
    mkdir -p "$d"
    "$bin/ugbuilding" --cad --faces "$n" --storeys "$storeys" --seed "$SEED" ${TRIANGLES:+--triangles} ${OBLIQUE:+--wing --pitched} ${STAIRS:+--stairs} ${CURVED:+--curved} -o "$d/0.ug"
    if [ -n "${ROUND:-}" ]; then
        python3 -c '
import re, sys
k = int(sys.argv[1])
def r(m):
    xs = " ".join(repr(round(float(x), k) + 0.0) for x in m.group(2).split())
    return "v %s %s;" % (m.group(1), xs)
sys.stdout.write(re.sub(r"^v (\S+) ([^;]*);", r, sys.stdin.read(), flags=re.M))
' "$ROUND" < "$d/0.ug" > "$d/rounded.ug"
        mv "$d/rounded.ug" "$d/0.ug"
    fi
    echo
    echo "### ugbuilding --cad --faces $n --storeys $storeys --seed $SEED${TRIANGLES:+ --triangles}${OBLIQUE:+ --wing --pitched}${STAIRS:+ --stairs}${CURVED:+ --curved}${ROUND:+, rounded to $ROUND decimals}: $(faces "$d/0.ug") faces"
    echo
    echo "| stage | faces in → out | s | peak MB |"
    echo "|---|---:|---:|---:|"
    prev="$d/0.ug"
    k=1
    for s in ugplanar ugvlmerge ugflip ugisect ugcopl ugclean; do
        stage "$s" "$prev" "$d/$k.ug" "$bin/$s"
        prev="$d/$k.ug"
        k=$((k + 1))
    done
    stage ugcut "$prev" "$d/cut.ug" "$bin/ugcut" ${LEN:+-l "$LEN"}
    stage "user's: ugvlmerge" "$d/0.ug" "$d/u1.ug" "$bin/ugvlmerge"
    stage "user's: ugisect" "$d/u1.ug" "$d/u2.ug" "$bin/ugisect"
    stage "user's: ugcut -l 2" "$d/u2.ug" "$d/u3.ug" "$bin/ugcut" -l 2
    echo
    echo "- faces after the chain: $(faces "$prev") ($(awk -v a="$(faces "$d/0.ug")" -v b="$(faces "$prev")" 'BEGIN {printf "%.2f", b / a}')× the input)"
    echo "- defects after the chain: $(defects "$prev" chain)"
    echo "- defects after ugcut: $(defects "$d/cut.ug" cut)"
    echo "- user's pipeline after ugcut -l 2: $(defects "$d/u3.ug" cut)"
done
