# --as: registers typed on the command line (docs/profiles.md), on the PDU manual's
# frames: a 29-register read from 0x0000 whose 0x0004-0x0005 hold 0x0000 0x3039.

# A slave without a profile: only the typed registers have names, the rest is unlisted.
add_cli_test(as_types_registers_of_a_slave_without_profile RC 0
  ARGS decode captures/seeds/pdu485.hex --values-csv --as 1:0=u16*0.1:V --as 1:0x0004=u32/cdab
  STDOUT_RE "\n,1,as-1,0x0000,reg_0x0000,220.5,V,0x089D,2,response,ok,,\n,1,as-1,0x0001,,150,,0x0096,2,response,ok,value.unlisted,not in the profile\n.*\n,1,as-1,0x0004,reg_0x0004,809041920,,0x0000 0x3039,2,response,ok,,\n")
# A slave with a profile: the typed register replaces the profile's, keeping its name.
add_cli_test(as_overrides_a_register_of_the_profile RC 0
  ARGS decode captures/seeds/pdu485.hex --device 1=pdu485 --as 1:4=u64
  STDOUT_RE "\n +voltage += 220.5 V \\(raw 0x089D\\)\n.*\n +energy += 53021371334659 \\(raw 0x0000 0x3039 0x0001 0x0003\\)\n +current_high_alarm")
add_cli_test(as_in_jsonl RC 0
  ARGS decode captures/seeds/pdu485.hex --jsonl --as 1:input:9=u16 --as 1:0x0002=i32/dcba
  STDOUT_RE "\"profile\":\"as-1\",\"values\":\\[{\"address\":0,\"name\":null,\"value\":2205,[^\n]*{\"address\":2,\"name\":\"reg_0x0002\",\"value\":-654096895,")
add_cli_test(as_malformed RC 2
  ARGS decode captures/seeds/pdu485.hex --as 1:0x0004=f32/xyzw
  STDERR_RE "^rtuscope: error: bad --as \"1:0x0004=f32/xyzw\": unknown word order \"xyzw\" \\([^\n]*\\)\n$")
add_cli_test(stats_takes_as RC 2
  ARGS stats captures/seeds/pdu485.hex --as 1:0x0004=q32
  STDERR_RE "^rtuscope: error: bad --as \"1:0x0004=q32\": unknown type \"q32\"")
