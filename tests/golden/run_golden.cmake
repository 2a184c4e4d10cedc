# Runs one golden test, one line of MANIFEST: `rtuscope COMMAND INPUT OPTIONS...` from the
# working directory with TZ=UTC (the text shows local time), its standard output compared
# byte for byte with GOLDEN_DIR/NAME and its exit status with EXPECTED_RC. The output goes to OUT_DIR/NAME; on a difference it
# stays there and a unified diff is printed, otherwise it is removed.
#   RTUSCOPE     the binary              NAME     the expected file's name
#   COMMAND      decode, stats, watch...
#   INPUT        the input               OPTIONS  rtuscope's options, a ;-list
#   EXPECTED_RC  0 unless the line says exit=N
#   GOLDEN_DIR   tests/golden            OUT_DIR  where the actual output goes
if(NOT DEFINED EXPECTED_RC)
  set(EXPECTED_RC 0)
endif()
list(JOIN OPTIONS " " shown_options)
set(command "rtuscope ${COMMAND} ${INPUT} ${shown_options}")
set(expected_file ${GOLDEN_DIR}/${NAME})
set(actual_file ${OUT_DIR}/${NAME})
file(MAKE_DIRECTORY ${OUT_DIR})
set(ENV{TZ} UTC)
execute_process(COMMAND ${RTUSCOPE} ${COMMAND} ${INPUT} ${OPTIONS}
  OUTPUT_FILE ${actual_file} ERROR_VARIABLE errors RESULT_VARIABLE rc)

set(failed FALSE)
if(NOT rc STREQUAL EXPECTED_RC)
  message(SEND_ERROR "${NAME}: `${command}` exited with ${rc}, expected ${EXPECTED_RC}; "
    "stderr:\n${errors}")
  set(failed TRUE)
endif()
if(NOT EXISTS ${expected_file})
  message(FATAL_ERROR "${NAME}: missing expectation ${expected_file} (scripts/regen-golden ${NAME})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${expected_file} ${actual_file}
  RESULT_VARIABLE differs)
if(NOT differs EQUAL 0)
  message(SEND_ERROR "${NAME}: the output of `${command}` differs from tests/golden/${NAME} "
    "(actual output kept in ${actual_file}; stderr: ${errors})")
  execute_process(COMMAND diff -u --label tests/golden/${NAME} --label ${actual_file}
    ${expected_file} ${actual_file})
  set(failed TRUE)
endif()
if(failed)
  message(FATAL_ERROR "golden test ${NAME} failed")
endif()
file(REMOVE ${actual_file})
