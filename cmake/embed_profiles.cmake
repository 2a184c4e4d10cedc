# Writes OUTPUT: a C++ include with each file of PROFILES (paths joined with |) as a raw
# string, so that the bundled profiles work from any directory. Run at build time whenever
# one changes.
string(REPLACE "|" ";" PROFILES "${PROFILES}")
set(content "// Generated from the bundled profiles by cmake/embed_profiles.cmake. Do not edit.\n")
string(APPEND content "struct BundledProfileFile {\n    const char* name;\n    const char* text;\n};\n")
string(APPEND content "const std::vector<BundledProfileFile> kBundledProfileFiles = {\n")
foreach(file IN LISTS PROFILES)
  file(READ ${file} text)
  get_filename_component(name ${file} NAME)
  string(FIND "${text}" ")rtuscope_profile\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${file} contains the raw-string delimiter")
  endif()
  string(APPEND content "    {\"${name}\", R\"rtuscope_profile(${text})rtuscope_profile\"},\n")
endforeach()
string(APPEND content "};\n")
file(WRITE ${OUTPUT}.tmp "${content}")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
