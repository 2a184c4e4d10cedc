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

# The time column (-t, tshark's letters): local time by default, with the date on a line of
# its own when it changes; UTC with u; the date in the column with ad and ud; the CSV's
# seconds with e. CSV and JSONL keep their seconds whatever -t says.
set(berlin "CET-1CEST,M3.5.0,M10.5.0/3")
add_times_test(local_time_of_day_by_default ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --no-color
  STDOUT_RE "\\(t1.5 1.56 ms, t3.5 3.65 ms\\)\n-- 2026-11-21 CET \\(UTC\\+01:00\\)\n    1 23:59:59.500000    1 ▶ [^\n]*\n    2 23:59:59.520000    1 ◀ [^\n]*\n-- 2026-11-22 CET \\(UTC\\+01:00\\)\n    3 00:00:00.500000    1 ▶ [^\n]*\n    4 00:00:00.520000 [^\n]*\n    5 00:59:59.500000 [^\n]*\n    6 00:59:59.520000 [^\n]*\n    7 01:00:00.500000 ")
add_times_test(local_time_in_utc UTC RC 0
  ARGS decode tests/data/times_midnight.rtucap --no-color -t a
  STDOUT_RE "\n-- 2026-11-21 UTC\n    1 22:59:59.500000 [^\n]*\n[^\n]*\n[^\n]*\n[^\n]*\n    5 23:59:59.500000 [^\n]*\n    6 23:59:59.520000 [^\n]*\n-- 2026-11-22 UTC\n    7 00:00:00.500000 ")
add_times_test(utc_time_of_day ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --no-color -t u
  STDOUT_RE "\n-- 2026-11-21 UTC\n    1 22:59:59.500000 [^\n]*\n[^\n]*\n[^\n]*\n[^\n]*\n    5 23:59:59.500000 [^\n]*\n    6 23:59:59.520000 [^\n]*\n-- 2026-11-22 UTC\n    7 00:00:00.500000 ")
add_times_test(local_date_and_time ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --no-color -t ad
  STDOUT_RE "\\)\n    1 2026-11-21 23:59:59.500000    1 ▶ [^\n]*\n    2 2026-11-21 23:59:59.520000    1 ◀ [^\n]*\n    3 2026-11-22 00:00:00.500000    1 ▶ ")
add_times_test(utc_date_and_time ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --no-color -t ud
  STDOUT_RE "\\)\n    1 2026-11-21 22:59:59.500000    1 ▶ .*\n    8 2026-11-22 00:00:00.520000    1 ◀ ")
add_times_test(epoch_seconds ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --no-color -t e
  STDOUT_RE "\\)\n    1 1795301999.500000    1 ▶ .*\n    8 1795305600.520000    1 ◀ ")
add_times_test(csv_keeps_its_seconds ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --csv -t ad
  STDOUT_RE "^frame,time,[^\n]*\n1,1795301999.500000,1,3,request,")
# Times read without a zone show as read, in any zone: a log's time of day (past
# midnight: a line says so), a log's date and time.
add_times_test(log_time_of_day_shows_as_read ${berlin} RC 0
  ARGS decode tests/data/time_of_day.log --no-color
  STDOUT_RE "\\)\n    1 09:00:00.480000    1 ▶ [^\n]*\n    2 09:00:00.500000    1 ◀ [^\n]*11.67 ms after #1\n    3 23:59:59.900000    1 ▶ [^\n]*\n-- day 2 \\(the log's times have no date\\)\n    4 00:00:00.100000    1 ◀ ")
add_times_test(log_date_and_time_show_as_read ${berlin} RC 0
  ARGS decode captures/logs/serial_terminal.log --no-color -t u
  STDOUT_RE "\\)\n-- 2024-05-01\n    1 10:21:33.120000    1 ▶ ")
