#!/usr/bin/env bash
# Two-thread scaling of the batched engine measured against the speed of each core it runs on.
#
# On a shared virtual machine the two vCPUs do not always run at the same speed (the same
# single-thread batch pinned to one or the other has differed by 45 %: docs/performance.md). A
# 2-thread call can then be no faster than the two cores together, and "2 threads / 1 thread"
# mixes the machine into the figure. Each round here times, back to back, a 1-thread batch pinned
# to CPU 0, the same pinned to CPU 1, and the 2-thread batch, and prints:
#   scaling     = t(faster core) / t(2 threads)      the usual figure
#   ideal       = 1 / (1/t0 + 1/t1)                  the 2-thread time if the cores shared the work
#                                                    at their own speeds and the pool cost nothing
#   efficiency  = ideal / t(2 threads)               1.0 is perfect; 0.9 is "1.8x" on equal cores
#
# Usage: bench/two_thread_scaling.sh [batch_bench binary] [rounds] [N] [steps per call]
# Needs `taskset` (util-linux) and two online CPUs, 0 and 1.
set -euo pipefail

bench=${1:-build/release-native/bench/batch_bench}
rounds=${2:-3}
n=${3:-1024}
steps=${4:-1}

if [[ ! -x $bench ]]; then
  echo "two_thread_scaling.sh: no benchmark binary at '$bench' (build the release-native preset)" >&2
  exit 2
fi
command -v taskset > /dev/null || { echo "two_thread_scaling.sh: taskset not found" >&2; exit 2; }

# Real time per call in ns of one benchmark row, run as given (prefix: e.g. "taskset -c 0").
time_ns() {
  local filter=$1
  shift
  "$@" "$bench" --benchmark_filter="^${filter}/real_time\$" --benchmark_min_time=0.5 2> /dev/null |
    awk '/^BM_/ { print $2; found = 1 } END { if (!found) exit 1 }'
}

printf '%-6s %5s %10s %10s %10s %8s %10s %10s\n' type round 't0 ns' 't1 ns' 't2thr ns' scaling 'ideal ns' efficiency
for type in Double Float; do
  one="BM_Batch${type}/N:${n}/steps:${steps}/threads:1"
  two="BM_Batch${type}/N:${n}/steps:${steps}/threads:2"
  for ((r = 1; r <= rounds; ++r)); do
    t0=$(time_ns "$one" taskset -c 0) || { echo "no row $one" >&2; exit 1; }
    t1=$(time_ns "$one" taskset -c 1)
    t2=$(time_ns "$two")
    awk -v ty="$type" -v r="$r" -v a="$t0" -v b="$t1" -v c="$t2" 'BEGIN {
      fast = (a < b) ? a : b; ideal = 1 / (1 / a + 1 / b);
      printf "%-6s %5d %10.0f %10.0f %10.0f %8.2f %10.0f %10.2f\n", ty, r, a, b, c, fast / c, ideal, ideal / c }'
  done
done
