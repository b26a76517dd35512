cmake_minimum_required(VERSION 3.25)
# The README's C++ example must be examples/minimal_trace.cpp, byte for byte: the example is built and its
# output checked by ctest ("example: minimal_trace"), so a README that quotes it verbatim cannot go stale.
#   cmake -DREADME=README.md -DEXAMPLE=examples/minimal_trace.cpp -P readme_example_check.cmake
# Takes the first block fenced by a line "```cpp" and the next line "```", and fails naming the first line
# that differs. Works on whole strings, not CMake lists, so that the code's ';' and '[' stay as they are.
foreach(var README EXAMPLE)
  if(NOT DEFINED ${var} OR NOT EXISTS "${${var}}")
    message(FATAL_ERROR "readme_example_check: -D${var}=<file> is missing or names no file ('${${var}}')")
  endif()
endforeach()

file(READ "${README}" readme)
file(READ "${EXAMPLE}" example)

set(text "\n${readme}")  # so that a fence on the first line is at a line start too
set(open_fence "\n```cpp\n")
string(FIND "${text}" "${open_fence}" open_at)
if(open_at EQUAL -1)
  message(FATAL_ERROR "${README}: no ```cpp block; its first one must be ${EXAMPLE}")
endif()
string(LENGTH "${open_fence}" fence_length)
math(EXPR body_at "${open_at} + ${fence_length}")
string(SUBSTRING "${text}" ${body_at} -1 rest)
# The closing fence: "```" alone on a line (an empty block closes at once).
if(rest MATCHES "^```(\n|$)")
  set(block "")
else()
  string(FIND "${rest}" "\n```\n" close_at)
  if(close_at EQUAL -1)
    string(LENGTH "${rest}" rest_length)
    math(EXPR last_at "${rest_length} - 4")
    if(last_at GREATER_EQUAL 0)
      string(SUBSTRING "${rest}" ${last_at} -1 tail)
      if(tail STREQUAL "\n```")
        set(close_at ${last_at})
      endif()
    endif()
  endif()
  if(close_at EQUAL -1)
    message(FATAL_ERROR "${README}: the first ```cpp block is not closed by a line ```")
  endif()
  math(EXPR block_length "${close_at} + 1")  # keeps the block's last newline, as the file has it
  string(SUBSTRING "${rest}" 0 ${block_length} block)
endif()

if(block STREQUAL example)
  return()
endif()

# The first line that differs, for the message.
# Takes the first line of the text in `var` into `line_var` and leaves the rest in `var`; `end_var` is -1
# when that was the last line.
macro(pop_line var line_var end_var)
  string(FIND "${${var}}" "\n" ${end_var})
  if(${end_var} EQUAL -1)
    set(${line_var} "${${var}}")
    set(${var} "")
  else()
    string(SUBSTRING "${${var}}" 0 ${${end_var}} ${line_var})
    math(EXPR _next "${${end_var}} + 1")
    string(SUBSTRING "${${var}}" ${_next} -1 ${var})
  endif()
endmacro()
set(a "${block}")
set(b "${example}")
set(line 1)
while(TRUE)
  pop_line(a a_line a_end)
  pop_line(b b_line b_end)
  if(NOT a_line STREQUAL b_line OR (a_end EQUAL -1) OR (b_end EQUAL -1))
    break()
  endif()
  math(EXPR line "${line} + 1")
endwhile()
if(a_line STREQUAL b_line)
  set(detail "the two differ in length after line ${line} (a missing or extra line, or a final newline)")
else()
  # An empty last piece is the end of the text (after its final newline).
  if(a_end EQUAL -1 AND a_line STREQUAL "")
    set(a_line "(the block ends here)")
  endif()
  if(b_end EQUAL -1 AND b_line STREQUAL "")
    set(b_line "(the file ends here)")
  endif()
  set(detail "line ${line} of the block differs:\n  README:  ${a_line}\n  example: ${b_line}")
endif()
message(FATAL_ERROR "${README}: its first ```cpp block is not ${EXAMPLE} verbatim; ${detail}\n"
                    "Copy the example into the README (or change both), so that the README shows code that is built "
                    "and tested.")
