# Runs one libFuzzer harness for SECONDS over a fresh copy of its seed corpus, so that the
# repository is never written to; crash, timeout and out-of-memory inputs land in WORK/artifacts.
# Fails on any finding (libFuzzer's non-zero exit) and when nothing was executed. SEED fixes
# libFuzzer's random stream, so that a run explores the same inputs each time (CI stays
# reproducible; a finding reproduces with the same seed); SEED=0 lets libFuzzer pick one.
#   cmake -DFUZZER=path -DSEEDS=dir -DWORK=dir -DSECONDS=n [-DSEED=n] -P run_fuzzer.cmake
foreach(var FUZZER SEEDS WORK SECONDS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_fuzzer.cmake: -D${var}=... missing")
  endif()
endforeach()
if(NOT IS_DIRECTORY "${SEEDS}")
  message(FATAL_ERROR "run_fuzzer.cmake: no seed corpus at ${SEEDS}")
endif()
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/corpus" "${WORK}/artifacts")
file(COPY "${SEEDS}/" DESTINATION "${WORK}/corpus")
if(NOT DEFINED SEED)
  set(SEED 0)
endif()
execute_process(
  COMMAND "${FUZZER}" -max_total_time=${SECONDS} -seed=${SEED} -rss_limit_mb=2048 -timeout=10
          -print_final_stats=1 -artifact_prefix=${WORK}/artifacts/ "${WORK}/corpus"
  RESULT_VARIABLE status
  OUTPUT_VARIABLE output
  ERROR_VARIABLE output)
file(WRITE "${WORK}/fuzzer.log" "${output}")
if(NOT status EQUAL 0)
  message("${output}")
  message(FATAL_ERROR "${FUZZER}: exit status ${status}: a finding; the input is in "
                      "${WORK}/artifacts (reproduce: ${FUZZER} <that file>)")
endif()
set(runs 0)
if(output MATCHES "stat::number_of_executed_units: *([0-9]+)")
  set(runs ${CMAKE_MATCH_1})
endif()
if(runs EQUAL 0)
  message("${output}")
  message(FATAL_ERROR "${FUZZER}: no input was executed")
endif()
set(peak "?")
if(output MATCHES "stat::peak_rss_mb: *([0-9]+)")
  set(peak ${CMAKE_MATCH_1})
endif()
message("${FUZZER}: ${runs} inputs in ${SECONDS} s (seed ${SEED}), peak RSS ${peak} MB, no finding")
