# Times and hex logs on the command line (included at the end of tests/CMakeLists.txt).
#
# add_times_test(NAME ZONE ...): add_cli_test's cli.times.NAME, run with TZ=ZONE, since the
# text shows local time. Zones are POSIX TZ strings where they must not need tzdata:
# CET-1CEST,M3.5.0,M10.5.0/3 is Central European time with its summer time.
function(add_times_test name zone)
  add_cli_test(times.${name} ${ARGN})
  set_tests_properties(cli.times.${name} PROPERTIES ENVIRONMENT "TZ=${zone}")
endfunction()

# Hex logs whose frames are split over lines (a terminal logging each read()), or several
# on one line: each line that is one frame is taken as it is, the others are framed.
add_times_test(hex_frame_split_over_lines UTC RC 0
  ARGS decode tests/data/split_frames.log --no-color
  STDOUT_RE "\n    1 [^\n]*    1 ▶ Read Holding Registers +0x0000 x2\n    2 [^\n]*    1 ◀ Read Holding Registers +2 registers: 0x089D 0x0096  11.67 ms after #1\n-- 2 records[^\n]*\n-- CRC: 0 bad[^\n]*\n-- note: 1 line held one frame, 2 lines were framed as a byte stream \\(not one frame by length and CRC\\)\n$")
add_times_test(hex_frame_keeps_the_logs_time UTC RC 0
  ARGS decode tests/data/split_frames.log --csv
  STDOUT_RE "\n1,36000.000000,1,3,request,[^\n]*\n2,36000.020000,1,3,response,ok,1,11.667,")
add_times_test(hex_request_and_answer_on_one_line UTC RC 0
  ARGS decode tests/data/two_frames_a_line.log --no-color
  STDOUT_RE "\n    1 +-    1 ▶ Read Holding Registers +0x0000 x2\n    2 +-    1 ◀ Read Holding Registers +2 registers: 0x089D 0x0096  answers #1\n-- 2 records")
add_times_test(hex_whole_and_framed_lines UTC RC 0
  ARGS decode tests/data/mixed_lines.log --no-color
  STDOUT_RE "\n    4 +-    1 ◀ Write Single Register +0x0001 = 0x0003 \\(3\\)  answers #3\n    5 +-    2 ▶ Read Holding Registers +0x0000 x1\n    6 +-    2 ◀ Read Holding Registers +exception 02 Illegal Data Address  answers #5\n-- 6 records, 46 bytes: 3 requests, 2 answers, 1 exceptions?, [^\n]*, 0 invalid,[^\n]*\n-- CRC: 0 bad[^\n]*\n-- note: 3 lines held one frame each, 3 lines were framed as a byte stream \\(not one frame by length and CRC\\)\n-- note: skipped 3 lines with no frame: 1, 5, 7\n$")
