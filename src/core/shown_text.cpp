#include <smoketrace/core/shown_text.hpp>

#include <cstdint>
#include <cstdio>

namespace smoketrace {

namespace {

// Length of the well-formed UTF-8 sequence at the start of `s` (RFC 3629: no overlong forms, no surrogates,
// nothing past U+10FFFF) and its code point; 0 when the first byte starts none.
std::size_t utf8_sequence(std::string_view s, char32_t& cp) {
    const auto b0 = static_cast<unsigned char>(s[0]);
    std::size_t n;
    char32_t lowest;
    if (b0 < 0x80) {
        cp = b0;
        return 1;
    }
    if (b0 >= 0xC2 && b0 <= 0xDF) n = 2, cp = b0 & 0x1Fu, lowest = 0x80;
    else if (b0 >= 0xE0 && b0 <= 0xEF) n = 3, cp = b0 & 0x0Fu, lowest = 0x800;
    else if (b0 >= 0xF0 && b0 <= 0xF4) n = 4, cp = b0 & 0x07u, lowest = 0x10000;
    else return 0;
    if (s.size() < n) return 0;
    for (std::size_t i = 1; i < n; ++i) {
        const auto b = static_cast<unsigned char>(s[i]);
        if ((b & 0xC0u) != 0x80u) return 0;
        cp = (cp << 6) | (b & 0x3Fu);
    }
    if (cp < lowest || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
    return n;
}

// A code point a terminal acts on instead of printing: C0 controls, DEL, C1 controls (0x9B is CSI on many
// terminals), and the bidirectional marks and overrides that reorder what follows them on the line.
bool acts_on_terminal(char32_t cp) {
    return cp < 0x20 || (cp >= 0x7F && cp < 0xA0) || cp == 0x200E || cp == 0x200F || (cp >= 0x202A && cp <= 0x202E) ||
           (cp >= 0x2066 && cp <= 0x2069);
}

std::string escaped(char32_t cp) {
    switch (cp) {
        case '\b': return "\\b";
        case '\f': return "\\f";
        case '\n': return "\\n";
        case '\r': return "\\r";
        case '\t': return "\\t";
        default: break;
    }
    char buffer[8];
    std::snprintf(buffer, sizeof buffer, "\\u%04x", unsigned(cp));
    return buffer;
}

}  // namespace

std::string shown_text(std::string_view text, std::size_t max_bytes) {
    static constexpr std::string_view kCut = "...";
    const std::size_t room_before_cut = max_bytes < kCut.size() ? 0 : max_bytes - kCut.size();
    std::string out;
    std::size_t cut_at = 0;  // the longest prefix of whole characters that leaves room for "..."
    for (std::size_t i = 0; i < text.size();) {
        char32_t cp = 0;
        const std::size_t n = utf8_sequence(text.substr(i), cp);
        if (n == 0) {
            char buffer[8];
            std::snprintf(buffer, sizeof buffer, "\\x%02x", unsigned(static_cast<unsigned char>(text[i])));
            out += buffer;
        } else if (acts_on_terminal(cp)) {
            out += escaped(cp);
        } else {
            out += text.substr(i, n);
        }
        i += n == 0 ? 1 : n;
        if (max_bytes == kShownUncapped) continue;
        if (out.size() > max_bytes) {
            out.resize(cut_at);
            return out.append(kCut);
        }
        if (out.size() <= room_before_cut) cut_at = out.size();
    }
    return out;
}

}  // namespace smoketrace
