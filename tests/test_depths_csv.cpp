// The optical depths' CSV (depths_csv.hpp): the shortest text that reads back as each float, for every kind of
// float, across the blocks formatted in parallel.
#include <smoketrace/io/depths_csv.hpp>
#include <smoketrace/core/prng.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

using namespace smoketrace;

namespace {

std::string joined(const std::vector<std::string>& pieces) {
    std::string out;
    for (const std::string& p : pieces) out += p;
    return out;
}

// The length of the shortest text of f that reads back as f, found by trying printf's two forms at every
// precision: %e with 1, 2, … significant digits and %f with 0, 1, … decimals (at most 60: enough for any float
// in %e, and %f is shorter only for numbers not far from 1).
std::size_t shortest_length(float f) {
    std::size_t best = std::string::npos;
    char text[128];
    for (int d = 0; d < 9; ++d) {
        const int n = std::snprintf(text, sizeof text, "%.*e", d, double(f));
        if (std::strtof(text, nullptr) == f) {
            best = std::size_t(n);
            break;
        }
    }
    for (int d = 0; d <= 60; ++d) {
        const int n = std::snprintf(text, sizeof text, "%.*f", d, double(f));
        if (std::strtof(text, nullptr) == f) {
            best = std::min(best, std::size_t(n));
            break;
        }
    }
    return best;
}

}  // namespace

// Each length is the shortest text that reads back as the same float: it reads back bit for bit, and no
// shorter text of printf's does (found independently by trying every precision). "%.9g" wrote 0.349999994
// for 0.35f. Checked over every kind of float and across the blocks formatted in parallel.
TEST_CASE("depths CSV: each length is the shortest text that reads back as the same float", "[depths_csv]") {
    std::vector<float> lengths = {0.0f, std::numeric_limits<float>::denorm_min(),
                                  std::numeric_limits<float>::min(), std::numeric_limits<float>::max(),
                                  1.0f, 0.1f, 0.35f, 1e-5f, 1e-4f, 123456789.0f, 1e9f, 999999999.0f, 99999.9999f, 0.5f,
                                  3.0e-39f, 1.17549435e-38f, 16777216.0f, 4294967296.0f};
    // Random bit patterns (every exponent, subnormals included) and typical lengths (0 … 100).
    Pcg32 rng(12, 0);
    while (lengths.size() < 40000) {
        const float bits = std::abs(std::bit_cast<float>(rng.next_u32()));
        if (std::isfinite(bits)) lengths.push_back(bits);
        lengths.push_back(float(rng.next_u32() % 100000) * 0.001f + float(rng.next_u32() % 1000) * 1e-7f);
    }
    lengths.push_back(std::numeric_limits<float>::infinity());  // occluded or cut off
    std::vector<std::uint32_t> hits(lengths.size());
    std::vector<DepthStatus> status(lengths.size());
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        hits[i] = i % 3 == 0 ? std::numeric_limits<std::uint32_t>::max() - std::uint32_t(i) : std::uint32_t(i % 200);
        status[i] = DepthStatus(i % 3);
    }
    static const char* const kNames[] = {"ok", "occluded", "cutoff"};
    std::istringstream csv(joined(format_depths_csv(lengths, hits, status)));
    std::string line;
    REQUIRE(std::getline(csv, line));
    CHECK(line == "particle,optical_path_length,hits,status");
    std::size_t rows = 0;
    for (std::size_t i = 0; std::getline(csv, line); ++i, ++rows) {
        INFO("row " << i << ": " << line);
        REQUIRE(i < lengths.size());
        const auto a = line.find(','), b = line.find(',', a + 1), c = line.find(',', b + 1);
        REQUIRE(c != std::string::npos);
        CHECK(line.substr(0, a) == std::to_string(i));
        CHECK(line.substr(b + 1, c - b - 1) == std::to_string(hits[i]));
        CHECK(line.substr(c + 1) == kNames[int(status[i])]);
        const std::string field = line.substr(a + 1, b - a - 1);
        if (std::isinf(lengths[i])) {
            CHECK(field == "inf");
            continue;
        }
        char* end = nullptr;
        const float back = std::strtof(field.c_str(), &end);
        CHECK(end == field.c_str() + field.size());
        CHECK(std::bit_cast<std::uint32_t>(back) == std::bit_cast<std::uint32_t>(lengths[i]));
        CHECK(field.size() == shortest_length(lengths[i]));
    }
    CHECK(rows == lengths.size());
    // What a scene file's numbers give back: the text a person wrote.
    const auto one = [](float f) {
        const std::vector<float> l{f};
        const std::vector<std::uint32_t> h{1};
        const std::vector<DepthStatus> s{DepthStatus::ok};
        return joined(format_depths_csv(l, h, s)).substr(std::strlen("particle,optical_path_length,hits,status\n"));
    };
    CHECK(one(0.35f) == "0,0.35,1,ok\n");
    CHECK(one(0.1f) == "0,0.1,1,ok\n");
    CHECK(one(2.0f) == "0,2,1,ok\n");
    CHECK(one(0.0f) == "0,0,1,ok\n");
}

TEST_CASE("depths CSV: no particles is the header alone", "[depths_csv]") {
    CHECK(joined(format_depths_csv({}, {}, {})) == "particle,optical_path_length,hits,status\n");
}
