#pragma once
// A progress bar on stderr for sequences, drawn only when stderr is a terminal (never into logs or pipes).
#include <cstdio>
#include <unistd.h>

namespace smoketrace::cli {

class ProgressBar {
public:
    explicit ProgressBar(unsigned total) : total_(total), enabled_(total > 1 && ::isatty(STDERR_FILENO)) { draw(); }
    void step() {
        ++done_;
        draw();
    }
    void finish() {
        if (enabled_) std::fputc('\n', stderr);
        enabled_ = false;
    }

private:
    void draw() const {
        if (!enabled_) return;
        constexpr int kWidth = 40;
        const int filled = total_ ? int(kWidth * done_ / total_) : kWidth;
        std::fprintf(stderr, "\r[%.*s%*s] %u/%u", filled, "########################################", kWidth - filled, "",
                     done_, total_);
        std::fflush(stderr);
    }
    unsigned total_, done_ = 0;
    bool enabled_;
};

}  // namespace smoketrace::cli
