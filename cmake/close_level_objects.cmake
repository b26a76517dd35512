# Closes one kernel level's objects on themselves (docs/simd.md, "One binary, every CPU"): links them into
# one relocatable object and gives every global symbol it defines a name of its own, `name.<level>`, but
# the kernels' entry points (instantiations over simd::Level, whose names already differ per level).
#
# Why: a kernel source compiled for AVX2 also emits its own copies of every inline function and template
# it uses (std::vector's, glm's, the trace headers'), under the same names as the baseline copies. The
# linker keeps one copy of each name, so without this the baseline path could run an AVX2 copy on a CPU
# without AVX2, or a level its neighbour's code. Renamed, each level calls only its own copies, and
# shares with the rest of the program only what it does not define (the baseline library, the C++ and
# TBB runtimes).
#
# cmake -DOBJECTS=a.o|b.o|... -DLEVEL=avx2 -DOUTPUT=out.o -DLINKER=ld -DNM=nm -DOBJCOPY=objcopy
#       -DREADELF=readelf -P this
cmake_minimum_required(VERSION 3.25)
foreach(v OBJECTS LEVEL OUTPUT LINKER NM OBJCOPY READELF)
  if(NOT DEFINED ${v} OR "${${v}}" STREQUAL "")
    message(FATAL_ERROR "close_level_objects: ${v} not given")
  endif()
endforeach()
string(REPLACE "|" ";" objects "${OBJECTS}")
set(joined "${OUTPUT}.joined.o")
execute_process(COMMAND ${LINKER} -r -o ${joined} ${objects} RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "close_level_objects: ${LINKER} -r failed: ${err}")
endif()
# The same symbol table twice, in its own order (-p): raw names, and demangled ones to tell the entry points.
foreach(form raw demangled)
  set(flag "")
  if(form STREQUAL "demangled")
    set(flag "-C")
  endif()
  execute_process(COMMAND ${NM} -p --defined-only --extern-only ${flag} ${joined}
                  OUTPUT_VARIABLE out RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "close_level_objects: ${NM} failed: ${err}")
  endif()
  string(REPLACE ";" "\\;" out "${out}")
  string(REPLACE "\n" ";" ${form} "${out}")
endforeach()
list(LENGTH raw count)
list(LENGTH demangled count_demangled)
if(NOT count EQUAL count_demangled)
  message(FATAL_ERROR "close_level_objects: ${NM} listed ${count} symbols, and ${count_demangled} demangled")
endif()
set(renames "")
set(kept 0)
math(EXPR last "${count} - 1")
foreach(i RANGE ${last})
  list(GET raw ${i} line)
  if(line STREQUAL "")
    continue()
  endif()
  list(GET demangled ${i} pretty)
  # nm -p: "<address> <type> <name>"; the name is the third field (mangled names have no spaces).
  string(REGEX REPLACE "^[0-9a-fA-F]* *[A-Za-z] " "" name "${line}")
  if(pretty MATCHES "<\\(smoketrace::simd::Level\\)[0-9]+>")
    math(EXPR kept "${kept} + 1")
  else()
    string(APPEND renames "${name} ${name}.${LEVEL}\n")
  endif()
endforeach()
# The COMDAT groups too: the linker keeps one group per signature name, and a signature may be a local
# symbol (GCC's D5/C5 groups of a class's destructors and constructors), which the list above lacks. Left
# with its name, a level's group would be dropped for the baseline's, and the level's renamed symbols in it
# with the group.
execute_process(COMMAND ${READELF} -gW ${joined} OUTPUT_VARIABLE groups RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "close_level_objects: ${READELF} failed: ${err}")
endif()
string(REGEX MATCHALL "COMDAT group section \\[ *[0-9]+\\] `[^']*' \\[[^]]*\\]" lines "${groups}")
foreach(line IN LISTS lines)
  string(REGEX REPLACE ".*\\[([^]]*)\\]$" "\\1" signature "${line}")
  string(FIND "${renames}" "\n${signature} " at)
  string(FIND "${renames}" "${signature} " at_start)
  if(at EQUAL -1 AND NOT at_start EQUAL 0 AND NOT signature MATCHES "ILNS[0-9A-Z_]*4simd5LevelE[0-9]+E")
    string(APPEND renames "${signature} ${signature}.${LEVEL}\n")
  endif()
endforeach()
if(kept EQUAL 0)
  message(FATAL_ERROR "close_level_objects: no kernel entry point (a function over simd::Level) in ${OBJECTS}")
endif()
file(WRITE "${OUTPUT}.renames" "${renames}")
execute_process(COMMAND ${OBJCOPY} --redefine-syms=${OUTPUT}.renames ${joined} ${OUTPUT}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "close_level_objects: ${OBJCOPY} failed: ${err}")
endif()
file(REMOVE ${joined})
