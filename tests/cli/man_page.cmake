# The man page documents every option of every command.
#
#   cmake -DRTUSCOPE=path/to/rtuscope -DMAN_PAGE=docs/rtuscope.1 -P tests/cli/man_page.cmake
#
# Runs `rtuscope --help` and `rtuscope COMMAND --help` for every command and subcommand
# (the ones listed below, and any other that a help text lists under "Subcommands:"),
# collects every option the help texts name (`--long-name` and `-x`), and fails listing
# each option and command that the man page does not mention. roff writes a hyphen as
# `\-` and switches fonts with `\fB`, `\fI`, `\fR`, `\fP` or `\f[B]`: those are undone
# before searching, so `\fB\-\-baud\fR` counts as `--baud`.
cmake_minimum_required(VERSION 3.25)

foreach(var RTUSCOPE MAN_PAGE)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "man_page.cmake: -D${var}=... is required")
  endif()
endforeach()
if(NOT EXISTS "${MAN_PAGE}")
  message(FATAL_ERROR "man_page.cmake: no man page at ${MAN_PAGE}")
endif()

# Commands as argument lists joined with "|"; "rtuscope" is the program itself.
set(commands "rtuscope" "decode" "stats" "sniff" "demo" "profiles" "profiles|list" "profiles|show" "profiles|infer"
             "profiles|check")
set(options "")
set(checked "")

# Each command's help; new subcommands found on the way are added to the queue.
set(queue ${commands})
list(LENGTH queue remaining)
while(remaining GREATER 0)
  list(POP_FRONT queue command)
  list(LENGTH queue remaining)
  if(command IN_LIST checked)
    continue()
  endif()
  list(APPEND checked "${command}")

  if(command STREQUAL "rtuscope")
    set(args "")
  else()
    string(REPLACE "|" ";" args "${command}")
  endif()
  execute_process(COMMAND "${RTUSCOPE}" ${args} --help
    RESULT_VARIABLE rc OUTPUT_VARIABLE help ERROR_VARIABLE err)
  string(REPLACE ";" " " shown "rtuscope ${args} --help")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "`${shown}` exited with ${rc}: ${err}")
  endif()
  if(NOT help MATCHES "Options:")
    message(FATAL_ERROR "`${shown}` printed no option list:\n${help}")
  endif()

  # Subcommands: the lines after "Subcommands:", each "  name   description".
  string(FIND "${help}" "Subcommands:" at)
  if(NOT at EQUAL -1)
    string(SUBSTRING "${help}" ${at} -1 tail)
    string(REPLACE "\n" ";" lines "${tail}")
    list(POP_FRONT lines)
    foreach(line IN LISTS lines)
      if(line MATCHES "^  ([a-z][a-z0-9-]*)( |$)")
        if(command STREQUAL "rtuscope")
          set(sub "${CMAKE_MATCH_1}")
        else()
          set(sub "${command}|${CMAKE_MATCH_1}")
        endif()
        if(NOT sub IN_LIST checked)
          list(APPEND queue "${sub}")
        endif()
      elseif(NOT line STREQUAL "")
        break()
      endif()
    endforeach()
    list(LENGTH queue remaining)
  endif()

  # Options: "-x" and "--long-name" where a word starts (after a space, a comma, "[" or
  # the start of a line), so that "read-only" or "10-20" are not taken for one. The
  # usage line is left out: it names the program by its path.
  string(REGEX REPLACE "Usage:[^\n]*" "" help "${help}")
  string(REPLACE "\n" " \n " help " ${help}")
  string(REGEX MATCHALL "[ ,[]--?[A-Za-z][A-Za-z0-9-]*" found "${help}")
  foreach(option IN LISTS found)
    string(SUBSTRING "${option}" 1 -1 option)
    string(REGEX REPLACE "-+$" "" option "${option}")
    if(NOT option IN_LIST options)
      list(APPEND options "${option}")
    endif()
  endforeach()
endwhile()

list(LENGTH options count)
if(count LESS 10)
  message(FATAL_ERROR "only ${count} options found in the help texts (${options}): "
                      "has their layout changed?")
endif()

# The man page as plain text: font switches undone, roff's escaped hyphens made plain.
file(READ "${MAN_PAGE}" page)
string(REGEX REPLACE "\\\\f\\[[A-Z]*\\]" "" page "${page}")
string(REGEX REPLACE "\\\\f\\([A-Z][A-Z]" "" page "${page}")
string(REGEX REPLACE "\\\\f[BIRP1-4]" "" page "${page}")
string(REPLACE "\\-" "-" page "${page}")
string(REPLACE "\\&" "" page "${page}")
string(REPLACE "\\%" "" page "${page}")
set(page " ${page} ")

set(missing "")
foreach(option IN LISTS options)
  # A whole option: not inside a longer one (`-t` is not found in `--time`).
  if(NOT page MATCHES "[^A-Za-z0-9-]${option}[^A-Za-z0-9-]")
    list(APPEND missing "${option}")
  endif()
endforeach()
foreach(command IN LISTS checked)
  if(command STREQUAL "rtuscope")
    continue()
  endif()
  string(REPLACE "|" " " words "${command}")
  if(NOT page MATCHES "[^A-Za-z0-9-]${words}[^A-Za-z0-9-]")
    list(APPEND missing "command `${words}`")
  endif()
endforeach()

if(missing)
  list(JOIN missing ", " missing_text)
  message(FATAL_ERROR "${MAN_PAGE} does not document: ${missing_text}")
endif()
list(LENGTH checked commands_count)
message(STATUS "${MAN_PAGE}: all ${count} options of ${commands_count} help texts documented")
