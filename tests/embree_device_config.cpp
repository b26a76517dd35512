// The bench's Embree device string (bench/embree_device.hpp, SMOKETRACE_EMBREE_CONFIG): a kernel level Embree
// does not know, which Embree itself would take and run at SSE2, and a string Embree refuses both give an
// error naming the variable, the string and the problem; a good string gives a device.
#include "../bench/embree_device.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>
#include <stdexcept>
#include <string>

using smoketrace::bench::bench_embree_device;
using smoketrace::bench::embree_config_problem;
using smoketrace::bench::kEmbreeConfigVariable;

namespace {

// Sets the variable for one scope and puts back what was there.
struct ScopedVariable {
    std::string old;
    bool had = false;
    explicit ScopedVariable(const char* value) {
        if (const char* v = std::getenv(kEmbreeConfigVariable)) {
            old = v;
            had = true;
        }
        ::setenv(kEmbreeConfigVariable, value, 1);
    }
    ScopedVariable(const ScopedVariable&) = delete;
    ScopedVariable& operator=(const ScopedVariable&) = delete;
    ~ScopedVariable() {
        if (had) ::setenv(kEmbreeConfigVariable, old.c_str(), 1);
        else ::unsetenv(kEmbreeConfigVariable);
    }
};

std::string device_error(const char* config) {
    const ScopedVariable variable(config);
    try {
        (void)bench_embree_device();
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("embree config: isa= and max_isa= take only the kernel levels Embree knows", "[embree][config]") {
    for (const char* good : {"isa=avx2", "isa=AVX2", "max_isa = sse4.2", "threads=1,isa=sse2", "isa=avx512 verbose=0",
                             "hugepages=1", "", "ISA=anything"}) {  // (Embree's keys are case-sensitive)
        INFO(good);
        CHECK(embree_config_problem(good).empty());
    }
    const std::string problem = embree_config_problem("threads=1,isa=avx3");
    CHECK_THAT(problem, Catch::StartsWith("isa=avx3 is not a kernel level Embree 3 knows"));
    CHECK_THAT(problem, Catch::Contains("avx2"));
    CHECK_THAT(embree_config_problem("max_isa=AVX2X"), Catch::StartsWith("max_isa=AVX2X is not"));
    CHECK_THAT(embree_config_problem("isa="), Catch::StartsWith("isa= is not"));
}

TEST_CASE("embree config: a bad SMOKETRACE_EMBREE_CONFIG is an error naming it, a good one gives a device",
          "[embree][config]") {
    const std::string unknown_level = device_error("isa=avx3");
    CHECK_THAT(unknown_level, Catch::StartsWith(std::string(kEmbreeConfigVariable) + "=\"isa=avx3\": isa=avx3 is not"));

    // A value Embree cannot parse: its own error, through rtcGetDeviceError.
    const std::string refused = device_error("threads=x");
    CHECK_THAT(refused,
               Catch::StartsWith(std::string(kEmbreeConfigVariable) + "=\"threads=x\": embree: rtcNewDevice("));
    CHECK_THAT(refused, Catch::Contains("failed: RTC_ERROR_"));

    CHECK(device_error("isa=sse2,threads=1").empty());
    CHECK(device_error("").empty());  // empty: Embree's defaults
}
