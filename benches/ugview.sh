#!/usr/bin/env bash
# ugview on a big model: a generated building cut into about 500,000 quads
# (about 1,000,000 triangles), rendered at 1920×1080 with 4× MSAA.
#
# Usage: benches/ugview.sh            Environment: ROOMS (default 64), LEN (ugcut -l, default 0.12)
# Prints ugview's -v timings (read, scene, device, render + tone map, PNG)
# and the wall time and peak memory of the whole run.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOMS=${ROOMS:-64}
LEN=${LEN:-0.12}
cargo build --release --quiet -p ugbuilding -p ugcut -p ugview -p ugcheck
bin=target/release
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugview-bench.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
"$bin/ugbuilding" --rooms "$ROOMS" --seed 1 | "$bin/ugcut" -l "$LEN" > "$tmp/big.ug"
"$bin/ugcheck" "$tmp/big.ug" | grep '^counts' >&2
echo "faces (patches, quads and triangles): $(grep -c '^f ' "$tmp/big.ug")" >&2
if [ -x /usr/bin/time ]; then
  /usr/bin/time -f "ugview: %e s wall, %M KB peak" "$bin/ugview" -v "$tmp/big.ug" --size 1920x1080 -o "$tmp/big.png"
else
  time "$bin/ugview" -v "$tmp/big.ug" --size 1920x1080 -o "$tmp/big.png"
fi
