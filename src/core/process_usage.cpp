// The process's CPU time and page faults (see process_usage.hpp).
#include <smoketrace/core/process_usage.hpp>

#if defined(__unix__) || defined(__APPLE__)
#include <sys/resource.h>
#endif

namespace smoketrace {

ProcessUsage ProcessUsage::now() {
#if defined(__unix__) || defined(__APPLE__)
    rusage u{};
    if (::getrusage(RUSAGE_SELF, &u) != 0) return {};
    const auto ms = [](const timeval& t) { return double(t.tv_sec) * 1e3 + double(t.tv_usec) * 1e-3; };
    return {ms(u.ru_utime), ms(u.ru_stime), std::int64_t(u.ru_minflt), std::int64_t(u.ru_majflt)};
#else
    return {};
#endif
}

}  // namespace smoketrace
