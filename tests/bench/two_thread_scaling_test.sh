#!/usr/bin/env bash
# bench/two_thread_scaling.sh: its figures from known times, and its refusals by name. A stand-in
# benchmark binary answers as batch_bench does, with a time per call that depends only on where it
# runs: 60 us pinned to CPU 0, 40 us pinned to CPU 1, 30 us for the 2-thread row, 31.25 us for
# the split row, 200 ns for the core-to-core round trip. By hand: scaling = 40 / 30 = 1.33,
# ideal = 1 / (1/60 + 1/40) = 24 us, efficiency = 24 / 30 = 0.80, split efficiency (fixed
# halves: the slower core's half, 30 us) = 30 / 31.25 = 0.96.
# Exits 77 (skipped) on a machine without CPU 1.
set -uo pipefail

script="$(cd "$(dirname "$0")/../.." && pwd)/bench/two_thread_scaling.sh"
taskset -c 1 true 2> /dev/null || { echo "no CPU 1 here: skipped"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
check() {  # check <what> <expected substring> <text>
  if [[ $3 != *"$2"* ]]; then
    echo "FAIL: $1: expected '$2' in:"
    echo "$3"
    failures=$((failures + 1))
  fi
}

fake="$work/batch_bench"
cat > "$fake" << 'FAKE'
#!/usr/bin/env bash
rows="BM_BatchDouble/N:1024/steps:1/threads:1 BM_BatchDouble/N:1024/steps:1/threads:2
BM_BatchFloat/N:1024/steps:1/threads:1 BM_BatchFloat/N:1024/steps:1/threads:2
BM_BatchDoubleSplit/N:1024/steps:1/threads:2 BM_BatchFloatSplit/N:1024/steps:1/threads:2
BM_CoreRoundTrip"
if [[ $1 == --benchmark_list_tests ]]; then
  for row in $rows; do echo "$row/real_time"; done
  exit 0
fi
filter=${1#--benchmark_filter=^}
row=${filter%/real_time\$}
cpus=$(awk '/^Cpus_allowed_list/ { print $2 }' /proc/self/status)
case "$row:$cpus" in
  BM_CoreRoundTrip:*) t=200 ;;
  *Split/*) t=31250 ;;
  *threads:2:*) t=30000 ;;
  *threads:1:0) t=60000 ;;
  *threads:1:1) t=40000 ;;
  *) exit 1 ;;
esac
echo "$row/real_time $t ns $t ns 100"
FAKE
chmod +x "$fake"

out=$(bash "$script" "$fake" 2 2>&1)
check "exit status of a run" "0" "$?"
for type in Double Float; do
  check "$type row" "$(printf '%-6s %5d %10.0f %10.0f %10.0f %8.2f %10.0f %10.2f %10.0f %10.2f %8.0f' \
    "$type" 2 60000 40000 30000 1.33 24000 0.80 31250 0.96 200)" "$out"
done

check "bad rounds" "rounds: expected a positive integer, got 'two'" "$(bash "$script" "$fake" two 2>&1)"
check "bad N" "N: expected a positive integer, got '-5'" "$(bash "$script" "$fake" 1 -5 2>&1)"
check "bad steps" "steps per call: expected a positive integer, got '0'" \
  "$(bash "$script" "$fake" 1 1024 0 2>&1)"
check "no binary" "no benchmark binary at '$work/missing'" "$(bash "$script" "$work/missing" 2>&1)"
check "no row" "has no row BM_BatchDouble/N:512/steps:1/threads:1; rows with 2 threads: N:1024/steps:1" \
  "$(bash "$script" "$fake" 1 512 2>&1)"
bash "$script" "$fake" 1 512 > /dev/null 2>&1
check "exit status of a refusal" "2" "$?"
# A binary from before the split rows: refused by name, not a run with an empty column.
old="$work/old_bench"
sed 's/BM_Batch[A-Za-z]*Split[^ "]*//g' "$fake" > "$old"
chmod +x "$old"
check "no split row" "has no row BM_BatchDoubleSplit/N:1024/steps:1/threads:2; split rows: none" \
  "$(bash "$script" "$old" 1 2>&1)"
check "split row of another N" "has no row BM_BatchDoubleSplit/N:512/steps:1/threads:2; split rows: N:1024/steps:1" \
  "$(sed 's|BM_BatchDouble/N:1024|BM_BatchDouble/N:512|g' "$fake" > "$work/n512" && chmod +x "$work/n512" && bash "$script" "$work/n512" 1 512 2>&1)"
no_trip="$work/no_trip_bench"
sed 's/^BM_CoreRoundTrip"$/"/' "$fake" > "$no_trip"
chmod +x "$no_trip"
check "no round-trip row" "has no row BM_CoreRoundTrip" "$(bash "$script" "$no_trip" 1 2>&1)"
echo "$out"

if ((failures > 0)); then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
