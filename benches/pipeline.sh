#!/usr/bin/env bash
# The whole recommended pipeline on generated buildings of growing size
# (DESIGN.md §8, issue #9):
#
#   ugbuilding --faces N --messy --seed SEED
#     | ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean
#     | ugcut -l LEN | ugrad -v --visibility ray --max-shots SHOTS --tail 0
#
# and, for sizes up to CONVERGE_MAX input faces (default 10000), ugrad once
# more from the same patches to convergence (1e-3 unshot energy, with the
# indirect tail: its defaults),
# stage by stage, with files in a temporary directory, printing two Markdown
# tables:
#
# 1. per size: input faces, faces after ugclean (the cleaned surfaces),
#    patches (faces after ugcut), leaf elements after the solution, and per
#    stage the wall time in seconds and the peak resident memory in MB
#    (`s / MB`; peak memory only with GNU time at /usr/bin/time, else "–");
#    ugrad's set-up (reading, meshing, BVH) and its milliseconds per shot
#    (solve time / shots, from the `time:` line of `ugrad -v`; shot by
#    shot, `--tail 0`, so that every size is measured on the same kind of
#    shot); the chain total (ugbuilding not included);
# 2. growth from each size to the next: for every stage, (time ratio) /
#    (input-face ratio): about 1 for linear growth, about the size ratio
#    (10 for 10× the faces) for quadratic growth. ms per shot is compared
#    with the ratio of leaf elements as well. Times under 0.05 s are too
#    short to compare and give "–";
# 3. ugrad to convergence: shots, when the indirect tail started, its
#    (patch, corner) pairs and iterations, the solve time, the whole run's
#    wall time and peak memory, and the leaf elements.
#
# Usage: benches/pipeline.sh [FACES...]          (default: 1000 10000 100000)
#
# Any size after the first two runs only when ten times the previous size's
# chain took under 5 minutes (BIG=1 runs it anyway).
# Environment: LEN (ugcut -l, metres; default 1), SHOTS (ugrad --max-shots;
# default 100), SEED (default 1), RAD_EPS (ugrad -e, model units; default
# ugrad's own, 1e-6 of the diagonal), KEEP=1 keeps the directory of models
# (and every stage's stderr, e.g. ugrad's per-shot lines in N/8.err).
# A stage that fails ends its size's row with "failed" (its stderr is shown)
# and the next size runs.
#
# The models come from crates/building with Dirt::messy(): 30% flipped faces,
# 10% non-planar floor quads, half the walls with T-vertices and nearly
# coincident vertices, a ceiling light and two furniture boxes per room.

set -euo pipefail

cd "$(dirname "$0")/.."
LEN=${LEN:-1}
SHOTS=${SHOTS:-100}
SEED=${SEED:-1}
RAD_EPS=${RAD_EPS:-}
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

now() { date +%s%N; }

# run NAME OUT_STDERR CMD… : runs CMD, sets $secs (wall, ms resolution),
# $peak (MB, or "–") and $ok (0 when CMD failed).
run() {
    local name=$1 err=$2 t0 t1
    shift 2
    ok=1
    t0=$(now)
    if [ -n "$gnu_time" ]; then
        /usr/bin/time -v -o "$tmp/time.$name" "$@" 2>"$err" || ok=0
    else
        "$@" 2>"$err" || ok=0
    fi
    t1=$(now)
    secs=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", (b - a) / 1e9 }')
    if [ -n "$gnu_time" ]; then
        local kb
        kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$tmp/time.$name")
        peak=$(awk -v k="$kb" 'BEGIN { printf "%.0f", k / 1024 }')
    else
        peak="–"
    fi
}

faces() { grep -c '^f ' "$1" || true; }
# Thousands separators: 1234567 → 1,234,567.
num() { printf "%s" "$1" | sed -e ':a' -e 's/\([0-9]\)\([0-9]\{3\}\)\($\|,\)/\1,\2\3/' -e 'ta'; }

