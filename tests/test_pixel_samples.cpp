// Where the samples of a pixel lie (pixel_samples.hpp): the centre for one sample, one sample per row and per
// column of the n × n grid for every n, the rotated grid for four, and the Hammersley net for powers of two.
#include <smoketrace/render/pixel_samples.hpp>

#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>
#include <vector>

using namespace smoketrace;

TEST_CASE("pixel samples: one sample is the pixel's centre, exactly", "[spp]") {
    const glm::vec2 o = subpixel_offset(0, 1);
    CHECK(o.x == 0.5f);
    CHECK(o.y == 0.5f);
    const PixelSamples one(1);
    CHECK(one.count() == 1);
    CHECK(one[0].x == 0.5f);
    CHECK(one[0].y == 0.5f);
}

TEST_CASE("pixel samples: four samples are the rotated grid", "[spp]") {
    // The radical inverses of 0, 1, 2, 3 are 0, 1/2, 1/4, 3/4: ranks 0, 2, 1, 3. Every value is exact in float.
    const glm::vec2 want[4] = {{0.125f, 0.125f}, {0.375f, 0.625f}, {0.625f, 0.375f}, {0.875f, 0.875f}};
    for (int i = 0; i < 4; ++i) {
        CAPTURE(i);
        CHECK(subpixel_offset(i, 4).x == want[i].x);
        CHECK(subpixel_offset(i, 4).y == want[i].y);
    }
}

TEST_CASE("pixel samples: every count up to kMaxSpp puts one sample in each row and column, inside the pixel",
          "[spp]") {
    for (int n = 1; n <= kMaxSpp; ++n) {
        CAPTURE(n);
        const PixelSamples samples(n);
        REQUIRE(samples.count() == n);
        std::vector<int> per_column(std::size_t(n), 0), per_row(std::size_t(n), 0);
        for (int i = 0; i < n; ++i) {
            CAPTURE(i);
            const glm::vec2 o = samples[i];
            CHECK(o.x == subpixel_offset(i, n).x);  // the table holds what the function gives
            CHECK(o.y == subpixel_offset(i, n).y);
            REQUIRE(o.x >= 0.0f);
            REQUIRE(o.x < 1.0f);
            REQUIRE(o.y >= 0.0f);
            REQUIRE(o.y < 1.0f);
            // At the centres of the grid's cells: (k + 0.5)/n, rounded once to float (relative error 2^-24; a
            // wrong k is off by 1/n, far beyond 1e-5).
            const int column = int(o.x * float(n)), row = int(o.y * float(n));
            CHECK(std::abs(o.x * float(n) - (float(column) + 0.5f)) < 1e-5f);
            CHECK(std::abs(o.y * float(n) - (float(row) + 0.5f)) < 1e-5f);
            CHECK(column == i);  // sample i in column i, in order
            ++per_column[std::size_t(column)];
            ++per_row[std::size_t(row)];
        }
        CHECK(per_column == std::vector<int>(std::size_t(n), 1));
        CHECK(per_row == std::vector<int>(std::size_t(n), 1));
    }
}

TEST_CASE("pixel samples: for a power of two every grid of as many equal cells holds one sample in each",
          "[spp]") {
    // The Hammersley set in base 2 is a (0, m, 2)-net: each of the 2^j × 2^(m−j) grids of 2^m cells holds
    // exactly one point per cell (Niederreiter 1992). Moving each point to the centre of its finest cell
    // keeps it in every coarser cell, so the property must hold for the pattern as it is.
    for (int m = 0; (1 << m) <= kMaxSpp; ++m) {
        const int n = 1 << m;
        for (int j = 0; j <= m; ++j) {
            CAPTURE(n, j);
            const int columns = 1 << j, rows = n >> j;
            std::vector<int> cells(std::size_t(n), 0);
            for (int i = 0; i < n; ++i) {
                const glm::vec2 o = subpixel_offset(i, n);
                ++cells[std::size_t(int(o.y * float(rows)) * columns + int(o.x * float(columns)))];
            }
            CHECK(cells == std::vector<int>(std::size_t(n), 1));
        }
    }
}

TEST_CASE("pixel samples: counts and indices out of range are refused", "[spp]") {
    CHECK_THROWS_AS(PixelSamples(0), std::invalid_argument);
    CHECK_THROWS_AS(PixelSamples(kMaxSpp + 1), std::invalid_argument);
    CHECK_THROWS_AS(subpixel_offset(0, 0), std::invalid_argument);
    CHECK_THROWS_AS(subpixel_offset(-1, 4), std::invalid_argument);
    CHECK_THROWS_AS(subpixel_offset(4, 4), std::invalid_argument);
}
