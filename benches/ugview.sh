#!/usr/bin/env bash
# ugview on a big model: a generated building cut into about 500,000 quads
# (about 1,000,000 triangles), rendered at 1920×1080 with 4× MSAA.
#
# Usage: benches/ugview.sh   Environment: ROOMS (a ROOMS × ROOMS grid, default 8), LEN (ugcut -l, default 0.095)
# Prints ugview's -v timings (read, scene, device, render + tone map, PNG)
# and the wall time and peak memory of the whole run.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOMS=${ROOMS:-8}
LEN=${LEN:-0.095}
cargo build --release --quiet -p ugbuilding -p ugcut -p ugview
bin=target/release
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugview-bench.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
"$bin/ugbuilding" --rooms "$ROOMS" --seed 1 | "$bin/ugcut" -l "$LEN" > "$tmp/big.ug"
echo "patches: $(grep -c '^f ' "$tmp/big.ug") ($(wc -c < "$tmp/big.ug") bytes of UG)" >&2
if [ -x /usr/bin/time ]; then
  /usr/bin/time -f "ugview: %e s wall, %M KB peak" "$bin/ugview" -v "$tmp/big.ug" --size 1920x1080 -o "$tmp/big.png"
else
  time "$bin/ugview" -v "$tmp/big.ug" --size 1920x1080 -o "$tmp/big.png"
fi