stages=(ugplanar ugvlmerge ugflip ugisect ugcopl ugclean "ugcut -l $LEN" "ugrad -v --visibility ray --max-shots $SHOTS --tail 0${RAD_EPS:+ -e $RAD_EPS}")
names=(ugplanar ugvlmerge ugflip ugisect ugcopl ugclean ugcut ugrad)

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(free -h | awk '/^Mem:/ { print $2 }') memory, load average $(cut -d' ' -f1-3 /proc/loadavg)" >&2
echo "chain: ugbuilding --faces N --messy --seed $SEED | ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean | ugcut -l $LEN | ugrad -v --visibility ray --max-shots $SHOTS --tail 0${RAD_EPS:+ -e $RAD_EPS}" >&2
CONVERGE_MAX=${CONVERGE_MAX:-10000}
if [ -n "$gnu_time" ]; then unit="s / MB"; else unit="s"; fi

echo
header="| input faces | faces after ugclean | patches | leaf elements |"
rule="|---:|---:|---:|---:|"
for nm in "${names[@]}"; do
    header+=" $nm ($unit) |"
    rule+="---:|"
done
header+=" ugrad set-up (s) | ugrad ms / shot | chain (s) |"
rule+="---:|---:|---:|"
echo "$header"
echo "$rule"

# Per size, for the growth table: input faces, leaf elements, stage times, ms per shot.
g_faces=()
g_elems=()
g_times=()
g_ms=()
conv=()
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
    run ugbuilding "$d/0.err" "$bin/ugbuilding" --faces "$n" --messy --seed "$SEED" -o "$d/0.ug"
    cells=()
    times=()
    failed=
    chain=0
    i=0
    for stage in "${stages[@]}"; do
        read -r -a cmd <<<"$stage"
        name=${cmd[0]}
        run "$name" "$d/$((i + 1)).err" "$bin/$name" "${cmd[@]:1}" -o "$d/$((i + 1)).ug" "$d/$i.ug"
        if [ "$ok" = 0 ]; then
            echo "$n faces: $name failed:" >&2
            tail -5 "$d/$((i + 1)).err" >&2
            failed=$name
            break
        fi
        cells+=("$secs${gnu_time:+ / $peak}")
        times+=("$secs")
        chain=$(awk -v a="$chain" -v b="$secs" 'BEGIN { printf "%.3f", a + b }')
        i=$((i + 1))
    done
    input=$(faces "$d/0.ug")
    if [ -n "$failed" ]; then
        row="| $(num "$input") | | | |"
        for cell in "${cells[@]}"; do row+=" $cell |"; done
        row+=" $failed failed |"
        echo "$row"
        prev_chain=
        continue
    fi
    cleaned=$(faces "$d/6.ug")
    patches=$(faces "$d/7.ug")
    elements=$(sed -n 's/.*; \([0-9]*\) leaf elements.*/\1/p' "$d/8.err" | tail -1)
    # ugrad -v: "time: read R s, mesh and set-up S s, solve T s (N shots, M ms per shot), write W s"
    setup=$(sed -n 's/^time: read \([0-9.]*\) s, mesh and set-up \([0-9.]*\) s.*/\1 \2/p' "$d/8.err" | awk '{ printf "%.2f", $1 + $2 }')
    ms=$(sed -n 's/^time: .*, \([0-9.]*\) ms per shot.*/\1/p' "$d/8.err")
    row="| $(num "$input") | $(num "$cleaned") | $(num "$patches") | $(num "${elements:-?}") |"
    for cell in "${cells[@]}"; do row+=" $cell |"; done
    row+=" ${setup:-?} | ${ms:-?} | $chain |"
    echo "$row"
    g_faces+=("$input")
    g_elems+=("${elements:-0}")
    g_times+=("${times[*]}")
    g_ms+=("${ms:-0}")
    prev_chain=$chain
    if [ "$input" -le "$CONVERGE_MAX" ]; then
        run ugrad "$d/9.err" "$bin/ugrad" -v --visibility ray ${RAD_EPS:+-e $RAD_EPS} -o "$d/9.ug" "$d/7.ug"
        if [ "$ok" = 1 ]; then
            # "indirect tail after shot S: N patch centres (P pairs stored, M MB …; …), I iterations; …"
            tl=$(sed -n 's/^indirect tail after shot \([0-9]*\): [0-9]* patch centres (\([0-9]*\) pairs stored, [^)]*), \([0-9]*\) iterations.*/\1 \2 \3/p' "$d/9.err")
            st=$(sed -n 's/^stopped (\([A-Za-z]*\)) after \([0-9]*\) shots; \([0-9]*\) leaf elements.*unshot \([0-9.e+-]*\) .*/\1 \2 \3 \4/p' "$d/9.err")
            sv=$(sed -n 's/^time: .*, solve \([0-9.]*\) s.*/\1/p' "$d/9.err")
            read -r stop shots elems unshot <<<"$st"
            read -r t_after t_pairs t_iter <<<"${tl:-– – –}"
            conv+=("| $(num "$input") | $(num "$patches") | ${stop:-?} | $(num "${shots:-?}") | ${unshot:-?} | $t_after | $(num "$t_pairs") | $t_iter | ${sv:-?} | $secs${gnu_time:+ / $peak} | $(num "${elems:-?}") |")
        else
            conv+=("| $(num "$input") | $(num "$patches") | failed | | | | | | | | |")
        fi
    fi
    if [ "${KEEP:-0}" != 1 ]; then rm -f "$d"/[0-9].ug; fi
