# `profiles check` and `profiles show` on the command line (included by tests/CMakeLists.txt,
# which defines add_cli_test).

# Every mistake of a file in one pass, in file order: a register with a mistake of its
# own still overlaps others, and a long string overlaps more than the register after it.
set(f tests/data/profile_several_mistakes.toml)
set(several_mistakes "${f}:5:8: bad line format \"8X1\" [^\n]*
${f}:13:1: register \"serial\" \\(0x0002\\) overlaps \"model\" \\(0x0000, 8 registers, line 7\\) in table holding
${f}:16:10: access \"RO\" must be \"R\", \"W\" or \"RW\"
${f}:18:1: register \"firmware\" \\(0x0005\\) overlaps \"model\" \\(0x0000, 8 registers, line 7\\) in table holding
${f}:27:12: give scale or decimals, not both
${f}:29:1: register \"bad name\" \\(0x000A\\) overlaps \"voltage\" \\(0x000A, 1 register, line 22\\) in table holding
${f}:31:8: name \"bad name\" must be letters, digits, _ \\. -
")
add_cli_test(profiles_check_several_mistakes_in_one_pass RC 1 ARGS profiles check ${f}
  STDERR_RE "^${several_mistakes}$")
# decode --profile prints the same list, each line as an error.
string(REPLACE "${f}:" "rtuscope: error: ${f}:" several_mistakes_as_errors "${several_mistakes}")
add_cli_test(decode_with_profile_of_several_mistakes RC 1
  ARGS decode captures/seeds/pdu485.hex --profile ${f}
  STDERR_RE "^${several_mistakes_as_errors}$")

# A TOML syntax error in plain words, at the place to look, from profiles check,
# --profile and --bus alike.
set(f tests/data/profile_unclosed_string.toml)
set(unclosed_string "${f}:7:8: a string is not closed: add the missing \" at the end of the value\n")
add_cli_test(profiles_check_unclosed_string RC 1 ARGS profiles check ${f}
  STDERR_RE "^${unclosed_string}$")
add_cli_test(decode_with_profile_of_unclosed_string RC 1
  ARGS decode captures/seeds/pdu485.hex --profile ${f}
  STDERR_RE "^rtuscope: error: ${unclosed_string}$")
set(f tests/data/bus_unclosed_header.toml)
add_cli_test(decode_with_bus_file_of_unclosed_header RC 1
  ARGS decode captures/seeds/pdu485.hex --bus ${f}
  STDERR_RE "^rtuscope: error: ${f}:6:1: the table header \\[\\[device\\] is not closed: write \\[\\[device\\]\\]\n$")

# profiles show prints every field that changes a value: how many registers it takes and,
# for 32-bit values, which comes first.
add_cli_test(profiles_show_word_order_and_length RC 0
  ARGS profiles show show-meter --profile tests/data/profile_show.toml
  STDOUT_RE "\ntable +address +name +type +registers +scale +unit +access +range +description\ncoil +0x0000  relay +u16 +bit +R +\nholding +0x0000  energy +u32 +2 low_first +x0.01 +kWh +R +\nholding +0x0002  power +f32 +2 high_first +W +R +\nholding +0x0004  model +string +4 +R +\n$")

# A word order or a type that is not one, each at its place.
set(f tests/data/profile_word_orders.toml)
add_cli_test(profiles_check_word_order_and_type RC 1 ARGS profiles check ${f}
  STDERR_RE "^${f}:17:14: unknown word_order \"bacd\" \\(abcd, cdab, badc, dcba, high_first \\(abcd\\), low_first \\(cdab\\)\\)
${f}:22:8: unknown type \"u128\" \\(u16, i16, u32, i32, f32, u64, i64, f64, bits, enum, string\\)
$")

# profiles check tells bus files from profiles by their content and checks them too:
# every mistake, profile names known from --profile, --profile-dir and the files checked
# with it.
add_cli_test(profiles_check_bus_file RC 0
  ARGS profiles check tests/data/seed_bus.toml profiles/pdu485.toml
  STDOUT_RE "^tests/data/seed_bus.toml: ok, bus file with 2 devices \\(line 9600 8N1\\)\nprofiles/pdu485.toml: ok, profile \"pdu485\" with 28 registers\n$")
set(f tests/data/bad_bus.toml)
set(bad_bus "${f}:3:8: bad line format \"9X1\" [^\n]*
${f}:4:1: unknown key \"speed\" \\(a bus file has line and \\[\\[device\\]\\]\\)
${f}:11:11: address must be a number from 0 to 255
${f}:16:11: unknown profile \"custom-meter\" \\(known: pdu485, sensor-analyser, zb-uvi485, zyi-relay\\)
${f}:17:1: unknown key \"name\" in \\[\\[device\\]\\]
${f}:19:1: \\[\\[device\\]\\] needs address and profile
")
add_cli_test(profiles_check_bad_bus_file RC 1 ARGS profiles check ${f}
  STDERR_RE "^${bad_bus}$")
string(REPLACE "${f}:" "rtuscope: error: ${f}:" bad_bus_as_errors "${bad_bus}")
add_cli_test(decode_with_bad_bus_file_every_mistake RC 1
  ARGS decode captures/seeds/pdu485.hex --bus ${f}
  STDERR_RE "^${bad_bus_as_errors}$")
add_cli_test(profiles_check_bus_file_of_unknown_profile RC 1
  ARGS profiles check tests/data/custom_meter_bus.toml
  STDERR_RE "^tests/data/custom_meter_bus.toml:5:11: unknown profile \"custom-meter\" [^\n]*\n$")
add_cli_test(profiles_check_bus_file_with_profile_option RC 0
  ARGS profiles check tests/data/custom_meter_bus.toml --profile tests/data/profiles/custom_meter.toml
  STDOUT_RE "^tests/data/custom_meter_bus.toml: ok, bus file with 1 device\n$")
add_cli_test(profiles_check_bus_file_with_profile_dir RC 0
  ARGS profiles check tests/data/custom_meter_bus.toml --profile-dir tests/data/profiles
  STDOUT_RE "^tests/data/custom_meter_bus.toml: ok, bus file with 1 device\n$")
add_cli_test(profiles_check_bus_file_with_its_profile RC 0
  ARGS profiles check tests/data/custom_meter_bus.toml tests/data/profiles/custom_meter.toml
  STDOUT_RE "^tests/data/custom_meter_bus.toml: ok, bus file with 1 device\ntests/data/profiles/custom_meter.toml: ok, profile \"custom-meter\" with 1 register\n$")
add_cli_test(profiles_check_neither_profile_nor_bus_file RC 1
  ARGS profiles check tests/data/not_a_profile.toml
  STDERR_RE "^tests/data/not_a_profile.toml: neither a device profile \\(\\[device\\]\\) nor a bus file \\(\\[\\[device\\]\\] entries or line\\): nothing to check\n$")
