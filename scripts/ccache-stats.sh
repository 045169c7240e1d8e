#!/usr/bin/env bash
# The compiler cache's hit rate over one build, for the scripts' stage lines.
#
# Usage: scripts/ccache-stats.sh snapshot        prints ccache's counters now
#        scripts/ccache-stats.sh since SNAPSHOT  prints ", ccache: H of N
#                                                compiles cached (P %)" for
#                                                the compiles since SNAPSHOT
# Prints nothing (and succeeds) without ccache, or when nothing was compiled
# through it (GYROTC_CCACHE=OFF): the stage line then reads as before.
set -euo pipefail

counters() {
  command -v ccache >/dev/null 2>&1 || return 0
  ccache --print-stats 2>/dev/null |
    awk -F'\t' '$1 ~ /^(direct_cache_hit|preprocessed_cache_hit|cache_miss)$/ { n[$1] = $2 }
                END { printf "%d %d\n", n["direct_cache_hit"] + n["preprocessed_cache_hit"], n["cache_miss"] }'
}

case "${1:-}" in
  snapshot) counters ;;
  since)
    [ -n "${2:-}" ] || exit 0
    now=$(counters)
    [ -n "$now" ] || exit 0
    read -r hits0 misses0 <<<"$2"
    read -r hits1 misses1 <<<"$now"
    hits=$((hits1 - hits0)) total=$((hits1 - hits0 + misses1 - misses0))
    [ "$total" -gt 0 ] || exit 0
    echo ", ccache: $hits of $total compiles cached ($((100 * hits / total)) %)" ;;
  *) echo "usage: $0 snapshot | since SNAPSHOT" >&2; exit 2 ;;
esac
