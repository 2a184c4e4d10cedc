# rtuscope_warnings: the warnings the project's own code compiles with, errors too with
# RTUSCOPE_WERROR. Linked PRIVATE by each target, so they never reach a user of the library.
option(RTUSCOPE_WERROR "Treat warnings as errors" OFF)
add_library(rtuscope_warnings INTERFACE)
target_compile_options(rtuscope_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion
  $<$<BOOL:${RTUSCOPE_WERROR}>:-Werror>)
