# --guess: readings of the registers no profile covers (docs/formats.md), on
# tests/data/guess_unknown_device.hex (slave 5: an f32 low word first at input 0x0100, an
# i16 -200 at 0x0102, writes to holding 0x0010 and 0x0020-0x0021).

# A register the profile covers is shown by the profile, never guessed; the ones it does
# not list are (pdu485 covers holding 0x0000-0x001C, so 0x0010 but not 0x0020).
add_cli_test(guess_leaves_profiled_registers_alone RC 0
  ARGS decode tests/data/guess_unknown_device.hex --values-csv --guess --device 5=pdu485
  STDOUT_RE "\n,5,pdu485,0x0010,humidity_low_alarm,6553.4,%,0xFFFE,3,request,ok,,\n.*\n,5,pdu485,0x0020,f32/abcd,1.5,,0x3FC0 0x0000,5,request,ok,value.guess,"
  STDOUT_NOT_RE ",0x0010,[ui]16,")
# --as types 0x0100-0x0101: the typed value, and guesses only from 0x0102 on (not of
# 0x0100, nor of 0x0101 with 0x0102).
add_cli_test(guess_with_as_on_the_same_register RC 0
  ARGS decode tests/data/guess_unknown_device.hex --no-color --guess --as 5:input:0x0100=f32/cdab
  STDOUT_RE "\n +reg_0x0100 += 23.5 \\(raw 0x0000 0x41BC\\)\n +0x0102..0x0103 not in the profile: 0xFF38 0x04D2\n +guess 0x0102 \\(0xFF38\\): u16 65336, i16 -200 \\| with 0x0103: "
  STDOUT_NOT_RE "guess 0x010[01]")
# --values-csv needs no device with --guess: the profile column is empty then.
add_cli_test(guess_values_csv_without_devices RC 0
  ARGS decode tests/data/guess_unknown_device.hex --values-csv --guess
  STDOUT_RE "\n,5,,0x0100,f32/cdab,23.5,,0x0000 0x41BC,2,response,ok,value.guess,a guess: no profile covers the register\n")
# stats takes the option, as decode does; it shows no values, so no guesses either.
add_cli_test(stats_takes_guess RC 0
  ARGS stats tests/data/guess_unknown_device.hex --guess
  STDOUT_NOT_RE "guess 0x")