done

if [ "${#conv[@]}" -gt 0 ]; then
    echo
    echo "ugrad to convergence (1e-3, indirect tail at its defaults), on the same patches:"
    echo
    echo "| input faces | patches | stop | shots | unshot | tail after shot | tail pairs | tail iterations | solve (s) | ugrad ($unit) | leaf elements |"
    echo "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    for r in "${conv[@]}"; do echo "$r"; done
fi

# Growth: (time ratio) / (size ratio), size = input faces.
if [ "${#g_faces[@]}" -ge 2 ]; then
    echo
    echo "Growth from one size to the next: (time ratio) / (input-face ratio); 1 is linear, about the face ratio is quadratic."
    echo
    header="| faces | face ratio |"
    rule="|---|---:|"
    for nm in "${names[@]}"; do
        header+=" $nm |"
        rule+="---:|"
    done
    header+=" chain | ugrad ms / shot (per face ratio; per leaf-element ratio) |"
    rule+="---:|---:|"
    echo "$header"
    echo "$rule"
    for ((j = 1; j < ${#g_faces[@]}; j++)); do
        a=${g_faces[j - 1]}
        b=${g_faces[j]}
        read -r -a ta <<<"${g_times[j - 1]}"
        read -r -a tb <<<"${g_times[j]}"
        r=$(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.2f", b / a }')
        row="| $(num "$a") → $(num "$b") | $r |"
        ca=0
        cb=0
        for ((s = 0; s < ${#names[@]}; s++)); do
            row+=" $(awk -v x="${ta[s]}" -v y="${tb[s]}" -v r="$r" 'BEGIN { if (x < 0.05) print "–"; else printf "%.2f", (y / x) / r }') |"
            ca=$(awk -v c="$ca" -v x="${ta[s]}" 'BEGIN { print c + x }')
            cb=$(awk -v c="$cb" -v x="${tb[s]}" 'BEGIN { print c + x }')
        done
        row+=" $(awk -v x="$ca" -v y="$cb" -v r="$r" 'BEGIN { printf "%.2f", (y / x) / r }') |"
        row+=" $(awk -v x="${g_ms[j - 1]}" -v y="${g_ms[j]}" -v r="$r" -v ea="${g_elems[j - 1]}" -v eb="${g_elems[j]}" \
            'BEGIN { if (x <= 0 || ea <= 0) print "–"; else printf "%.2f; %.2f (elements ×%.2f)", (y / x) / r, (y / x) / (eb / ea), eb / ea }') |"
        echo "$row"
    done
fi
