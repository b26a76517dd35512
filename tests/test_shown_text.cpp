// shown_text() (core/shown_text.hpp): input as a message repeats it, with what a terminal would act on written
// out, and capped at whole characters.
#include <smoketrace/core/shown_text.hpp>

#include <catch2/catch.hpp>

#include <string>

using smoketrace::kShownUncapped;
using smoketrace::shown_text;

TEST_CASE("shown text: control characters as JSON writes them, printable UTF-8 as it is", "[shown_text]") {
    CHECK(shown_text("a\x1b[2Jb") == "a\\u001b[2Jb");
    CHECK(shown_text(std::string("a\0b", 3)) == "a\\u0000b");  // a NUL no longer ends the message
    CHECK(shown_text("\n\t\r\b\f") == "\\n\\t\\r\\b\\f");
    CHECK(shown_text("\x7f") == "\\u007f");
    CHECK(shown_text("\xc2\x9b" "31m") == "\\u009b31m");           // C1 CSI, valid UTF-8
    CHECK(shown_text("ab\xe2\x80\xae" "cd") == "ab\\u202ecd");     // RIGHT-TO-LEFT OVERRIDE
    CHECK(shown_text("caf\xc3\xa9 \xe2\x80\xa6 \xf0\x9f\x94\xa5") == "caf\xc3\xa9 \xe2\x80\xa6 \xf0\x9f\x94\xa5");
    CHECK(shown_text("C:\\dir\\u001b") == "C:\\dir\\u001b");       // a backslash is kept
}

TEST_CASE("shown text: bytes that are not UTF-8, one by one", "[shown_text]") {
    CHECK(shown_text("x\xffy") == "x\\xffy");
    CHECK(shown_text("\xc0\xaf") == "\\xc0\\xaf");          // overlong '/'
    CHECK(shown_text("\xed\xa0\x80") == "\\xed\\xa0\\x80");  // a surrogate
    CHECK(shown_text("\xe2\x82") == "\\xe2\\x82");          // cut short
    CHECK(shown_text("\xf4\x90\x80\x80") == "\\xf4\\x90\\x80\\x80");  // beyond U+10FFFF
}

TEST_CASE("shown text: shown text passes through again unchanged", "[shown_text]") {
    for (const std::string& input : {std::string("a\x1b[2J\xff\xc2\x9b\n"), std::string("plain"), std::string()}) {
        const std::string once = shown_text(input, kShownUncapped);
        CHECK(shown_text(once, kShownUncapped) == once);
    }
}

TEST_CASE("shown text: capped at whole characters, with \"...\"", "[shown_text]") {
    CHECK(shown_text(std::string(10, 'a'), 10) == std::string(10, 'a'));  // fits: nothing cut
    CHECK(shown_text(std::string(11, 'a'), 10) == "aaaaaaa...");
    CHECK(shown_text(std::string(100000, 'a'), 10).size() == 10);
    // Five two-byte characters in 8 bytes: two of them and "...", never half of one.
    CHECK(shown_text("\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9", 8) == "\xc3\xa9\xc3\xa9...");
    // An escape is never cut either.
    CHECK(shown_text("ab\x01\x01", 8) == "ab...");
    CHECK(shown_text(std::string(100000, 'a'), kShownUncapped).size() == 100000);
}
