# Writes a C++ source holding the text of every shader in INPUTS ("|"-separated
# absolute paths) as raw string literals, for shaders/embedded_shaders.cc.
# Run by shaders/CMakeLists.txt with cmake -P; OUTPUT is in the build tree.
if(NOT DEFINED OUTPUT OR NOT DEFINED INPUTS)
  message(FATAL_ERROR "embed_shaders.cmake: OUTPUT and INPUTS must be set")
endif()
string(REPLACE "|" ";" inputs "${INPUTS}")

set(delimiter "mvbrdf_glsl")
set(content "// Generated from shaders/*.glsl|vert|frag by shaders/embed_shaders.cmake. Do not edit.\n")
string(APPEND content "#include \"shaders/embedded_shaders.h\"\n\n")
string(APPEND content "namespace mvbrdf::shaders::internal {\n\n")
string(APPEND content "const EmbeddedShader kEmbeddedShaders[] = {\n")
set(count 0)
foreach(path IN LISTS inputs)
  get_filename_component(name "${path}" NAME)
  file(READ "${path}" text)
  string(FIND "${text}" ")${delimiter}\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${path} contains the raw-string delimiter )${delimiter}\"")
  endif()
  string(APPEND content "    {\"${name}\", R\"${delimiter}(${text})${delimiter}\"},\n")
  math(EXPR count "${count} + 1")
endforeach()
string(APPEND content "};\n\n")
string(APPEND content "const int kNumEmbeddedShaders = ${count};\n\n")
string(APPEND content "}  // namespace mvbrdf::shaders::internal\n")

# Only touch the output when it changes, so an unchanged shader set does not
# recompile dependants.
file(WRITE "${OUTPUT}.tmp" "${content}")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
