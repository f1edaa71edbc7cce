#!/usr/bin/env bash
# Peak memory of ugrad per leaf element, on a generated building:
#
#   ugbuilding --rooms ROOMS --messy --seed SEED
#     | ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean | ugcut -l LEN
#   ugrad -v --visibility ray --max-shots SHOTS     (under /usr/bin/time -v)
#
# and prints the peak resident memory (GNU time's "Maximum resident set
# size"), ugrad's resident memory right after reading its input (its -v
# "memory:" line, from /proc/self/status), the leaf elements and vertices,
# and bytes per leaf element counted two ways:
#
#   over the input = (peak RSS − RSS after reading the input) / leaf elements
#   in all         = peak RSS / leaf elements
#
# Usage: benches/ugrad-memory.sh
# Environment: ROOMS (rooms per side; default 6), LEN (ugcut -l, metres;
# default 0.375), SHOTS (default 400), SEED (default 1), KEEP=1 keeps the
# directory of models, UGRAD=path runs another ugrad binary (e.g. an older
# build, to compare). Release build, into $CARGO_TARGET_DIR (default target).

set -euo pipefail

cd "$(dirname "$0")/.."
ROOMS=${ROOMS:-6}
LEN=${LEN:-0.375}
SHOTS=${SHOTS:-400}
SEED=${SEED:-1}

if ! { [ -x /usr/bin/time ] && /usr/bin/time -v true >/dev/null 2>&1; }; then
    echo "GNU time is missing: installing it (apt-get install time)…" >&2
    apt-get install -y -qq time >/dev/null
fi

echo "building release binaries…" >&2
cargo build --release --quiet -p ugbuilding -p ugplanar -p ugvlmerge -p ugflip \
    -p ugisect -p ugcopl -p ugclean -p ugcut -p ugrad
bin=${CARGO_TARGET_DIR:-target}/release
ugrad=${UGRAD:-$bin/ugrad}

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugradmem.XXXXXX")
if [ "${KEEP:-0}" = 1 ]; then
    echo "models kept in $tmp" >&2
else
    trap 'rm -rf "$tmp"' EXIT
fi

"$bin/ugbuilding" --rooms "$ROOMS" --messy --seed "$SEED" -o "$tmp/building.ug"
"$bin/ugplanar" -q "$tmp/building.ug" | "$bin/ugvlmerge" -q | "$bin/ugflip" -q | "$bin/ugisect" -q \
    | "$bin/ugcopl" -q | "$bin/ugclean" -q | "$bin/ugcut" -q -l "$LEN" -o "$tmp/patches.ug"
patches=$(grep -c '^f' "$tmp/patches.ug" || true)

/usr/bin/time -v -o "$tmp/time" "$ugrad" -v --visibility ray --max-shots "$SHOTS" "$tmp/patches.ug" -o "$tmp/lit.ug" 2>"$tmp/ugrad.err"

kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$tmp/time")
wall=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$tmp/time")
stats=$(grep '^stopped' "$tmp/ugrad.err" | tail -1)
leaves=$(sed -n 's/.*; \([0-9]*\) leaf elements.*/\1/p' <<<"$stats")
verts=$(sed -n 's/.* leaf elements, \([0-9]*\) vertices.*/\1/p' <<<"$stats")
input_mb=$(sed -n 's/^memory: .*, \([0-9.]*\) MB after reading the input.*/\1/p' "$tmp/ugrad.err")

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(free -h | awk '/^Mem:/ { print $2 }') memory"
echo "model: ugbuilding --rooms $ROOMS --messy --seed $SEED | ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean | ugcut -l $LEN: $patches patches"
echo "run: ugrad -v --visibility ray --max-shots $SHOTS ($wall wall)"
echo "$stats"
awk -v kb="$kb" -v in_mb="${input_mb:-}" -v n="$leaves" -v nv="$verts" 'BEGIN {
    peak = kb * 1024
    printf "peak RSS %.1f MB; %d leaf elements, %d vertices\n", peak / 1048576, n, nv
    if (in_mb != "") {
        base = in_mb * 1048576
        printf "RSS after reading the input %.1f MB\n", in_mb
        printf "bytes per leaf element: %.0f over the input ((peak − input) / leaves), %.0f in all (peak / leaves)\n", (peak - base) / n, peak / n
    } else {
        printf "bytes per leaf element: %.0f in all (peak / leaves); this ugrad does not report its RSS after reading the input\n", peak / n
    }
}'
