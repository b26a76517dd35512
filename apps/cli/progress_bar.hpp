#pragma once
// Progress of a long run on standard error: the steps done (frames of a sequence, repeats of the depths pass),
// the stage the work is in and how far it has come (work_progress.hpp), and an estimate of the time left.
// Drawn only on a terminal, never into logs or pipes. A thread of the bar's own redraws the line a few times a
// second from the counts; the work only counts, at a coarse grain, and counts nothing when nothing is drawn.
#include <smoketrace/core/work_progress.hpp>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <vector>
#include <sys/ioctl.h>
#include <unistd.h>

namespace smoketrace::cli {

inline bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

// Columns of the terminal `out` is, 0 when unknown: a line longer than the terminal wraps, and "\r" then
// returns only to the start of its last row, leaving the others behind.
inline unsigned terminal_columns(std::FILE* out) {
    struct winsize size{};
    if (::ioctl(::fileno(out), TIOCGWINSZ, &size) != 0) return 0;
    return size.ws_col;
}

// "12 s", "3 min 05 s", "2 h 04 min": the estimate's own precision.
inline std::string shown_duration(double seconds) {
    const auto s = static_cast<long long>(seconds + 0.5);
    char text[48];
    if (s < 60)
        std::snprintf(text, sizeof text, "%lld s", s);
    else if (s < 3600)
        std::snprintf(text, sizeof text, "%lld min %02lld s", s / 60, s % 60);
    else
        std::snprintf(text, sizeof text, "%lld h %02lld min", s / 3600, (s % 3600) / 60);
    return text;
}

class ProgressBar {
public:
    // `steps`: the steps of the run, each named `unit` ("frame"); `on_terminal`: whether to draw at all (the
    // check is the caller's, so that a test can give it); `out`: where to draw.
    ProgressBar(std::uint64_t steps, const char* unit, bool on_terminal = stderr_is_terminal(), std::FILE* out = stderr)
        : steps_(steps), unit_(unit), enabled_(on_terminal), out_(out), start_(Clock::now()), step_end_(start_) {
        if (!enabled_) return;
        columns_ = terminal_columns(out_);
        // A quarter of a narrow terminal, so that the words after the bar still show.
        if (columns_ > 0) width_ = std::clamp(int(columns_ / 4), kMinWidth, kMaxWidth);
        draw();
        redraw_ = std::thread([this] {
            std::unique_lock lock(mutex_);
            while (!stop_.wait_for(lock, kRedrawInterval, [this] { return stopping_; })) draw_locked();
        });
    }
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;
    ~ProgressBar() { finish(); }

    // Where the work counts its stages; null when nothing is drawn.
    [[nodiscard]] WorkProgress* work() { return enabled_ ? &work_ : nullptr; }

    // One step is done.
    void step() {
        std::lock_guard lock(mutex_);
        ++done_;
        step_end_ = Clock::now();
        if (enabled_) draw_locked();
    }
    // Clears the bar's line for a line of text (the next redraw brings the bar back below it): standard output
    // and standard error are often the same terminal.
    void clear_line() {
        std::lock_guard lock(mutex_);
        if (!enabled_) return;
        std::fputs("\r\033[K", out_);
        std::fflush(out_);
    }
    // The run is over: the line is cleared, so that what the command prints next starts on a clean line.
    void finish() {
        {
            std::lock_guard lock(mutex_);
            if (!enabled_) return;
            enabled_ = false;
            stopping_ = true;
        }
        stop_.notify_all();
        redraw_.join();
        std::fputs("\r\033[K", out_);
        std::fflush(out_);
    }

private:
    using Clock = std::chrono::steady_clock;
    // Often enough to look alive, rarely enough to cost nothing.
    static constexpr auto kRedrawInterval = std::chrono::milliseconds(200);
    static constexpr int kMaxWidth = 30, kMinWidth = 8;

    static double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

    void draw() {
        std::lock_guard lock(mutex_);
        draw_locked();
    }

    void draw_locked() {
        const auto now = Clock::now();
        const char* stage = work_.stage();
        const std::uint64_t done = work_.done(), total = work_.total();
        // A new stage (or the same one again in the next frame, its count started over): its clock restarts.
        if (stage != stage_ || done < stage_done_) stage_start_ = now;
        stage_ = stage;
        stage_done_ = done;
        const double stage_fraction = total > 0 ? double(std::min(done, total)) / double(total) : 0.0;

        // The parts of the line, joined by ", " (appended piece by piece: GCC 12 warns falsely, -Wrestrict,
        // on " " + std::to_string(…)).
        std::vector<std::string> parts;
        if (steps_ > 1)
            parts.push_back(
                std::to_string(done_).append("/").append(std::to_string(steps_)).append(" ").append(unit_).append("s"));
        if (stage) {
            parts.emplace_back(stage);
            if (total > 0) parts.back().append(" ").append(std::to_string(int(100.0 * stage_fraction))).append("%");
        }
        // The time left: from the steps done when there are some, else from the current stage's rate (the
        // stage is all that is known of a run's first step).
        if (done_ > 0 && done_ < steps_) {
            const double per_step = seconds(step_end_ - start_) / double(done_);
            const double left = per_step * double(steps_ - done_) - seconds(now - step_end_);
            parts.push_back(std::string("~").append(shown_duration(left > 0.0 ? left : 0.0)).append(" left"));
        } else if (done_ == 0 && total > 0 && done > 0 && done < total) {
            const double left = seconds(now - stage_start_) * double(total - done) / double(done);
            parts.push_back(std::string("~").append(shown_duration(left)).append(" left in ").append(stage));
        }
        parts.push_back(shown_duration(seconds(now - start_)) + " so far");

        const double bar = steps_ > 1 ? double(done_) / double(steps_) : stage_fraction;
        const int filled = int(width_ * bar);
        std::string line = "\r[";
        line.append(std::size_t(filled), '#').append(std::size_t(width_ - filled), ' ').append("] ");
        for (std::size_t i = 0; i < parts.size(); ++i) line.append(i ? ", " : "").append(parts[i]);
        if (columns_ > 1 && line.size() > columns_) line.resize(columns_);  // "\r" and columns_ - 1 characters
        line.append("\033[K");
        std::fputs(line.c_str(), out_);
        std::fflush(out_);
    }

    const std::uint64_t steps_;
    const char* const unit_;
    bool enabled_;
    std::FILE* const out_;
    WorkProgress work_;
    const Clock::time_point start_;
    unsigned columns_ = 0;
    int width_ = kMaxWidth;  // of the bar
    std::mutex mutex_;
    std::condition_variable stop_;
    bool stopping_ = false;
    std::thread redraw_;
    // Under mutex_:
    std::uint64_t done_ = 0;
    Clock::time_point step_end_;
    const char* stage_ = nullptr;
    std::uint64_t stage_done_ = 0;
    Clock::time_point stage_start_ = start_;
};

}  // namespace smoketrace::cli
