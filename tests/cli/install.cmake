# `cmake --install` into a fresh prefix, then (with DEB set) `cpack` into a fresh directory:
# the binary, the man page and the bundled profiles' documentation must land where a user
# and man(1) look for them, and the installed binary must run.
#   cmake -DBUILD_DIR=... -DWORK_DIR=... -DVERSION=... [-DDEB=1] -P install.cmake
set(files bin/rtuscope share/man/man1/rtuscope.1 share/doc/rtuscope/README.md
          share/doc/rtuscope/formats.md share/doc/rtuscope/profiles.md
          share/doc/rtuscope/profiles/README.md share/doc/rtuscope/profiles/pdu485.toml
          share/doc/rtuscope/profiles/sensor-analyser.toml
          share/doc/rtuscope/profiles/zb-uvi485.toml share/doc/rtuscope/profiles/zyi-relay.toml
          share/doc/rtuscope/third_party/uplot/LICENSE)
file(REMOVE_RECURSE ${WORK_DIR})

if(NOT DEB)
  execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}
    RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE errors)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "cmake --install failed (${rc}): ${errors}")
  endif()
  foreach(file IN LISTS files)
    if(NOT EXISTS ${WORK_DIR}/${file})
      message(FATAL_ERROR "not installed: ${file}")
    endif()
  endforeach()
  execute_process(COMMAND ${WORK_DIR}/bin/rtuscope --version OUTPUT_VARIABLE out
    RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0 OR NOT out STREQUAL "rtuscope ${VERSION}\n")
    message(FATAL_ERROR "the installed binary says \"${out}\" (exit ${rc})")
  endif()
  return()
endif()

execute_process(COMMAND cpack --config ${BUILD_DIR}/CPackConfig.cmake -B ${WORK_DIR}
  RESULT_VARIABLE rc OUTPUT_VARIABLE output ERROR_VARIABLE errors)
file(GLOB debs ${WORK_DIR}/rtuscope_${VERSION}_*.deb)
if(NOT rc EQUAL 0 OR NOT debs)
  message(FATAL_ERROR "cpack made no .deb (${rc}): ${output}${errors}")
endif()
execute_process(COMMAND dpkg-deb --contents ${debs} OUTPUT_VARIABLE contents)
execute_process(COMMAND dpkg-deb --field ${debs} Package Version Depends OUTPUT_VARIABLE fields)
foreach(file IN LISTS files)
  string(FIND "${contents}" " ./usr/${file}\n" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "not in the package: /usr/${file}\n${contents}")
  endif()
endforeach()
if(NOT fields MATCHES "Package: rtuscope\nVersion: ${VERSION}\nDepends: [^\n]*libmodbus")
  message(FATAL_ERROR "package fields:\n${fields}")
endif()
