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

# --from and --to take what the output shows: a time of day (local for absolute times, on
# the first record's day or the next; as read for a log's times), a date and time,
# seconds as in the CSV, +S after the first record. A time the input's times cannot
# hold (a time of day for relative times, a date for times of day) is a bad value.
add_times_test(from_to_local_time_of_day ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --csv --from 00:00:00 --to 00:59:59.9
  STDOUT_RE "^frame,[^\n]*\n3,1795302000.500000,[^\n]*\n4,[^\n]*\n5,[^\n]*\n6,1795305599.520000,[^\n]*\n$")
add_times_test(from_time_of_day_in_utc UTC RC 0
  ARGS decode tests/data/times_midnight.rtucap --csv --from 23:59:59
  STDOUT_RE "^frame,[^\n]*\n5,[^\n]*\n6,[^\n]*\n7,[^\n]*\n8,1795305600.520000,[^\n]*\n$")
add_times_test(from_to_date_and_time ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --csv --from "2026-11-22 00:00:00" --to 2026-11-22T00:59:59.6
  STDOUT_RE "^frame,[^\n]*\n3,[^\n]*\n4,[^\n]*\n5,[^\n]*\n6,[^\n]*\n$")
add_times_test(from_epoch_seconds ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --csv --from 1795305600
  STDOUT_RE "^frame,[^\n]*\n7,[^\n]*\n8,[^\n]*\n$")
add_times_test(from_after_the_first_record ${berlin} RC 0
  ARGS decode tests/data/times_midnight.rtucap --csv --from +3599.9
  STDOUT_RE "^frame,[^\n]*\n5,[^\n]*\n6,[^\n]*\n7,[^\n]*\n8,[^\n]*\n$")
add_times_test(from_a_logs_time_of_day ${berlin} RC 0
  ARGS decode tests/data/time_of_day.log --no-color --from 23:00:00
  STDOUT_RE "\\)\n    3 23:59:59.900000    1 ▶ [^\n]*\n-- day 2 [^\n]*\n    4 00:00:00.100000    1 ◀ [^\n]*\n-- 4 records")
add_times_test(bad_time_of_day ${berlin} RC 2
  ARGS decode tests/data/times_midnight.rtucap --from 24:00:00
  STDERR_RE "^rtuscope: error: --from: bad time \"24:00:00\" \\(a time of day 08:00:01.5, a date and time 2026-11-21 08:00:01, seconds as in the CSV time column, or \\+S after the first frame\\)\n$")
add_times_test(time_of_day_for_relative_times ${berlin} RC 2
  ARGS decode captures/framing/bad_crc.rtucap --to 08:00:01
  STDERR_RE "^rtuscope: error: --to: the input's times are relative seconds, with no clock: give seconds as in the CSV time column, or \\+S after the first frame\n$")
add_times_test(date_for_times_of_day ${berlin} RC 2
  ARGS decode tests/data/time_of_day.log --from "2024-05-01 09:00:00"
  STDERR_RE "^rtuscope: error: --from: the input's times have no date: give a time of day \\(08:00:01\\)\n$")
