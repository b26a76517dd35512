// The optical depths' CSV (depths_csv.hpp): std::to_chars must write the bytes printf's "%.9g" wrote, for every
// kind of float, across the blocks formatted in parallel.
#include <smoketrace/io/depths_csv.hpp>
#include <smoketrace/core/prng.hpp>

#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

using namespace smoketrace;

namespace {

// The CSV as `smoketrace depths` wrote it before std::to_chars: snprintf per value, "inf" for infinities.
std::string printf_csv(const std::vector<float>& lengths, const std::vector<std::uint32_t>& hits,
                       const std::vector<DepthStatus>& status) {
    static const char* const kNames[] = {"ok", "occluded", "cutoff"};
    std::string out = "particle,optical_path_length,hits,status\n";
    char buf[128];
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        char number[64];
        if (std::isinf(lengths[i])) std::snprintf(number, sizeof number, "inf");
        else std::snprintf(number, sizeof number, "%.9g", double(lengths[i]));
        std::snprintf(buf, sizeof buf, "%zu,%s,%u,%s\n", i, number, hits[i], kNames[int(status[i])]);
        out += buf;
    }
    return out;
}

std::string joined(const std::vector<std::string>& pieces) {
    std::string out;
    for (const std::string& p : pieces) out += p;
    return out;
}

}  // namespace

TEST_CASE("depths CSV: the bytes of %.9g for every kind of float, across parallel blocks", "[depths_csv]") {
    std::vector<float> lengths = {0.0f, -0.0f, std::numeric_limits<float>::denorm_min(),
                                  std::numeric_limits<float>::min(), std::numeric_limits<float>::max(),
                                  std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                                  1.0f, 0.1f, 1e-5f, 1e-4f, 123456789.0f, 1e9f, 999999999.0f, 99999.9999f, 0.5f,
                                  3.0e-39f, 1.17549435e-38f, 16777216.0f, 4294967296.0f};
    // Random bit patterns (every exponent, subnormals included) and typical lengths (0 … 100).
    Pcg32 rng(12, 0);
    while (lengths.size() < 40000) {
        const float bits = std::bit_cast<float>(rng.next_u32());
        if (std::isfinite(bits)) lengths.push_back(bits);
        lengths.push_back(float(rng.next_u32() % 100000) * 0.001f + float(rng.next_u32() % 1000) * 1e-7f);
    }
    std::vector<std::uint32_t> hits(lengths.size());
    std::vector<DepthStatus> status(lengths.size());
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        hits[i] = i % 3 == 0 ? std::numeric_limits<std::uint32_t>::max() - std::uint32_t(i) : std::uint32_t(i % 200);
        status[i] = DepthStatus(i % 3);
    }
    const std::string expected = printf_csv(lengths, hits, status);
    CHECK(joined(format_depths_csv(lengths, hits, status)) == expected);
    // Row by row too, so that a difference names its value.
    for (std::size_t i = 0; i < 20; ++i) {
        const std::vector<float> one{lengths[i]};
        const std::vector<std::uint32_t> one_hits{hits[i]};
        const std::vector<DepthStatus> one_status{status[i]};
        INFO("length " << double(lengths[i]));
        CHECK(joined(format_depths_csv(one, one_hits, one_status)) == printf_csv(one, one_hits, one_status));
    }
}

TEST_CASE("depths CSV: no particles is the header alone", "[depths_csv]") {
    CHECK(joined(format_depths_csv({}, {}, {})) == "particle,optical_path_length,hits,status\n");
}
