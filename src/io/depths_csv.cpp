// The optical depths as CSV (see depths_csv.hpp).
#include <smoketrace/io/depths_csv.hpp>

#include <tbb/parallel_for.h>

#include <charconv>
#include <cmath>
#include <cstring>

namespace smoketrace {

namespace {

// Rows per piece: enough that a task's overhead vanishes, few enough that two threads share the work evenly.
constexpr std::size_t kRowsPerPiece = 16384;
// The longest row: a 20-digit index, "-1.1754942e-38", a 10-digit count, "occluded", a double's shortest
// text (at most 24 characters), 4 commas and '\n'.
constexpr std::size_t kMaxRowChars = 96;
// A row of a million-particle run ("123456,0.05438399,10,ok\n"), to reserve each piece.
constexpr std::size_t kTypicalRowChars = 26;

std::string_view status_name(DepthStatus s) {
    switch (s) {
        case DepthStatus::ok: return "ok";
        case DepthStatus::occluded: return "occluded";
        case DepthStatus::cutoff: return "cutoff";
    }
    return "?";
}

char* append(char* out, std::string_view text) {
    std::memcpy(out, text.data(), text.size());
    return out + text.size();
}

// std::to_chars of the float itself writes the shortest text that reads back as the same float (0.35, not
// printf's "%.9g" 0.349999994), without the locale, the format parsing and the stream per row.
char* format_row(char* out, std::size_t index, float length, std::uint32_t hits, DepthStatus status,
                 const double* true_depth) {
    char* const end = out + kMaxRowChars;
    out = std::to_chars(out, end, index).ptr;
    *out++ = ',';
    if (std::isinf(length)) out = append(out, "inf");
    else out = std::to_chars(out, end, length).ptr;
    *out++ = ',';
    out = std::to_chars(out, end, hits).ptr;
    *out++ = ',';
    out = append(out, status_name(status));
    if (true_depth) {
        *out++ = ',';
        out = std::to_chars(out, end, *true_depth).ptr;
    }
    *out++ = '\n';
    return out;
}

}  // namespace

std::vector<std::string> format_depths_csv(std::span<const float> lengths, std::span<const std::uint32_t> hit_counts,
                                           std::span<const DepthStatus> status, std::span<const double> true_depths) {
    const std::size_t rows = lengths.size();
    std::vector<std::string> pieces(1 + (rows + kRowsPerPiece - 1) / kRowsPerPiece);
    pieces[0] = true_depths.empty() ? "particle,optical_path_length,hits,status\n"
                                    : "particle,optical_path_length,hits,status,true_optical_depth\n";
    tbb::parallel_for(std::size_t{1}, pieces.size(), [&](std::size_t p) {
        const std::size_t begin = (p - 1) * kRowsPerPiece, end = std::min(rows, begin + kRowsPerPiece);
        std::string& piece = pieces[p];
        piece.reserve((end - begin) * kTypicalRowChars);  // not resized to the longest rows: no 64 MB to clear
        char row[kMaxRowChars];
        for (std::size_t i = begin; i < end; ++i)
            piece.append(row, format_row(row, i, lengths[i], hit_counts[i], status[i],
                                                 true_depths.empty() ? nullptr : &true_depths[i]));
    });
    return pieces;
}

}  // namespace smoketrace
