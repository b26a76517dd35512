#pragma once
// --threads T: caps TBB's worker count for the lifetime of the object (0 = all cores).
#include <tbb/global_control.h>

#include <memory>

namespace smoketrace::cli {

class ThreadLimit {
public:
    explicit ThreadLimit(int threads) {
        if (threads > 0)
            control_ = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                             static_cast<std::size_t>(threads));
    }

private:
    std::unique_ptr<tbb::global_control> control_;
};

}  // namespace smoketrace::cli
