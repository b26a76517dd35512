// The process's CPU time and page faults (core/process_usage.hpp) and how the stage reports carry them
// (core/frame_timings.hpp): what --timings prints beside each stage's wall time.
#include <smoketrace/core/frame_timings.hpp>
#include <smoketrace/core/huge_page_allocator.hpp>
#include <smoketrace/core/process_usage.hpp>

#include <catch2/catch.hpp>

#include <cstring>
#include <memory>

using namespace smoketrace;

TEST_CASE("process usage: writing fresh memory faults its pages in, and the counts only grow", "[timings]") {
    REQUIRE(kProcessUsageCounted);  // the systems this project builds on have getrusage()
    constexpr std::size_t kBytes = std::size_t{64} << 20;
    const ProcessUsage before = ProcessUsage::now();
    StageClock clock;
    {
        const std::unique_ptr<char[]> fresh(new char[kBytes]);  // above malloc's mmap threshold: new pages
        std::memset(fresh.get(), 1, kBytes);
        REQUIRE(fresh[kBytes - 1] == 1);
    }
    ProcessUsage lap;
    const double ms = clock.lap_ms(lap);
    const ProcessUsage total = ProcessUsage::now() - before;
    CHECK(ms >= 0.0);
    // At least a fault per page, and with transparent huge pages at least one per 2 MB.
    CHECK(lap.minor_faults >= std::int64_t(kBytes / kHugePageBytes));
    CHECK(lap.user_ms >= 0.0);
    CHECK(lap.system_ms >= 0.0);
    CHECK(lap.major_faults >= 0);
    // The lap lies inside [before, now]: it cannot have counted more.
    CHECK(total.minor_faults >= lap.minor_faults);
    CHECK(total.user_ms + total.system_ms >= lap.user_ms + lap.system_ms);
    // A second lap starts where the first ended.
    ProcessUsage second;
    (void)clock.lap_ms(second);
    CHECK(second.minor_faults < lap.minor_faults);
}

TEST_CASE("process usage: the stage lines, and their medians over frames", "[timings]") {
    CHECK(format_stage_usage("read_scene", ProcessUsage{1.5, 0.25, 12, 3}) ==
          "read_scene.user_ms=1.500\nread_scene.system_ms=0.250\nread_scene.minor_faults=12\n"
          "read_scene.major_faults=3\n");
    // Element-wise, the faults of an even count rounded to a whole page.
    std::vector<FrameTimings> frames(4);
    const std::int64_t faults[] = {40, 10, 30, 21};
    for (std::size_t i = 0; i < frames.size(); ++i) {
        frames[i].od_pass = double(i);
        frames[i].usage.od_pass = {double(10 - i), double(i), faults[i], std::int64_t(i % 2)};
        frames[i].usage.view.minor_faults = std::int64_t(100 * i);
    }
    const FrameTimings m = median(frames);
    CHECK(m.od_pass == 1.5);
    CHECK(m.usage.od_pass.user_ms == 8.5);
    CHECK(m.usage.od_pass.system_ms == 1.5);
    CHECK(m.usage.od_pass.minor_faults == 26);  // (21 + 30) / 2 = 25.5, rounded away from 0
    CHECK(m.usage.od_pass.major_faults == 1);   // (0 + 1) / 2 = 0.5
    CHECK(m.usage.view.minor_faults == 150);
    // format_usage() names the stages format_timings() does, in its order, each with its four counts.
    const std::string usage = format_usage(m, true);
    std::size_t at = 0;
    for (const char* stage : {"tlas_update", "od_pass", "resolve", "view", "total"}) {
        INFO(stage);
        at = usage.find(std::string(stage) + ".user_ms=", at);
        REQUIRE(at != std::string::npos);
    }
    CHECK(usage.find("od_pass.minor_faults=26\n") != std::string::npos);
    CHECK(format_usage(m, false).find("view.") == std::string::npos);
}
