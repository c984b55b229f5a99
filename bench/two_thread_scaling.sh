#!/usr/bin/env bash
# Two-thread scaling of the batched engine measured against the speed of each core it runs on.
#
# On a shared virtual machine the two vCPUs do not always run at the same speed (the same
# single-thread batch pinned to one or the other has differed by 45 %: docs/performance.md). A
# 2-thread call can then be no faster than the two cores together, and "2 threads / 1 thread"
# mixes the machine into the figure. Each round here times, back to back, a 1-thread batch pinned
# to CPU 0, the same pinned to CPU 1, the 2-thread batch, and the same lanes split into one
# 1-thread batch per thread stepped by one pool (the BM_Batch*Split row: the same work and hand-over
# with no memory in common between the threads), and prints:
#   scaling     = t(faster core) / t(2 threads)      the usual figure
#   ideal       = 1 / (1/t0 + 1/t1)                  the 2-thread time if the cores shared the work
#                                                    at their own speeds and the pool cost nothing
#   efficiency  = ideal / t(2 threads)               1.0 is perfect; 0.9 is "1.8x" on equal cores
#   split eff.  = max(t0, t1) / 2 / t(split)         what two threads give with nothing shared,
#                                                    against their own ideal (fixed halves: the
#                                                    slower core's half); where it is as low as
#                                                    the efficiency, the machine is the limit
#   trip ns     = a cache line's round trip between CPU 0 and CPU 1 (BM_CoreRoundTrip), which
#                 every hand-over and every line both threads touch pays
#
# Usage: bench/two_thread_scaling.sh [batch_bench binary] [rounds] [N] [steps per call]
# Needs `taskset` (util-linux) and two online CPUs, 0 and 1. Tested by
# tests/bench/two_thread_scaling_test.sh.
set -euo pipefail

me=two_thread_scaling.sh
bench=${1:-build/release-native/bench/batch_bench}
rounds=${2:-3}
n=${3:-1024}
steps=${4:-1}

fail() {
  echo "$me: $*" >&2
  exit 2
}
for arg in "rounds=$rounds" "N=$n" "steps per call=$steps"; do
  [[ ${arg#*=} =~ ^[1-9][0-9]*$ ]] || fail "${arg%%=*}: expected a positive integer, got '${arg#*=}'"
done
[[ -x $bench ]] || fail "no benchmark binary at '$bench' (build the release-native preset)"
command -v taskset > /dev/null || fail "taskset not found (util-linux)"
taskset -c 1 true 2> /dev/null || fail "cannot run on CPU 1: two online CPUs, 0 and 1, are needed"

one_row() { echo "BM_Batch$1/N:${n}/steps:${steps}/threads:$2"; }
split_row() { echo "BM_Batch$1Split/N:${n}/steps:${steps}/threads:2"; }
rows=$("$bench" --benchmark_list_tests 2> /dev/null) || fail "'$bench --benchmark_list_tests' failed"
for type in Double Float; do
  for threads in 1 2; do
    row=$(one_row "$type" "$threads")
    grep -qxF "$row/real_time" <<< "$rows" ||
      fail "$bench has no row $row; rows with 2 threads:" \
        "$(grep -E "^BM_Batch$type/.*threads:2" <<< "$rows" | sed 's|^BM_Batch[A-Za-z]*/||; s|/threads:2/real_time||' | tr '\n' ' ')"
  done
  row=$(split_row "$type")
  grep -qxF "$row/real_time" <<< "$rows" ||
    fail "$bench has no row $row; split rows:" \
      "$(grep -E "^BM_Batch${type}Split/" <<< "$rows" | sed 's|^BM_Batch[A-Za-z]*/||; s|/threads:2/real_time||' | tr '\n' ' ' | grep . || echo none)"
done

grep -qxF "BM_CoreRoundTrip/real_time" <<< "$rows" || fail "$bench has no row BM_CoreRoundTrip"

# Real time per call in ns of one benchmark row, run as given (prefix: e.g. "taskset -c 0").
time_ns() {
  local row=$1
  shift
  "$@" "$bench" --benchmark_filter="^${row}/real_time\$" --benchmark_min_time=0.5 2> /dev/null |
    awk '/^BM_/ { print $2; found = 1 } END { if (!found) exit 1 }' ||
    fail "no time from '$* $bench' for $row"
}

printf '%-6s %5s %10s %10s %10s %8s %10s %10s %10s %10s %8s\n' type round 't0 ns' 't1 ns' 't2thr ns' scaling \
  'ideal ns' efficiency 'split ns' 'split eff' 'trip ns'
for type in Double Float; do
  for ((r = 1; r <= rounds; ++r)); do
    t0=$(time_ns "$(one_row "$type" 1)" taskset -c 0)
    t1=$(time_ns "$(one_row "$type" 1)" taskset -c 1)
    t2=$(time_ns "$(one_row "$type" 2)")
    ts=$(time_ns "$(split_row "$type")")
    trip=$(time_ns BM_CoreRoundTrip)
    awk -v ty="$type" -v r="$r" -v a="$t0" -v b="$t1" -v c="$t2" -v d="$ts" -v e="$trip" 'BEGIN {
      fast = (a < b) ? a : b; ideal = 1 / (1 / a + 1 / b);
      printf "%-6s %5d %10.0f %10.0f %10.0f %8.2f %10.0f %10.2f %10.0f %10.2f %8.0f\n",
        ty, r, a, b, c, fast / c, ideal, ideal / c, d, (a > b ? a : b) / 2 / d, e }'
  done
done
