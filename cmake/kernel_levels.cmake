# smoketrace_add_kernel_levels(<target> SOURCES <kernel sources...> LINK <libraries their headers need>)
#
# Compiles the kernel sources once more for each x86 kernel level above the baseline (AVX2: x86-64-v3,
# AVX-512: x86-64-v4), closes each level's objects on themselves (close_level_objects.cmake: every
# symbol renamed `name.<level>` but the kernels' entry points) and adds the result to <target>. The
# target then defines SMOKETRACE_DISPATCH (and SMOKETRACE_DISPATCH_AVX512), so that its entry points
# switch over the levels (core/simd/dispatch.hpp). The baseline copy of each kernel is <target>'s own.
set(SMOKETRACE_KERNEL_LEVEL_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/close_level_objects.cmake)
# The levels above the baseline, and the flags each is compiled with (core/simd/level.hpp names them).
set(SMOKETRACE_KERNEL_LEVELS avx2 avx512)
set(SMOKETRACE_KERNEL_LEVEL_FLAGS_avx2 -march=x86-64-v3)
set(SMOKETRACE_KERNEL_LEVEL_FLAGS_avx512 -march=x86-64-v4)

function(smoketrace_add_kernel_levels target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "SOURCES;LINK")
  if(NOT CMAKE_OBJCOPY OR NOT CMAKE_NM OR NOT CMAKE_LINKER OR NOT CMAKE_READELF)
    message(FATAL_ERROR "SMOKETRACE_DISPATCH needs ld, nm, objcopy and readelf (binutils); none found")
  endif()
  set(dispatch_definitions SMOKETRACE_DISPATCH=1 SMOKETRACE_DISPATCH_AVX512=1)
  target_compile_definitions(${target} PRIVATE ${dispatch_definitions})
  foreach(level IN LISTS SMOKETRACE_KERNEL_LEVELS)
    set(objects ${target}_kernels_${level})
    add_library(${objects} OBJECT ${arg_SOURCES})
    target_compile_options(${objects} PRIVATE ${SMOKETRACE_KERNEL_LEVEL_FLAGS_${level}})
    target_compile_definitions(${objects} PRIVATE ${dispatch_definitions}
      $<TARGET_PROPERTY:${target},COMPILE_DEFINITIONS>)
    target_include_directories(${objects} PRIVATE $<TARGET_PROPERTY:${target},INCLUDE_DIRECTORIES>)
    target_link_libraries(${objects} PRIVATE ${arg_LINK})
    set(closed ${CMAKE_CURRENT_BINARY_DIR}/${target}_kernels_${level}.o)
    add_custom_command(OUTPUT ${closed}
      COMMAND ${CMAKE_COMMAND} "-DOBJECTS=$<JOIN:$<TARGET_OBJECTS:${objects}>,|>" -DLEVEL=${level}
              -DOUTPUT=${closed} -DLINKER=${CMAKE_LINKER} -DNM=${CMAKE_NM} -DOBJCOPY=${CMAKE_OBJCOPY}
              -DREADELF=${CMAKE_READELF}
              -P ${SMOKETRACE_KERNEL_LEVEL_SCRIPT}
      DEPENDS ${objects} $<TARGET_OBJECTS:${objects}> ${SMOKETRACE_KERNEL_LEVEL_SCRIPT}
      COMMENT "Closing the ${level} kernels of ${target}"
      VERBATIM)
    set_source_files_properties(${closed} PROPERTIES EXTERNAL_OBJECT TRUE GENERATED TRUE)
    target_sources(${target} PRIVATE ${closed})
  endforeach()
endfunction()
