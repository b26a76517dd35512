# The consumer tests of tests/install/CMakeLists.txt, as a CMake script (ctest runs it with -P).
# MODE=package: install, move, check and use the installed tree (with CMake and with pkg-config);
# MODE=subdirectory: configure a parent project that adds smoketrace with add_subdirectory(); MODE=readme:
# the README's hand-compile line against the build tree's library. WORK is this test's folder, emptied first.
cmake_minimum_required(VERSION 3.25)

function(run what)  # run(<what> COMMAND …): the command must exit 0; its output goes to WORK/<what>.log
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "WORKING_DIRECTORY" "COMMAND")
  if(NOT arg_WORKING_DIRECTORY)
    set(arg_WORKING_DIRECTORY "${WORK}")
  endif()
  string(REPLACE " " "_" log "${what}")
  execute_process(COMMAND ${arg_COMMAND} WORKING_DIRECTORY "${arg_WORKING_DIRECTORY}"
    RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  file(WRITE "${WORK}/${log}.log" "${out}${err}")
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "${what} failed (${code}):\n${out}${err}")
  endif()
  set(output "${out}" PARENT_SCOPE)
endfunction()

function(fail message)
  message(FATAL_ERROR "${message}")
endfunction()

# The same compiler and generator as this build; ccache too when this build uses it.
set(configure_args -G "${GENERATOR}" -DCMAKE_CXX_COMPILER=${CXX})
if(MAKE_PROGRAM)
  list(APPEND configure_args -DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM})
