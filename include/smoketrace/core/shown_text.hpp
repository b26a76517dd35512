#pragma once
// Text that came from input (a scene key or value, a path, a command-line argument) as a message repeats it:
// a message goes to a terminal, and input must not be able to drive that terminal (an escape sequence in a
// scene key), cut the message short (a NUL) or flood it. Every message that repeats input passes it here.
#include <cstddef>
#include <string>
#include <string_view>

namespace smoketrace {

// Longest shown scene key or value, in bytes of the shown text: enough to recognise it.
inline constexpr std::size_t kMaxShownValueBytes = 60;
// Longest shown path or command-line argument: the user must recognise the whole name they typed, and a
// path is rarely longer; an argument of 100 kB is shown by its start.
inline constexpr std::size_t kMaxShownPathBytes = 1024;
// No cap: a whole message, whose parts were capped where they were put in.
inline constexpr std::size_t kShownUncapped = std::string_view::npos;

// `text` with every byte a terminal would act on written out: control characters (C0, DEL, C1) and the
// bidirectional overrides as JSON writes them ("\u001b", "\n"), a byte that is not UTF-8 as "\xff". Printable
// UTF-8 (and '\\') is kept as it is, so that shown text passes through again unchanged. Past `max_bytes` of
// shown text the rest is cut at a character boundary and "..." appended.
[[nodiscard]] std::string shown_text(std::string_view text, std::size_t max_bytes = kMaxShownValueBytes);

}  // namespace smoketrace