endif()
if(LAUNCHER)
  list(APPEND configure_args -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
# The build's configuration (empty for a single-configuration build without CMAKE_BUILD_TYPE).
set(config_args)
if(CONFIG)
  set(config_args --config "${CONFIG}")
endif()
# The installed command line and the downstream program must find their assets without help.
set(no_env ${CMAKE_COMMAND} -E env --unset=SMOKETRACE_ASSETS)

file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

# The README's line that compiles an example by hand, found by what it holds (`marker`), into `line`.
function(readme_line marker)
  file(STRINGS "${SOURCE_DIR}/README.md" lines REGEX "^g\\+\\+ ")
  foreach(l ${lines})
    string(FIND "${l}" "${marker}" at)
    if(NOT at EQUAL -1)
      set(line "${l}" PARENT_SCOPE)
      return()
    endif()
  endforeach()
  fail("README.md has no line 'g++ …' with '${marker}'")
endfunction()

# Every example but the Embree one, built with `command` (a README line, its example and program names
# swapped in; ccache in front when this build uses it) in `directory`, then run, its output checked.
function(build_and_run_examples what command directory)
  foreach(example minimal_trace optical_path_lengths render_frame)
    string(REPLACE "minimal_trace" "${example}" line "${command}")
    string(REPLACE "-o ${example}" "-o ${WORK}/${example}" line "${line}")
    if(LAUNCHER)
      string(REGEX REPLACE "^g\\+\\+ " "${LAUNCHER} g++ " line "${line}")
    endif()
    run("${what}: build ${example}" COMMAND sh -c "${line}" WORKING_DIRECTORY "${directory}")
  endforeach()
  run("${what}: run minimal_trace" COMMAND "${WORK}/minimal_trace")
  if(NOT output MATCHES "t=1.500 instance=0 enter.*t=8.500 instance=2 leave")
    fail("${what}: minimal_trace printed:\n${output}")
  endif()
  run("${what}: run optical_path_lengths" COMMAND "${WORK}/optical_path_lengths")
  if(NOT output MATCHES "all path lengths within 1e-4 of the chords")
    fail("${what}: optical_path_lengths printed:\n${output}")
  endif()
  run("${what}: run render_frame" COMMAND "${WORK}/render_frame" "${SOURCE_DIR}/assets/scenes/minimal.json"
    "${SOURCE_DIR}/assets" "${WORK}/frame.png" 16x12)
  file(READ "${WORK}/frame.png" signature LIMIT 8 HEX)
  if(NOT signature STREQUAL "89504e470d0a1a0a")
    fail("${what}: render_frame wrote no PNG (${WORK}/frame.png starts with ${signature})")
  endif()
  file(REMOVE "${WORK}/minimal_trace" "${WORK}/optical_path_lengths" "${WORK}/render_frame" "${WORK}/frame.png")
endfunction()

if(MODE STREQUAL "readme")
  # Run in the source tree as the README says, with this build's library in place of build/libsmoketrace.a.
  readme_line("build/libsmoketrace.a")
  # What the headers require of the code that includes them (docs/building.md), which a link cannot catch.
  foreach(flag "-std=c++20" "-DGLM_FORCE_XYZW_ONLY" "-ffp-contract=off")
    string(FIND "${line}" " ${flag} " at)
    if(at EQUAL -1)
      fail("the README's hand-compile line lacks ${flag}: ${line}")
    endif()
  endforeach()
  string(REPLACE "build/libsmoketrace.a" "${LIBRARY}" line "${line}")
  build_and_run_examples("README line" "${line}" "${SOURCE_DIR}")
  message(STATUS "the README's hand-compile line builds and runs every example")
  return()
endif()

if(MODE STREQUAL "subdirectory")
  run("configure the add_subdirectory project" COMMAND ${CMAKE_COMMAND} ${configure_args}
    -S "${SOURCE_DIR}/tests/install/subdirectory" -B "${WORK}/build" -DSMOKETRACE_SOURCE_DIR=${SOURCE_DIR})
  message(STATUS "add_subdirectory: configured with the library and the command line only")
  return()
endif()

if(NOT MODE STREQUAL "package")
  fail("run_install_test.cmake: MODE must be package or subdirectory")
endif()

# 1. Install, then move the tree: what follows uses it where no path compiled in could point.
run("cmake --install" COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" ${config_args} --prefix "${WORK}/installed")
file(RENAME "${WORK}/installed" "${WORK}/moved")
set(prefix "${WORK}/moved")

# 2. What the tree holds.
foreach(f ${LIBDIR}/libsmoketrace.a ${INCLUDEDIR}/smoketrace/trace/trace.hpp
          ${INCLUDEDIR}/smoketrace/smoke/optical_depth_pass.hpp ${BINDIR}/smoketrace
          ${DATADIR}/smoketrace/sixway.json ${DATADIR}/smoketrace/sixway_pos.png ${DATADIR}/smoketrace/sixway_neg.png
          ${DATADIR}/smoketrace/scenes/minimal.json ${LIBDIR}/cmake/smoketrace/smoketraceConfig.cmake
          ${LIBDIR}/cmake/smoketrace/smoketraceConfigVersion.cmake ${LIBDIR}/cmake/smoketrace/smoketraceTargets.cmake
          ${DOCDIR}/LICENSE)
  if(NOT EXISTS "${prefix}/${f}")
    fail("the installed tree has no ${f}")
  endif()
endforeach()
# No public header includes TBB (it is a private dependency).
file(GLOB_RECURSE headers "${prefix}/${INCLUDEDIR}/smoketrace/*.hpp")
foreach(h ${headers})
  file(STRINGS "${h}" tbb REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](tbb|oneapi)/")
  if(tbb)
    fail("${h} includes TBB: ${tbb}")
  endif()
endforeach()
# Nothing of the build machine in the package: no -march, no path of the source or build tree.
file(GLOB package_files "${prefix}/${LIBDIR}/cmake/smoketrace/*.cmake")
foreach(f ${package_files})
  file(READ "${f}" text)
  foreach(leak "-march" "${SOURCE_DIR}" "${BUILD_DIR}")
    string(FIND "${text}" "${leak}" at)
    if(NOT at EQUAL -1)
      fail("${f} contains '${leak}': the package must not depend on the build machine")
    endif()
  endforeach()
endforeach()
# The command line has no assets path compiled in.
string(REGEX REPLACE "([][+.*()^$?|\\])" "\\\\\\1" source_regex "${SOURCE_DIR}")
file(STRINGS "${prefix}/${BINDIR}/smoketrace" compiled_in REGEX "${source_regex}/assets")
if(compiled_in)
  fail("the installed smoketrace holds the source tree's path: ${compiled_in}")
endif()

# 3. The installed command line: its version, and a render that finds the textures beside it.
run("smoketrace --version" COMMAND "${prefix}/${BINDIR}/smoketrace" --version)
if(NOT output MATCHES "^smoketrace ${VERSION}\nkernels: [a-z0-9]+ \\(this binary: [a-z0-9, ]+\\)\n$")
  fail("smoketrace --version printed '${output}', expected 'smoketrace ${VERSION}' and its kernel levels")
endif()
run("smoketrace render" COMMAND ${no_env} "${prefix}/${BINDIR}/smoketrace" render
  "${prefix}/${DATADIR}/smoketrace/scenes/minimal.json" -o "${WORK}/cli.png" --size 32x24)
if(NOT EXISTS "${WORK}/cli.png")
  fail("the installed smoketrace render wrote no ${WORK}/cli.png")
endif()

# 4. A downstream project: find_package(smoketrace CONFIG REQUIRED), one .cpp, built and run.
run("configure the downstream project" COMMAND ${CMAKE_COMMAND} ${configure_args}
  -S "${SOURCE_DIR}/tests/install/downstream" -B "${WORK}/build" -DCMAKE_BUILD_TYPE=${CONFIG}
  -DCMAKE_PREFIX_PATH=${prefix} -DSMOKETRACE_EXPECTED_VERSION=${VERSION})
run("build the downstream project" COMMAND ${CMAKE_COMMAND} --build "${WORK}/build" ${config_args})
file(GLOB_RECURSE program "${WORK}/build/downstream" "${WORK}/build/*/downstream")
if(NOT program)
  fail("the downstream build made no program")
endif()
list(GET program 0 program)
run("run the downstream program" COMMAND ${no_env} "${program}")
if(NOT output MATCHES "downstream: ok")
  fail("the downstream program printed:\n${output}")
endif()
message(STATUS "${output}")

# 5. Without CMake: the README's pkg-config line, the installed (and moved) tree's smoketrace.pc.
if(NOT EXISTS "${prefix}/${LIBDIR}/pkgconfig/smoketrace.pc")
  fail("the installed tree has no ${LIBDIR}/pkgconfig/smoketrace.pc")
endif()
readme_line("pkg-config --cflags --libs smoketrace")
set(ENV{PKG_CONFIG_PATH} "${prefix}/${LIBDIR}/pkgconfig")
run("pkg-config" COMMAND pkg-config --cflags --libs smoketrace)
foreach(flag "-ffp-contract=off" "-DGLM_FORCE_XYZW_ONLY" "-lsmoketrace")
  string(FIND "${output}" "${flag}" at)
  if(at EQUAL -1)
    fail("pkg-config --cflags --libs smoketrace lacks ${flag}: ${output}")
  endif()
endforeach()
# The include path is the moved tree's, spelt from the .pc file's own folder (lib/pkgconfig/../../include).
string(REGEX MATCH "-I([^ \n]*/${INCLUDEDIR})[ \n]" include_flag "${output}")
file(REAL_PATH "${CMAKE_MATCH_1}" include_dir)
file(REAL_PATH "${prefix}/${INCLUDEDIR}" want_include_dir)
if(NOT include_flag OR NOT include_dir STREQUAL want_include_dir)
  fail("pkg-config --cflags smoketrace does not name the moved tree's ${INCLUDEDIR}: ${output}")
endif()
build_and_run_examples("pkg-config line" "${line}" "${SOURCE_DIR}")
message(STATUS "the README's pkg-config line builds and runs every example against the moved tree")
