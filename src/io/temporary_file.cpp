// Temporary files, listed where a signal handler can remove them (see temporary_file.hpp).
#include <smoketrace/io/temporary_file.hpp>

#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstring>
#include <ctime>
#include <fcntl.h>
#include <pthread.h>
#include <stdexcept>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

namespace smoketrace {

namespace fs = std::filesystem;

namespace {

// The signals that end a program by default and that a user or a scheduler sends to stop a run (or that
// a write itself raises: SIGPIPE, SIGXFSZ), and those of a crash or an abort() (std::terminate, a failed
// assertion): an error path too. SIGKILL cannot be caught: nothing can clean up after it.
constexpr std::array kSignals{SIGHUP, SIGINT, SIGQUIT, SIGTERM, SIGPIPE, SIGXCPU, SIGXFSZ,
                              SIGABRT, SIGBUS, SIGFPE, SIGILL, SIGSEGV};

// More temporary files than the program ever has at once (one per output being written, three for a
// six-way bake); a file that finds the table full is still removed on every error, only not on a signal.
constexpr int kSlots = 64;
// How long the handler waits for a thread that is creating a file or renaming a group (microseconds of
// work) before it removes what it can and lets the signal end the program: long enough for a loaded
// machine to schedule that thread, short enough that ^C still feels immediate should a file system hang.
constexpr long kBusyWaitNanoseconds = 1'000'000'000;

// A slot's states. free -> busy (a thread fills in the path, creates the file) -> listed -> free (renamed or
// removed by its owner), or listed -> taken (the handler removes it; the program is ending). A group's
// rename takes its slots listed -> busy -> free.
enum SlotState : int { kFree, kBusy, kListed, kTaken };

struct Slot {
    std::atomic<int> state{kFree};
    char path[PATH_MAX];  // the kernel takes no longer path, so a longer one cannot be created either
};
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler may use only lock-free atomics");

Slot g_slots[kSlots];

sigset_t handled_signals() {
    sigset_t set;
    sigemptyset(&set);
    for (const int s : kSignals) sigaddset(&set, s);
    return set;
}

// The handled signals held off in this thread for a scope, so that the handler never runs here while this
// thread has a slot busy (it would wait for itself); a signal sent meanwhile is delivered at the end.
struct HoldSignals {
    sigset_t old;
    HoldSignals() {
        const sigset_t set = handled_signals();
        pthread_sigmask(SIG_BLOCK, &set, &old);
    }
    ~HoldSignals() { pthread_sigmask(SIG_SETMASK, &old, nullptr); }
    HoldSignals(const HoldSignals&) = delete;
    HoldSignals& operator=(const HoldSignals&) = delete;
};

// A free slot, now busy; -1 when none is free.
int claim_slot() {
    for (int i = 0; i < kSlots; ++i) {
        int expected = kFree;
        if (g_slots[i].state.compare_exchange_strong(expected, kBusy)) return i;
    }
    return -1;
}

// listed -> free: the owner is done with the file. When the handler has taken it, it stays taken.
void unlist(int slot) {
    if (slot < 0) return;
    int expected = kListed;
    g_slots[slot].state.compare_exchange_strong(expected, kFree);
}

long elapsed_ns(const timespec& since) {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (now.tv_sec - since.tv_sec) * 1'000'000'000L + (now.tv_nsec - since.tv_nsec);
}

extern "C" void remove_and_raise_again(int signal) {
    const int saved = errno;
    remove_temporary_files();
    struct sigaction default_action{};
    default_action.sa_handler = SIG_DFL;
    sigemptyset(&default_action.sa_mask);
    sigaction(signal, &default_action, nullptr);
    // Blocked while this handler runs: delivered when it returns, now with the default action.
    raise(signal);
    errno = saved;
}

std::string errno_text(int e) { return std::strerror(e); }

}  // namespace

fs::path hidden_name_beside(const fs::path& file, std::string_view kind) {
    static std::atomic<unsigned> serial{0};
    const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
    std::string name(1, '.');
    name += file.filename().string().substr(0, 200);
    name += kind;
    name += std::to_string(::getpid());
    name += '-';
    name += std::to_string(serial.fetch_add(1));
    return folder / name;
}

TemporaryFile::~TemporaryFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!renamed_ && !path_.empty()) ::unlink(path_.c_str());
    unlist(slot_);
}

bool TemporaryFile::create(const fs::path& path) {
    const std::string& text = path.native();
    HoldSignals hold;
    slot_ = text.size() < PATH_MAX ? claim_slot() : -1;
    if (slot_ >= 0) std::memcpy(g_slots[slot_].path, text.c_str(), text.size() + 1);
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd_ < 0) {
        const int e = errno;
        if (slot_ >= 0) g_slots[slot_].state.store(kFree);
        slot_ = -1;
        errno = e;
        return false;
    }
    path_ = path;
    if (slot_ >= 0) g_slots[slot_].state.store(kListed);
    return true;
}

int TemporaryFile::close() {
    const int r = ::close(fd_);
    fd_ = -1;
    return r;
}

bool TemporaryFile::rename_to(const fs::path& target) {
    if (::rename(path_.c_str(), target.c_str()) != 0) return false;
    renamed_ = true;
    unlist(slot_);  // a handler that takes it first finds no file: the name is gone
    return true;
}

void rename_together(std::span<TemporaryFile* const> files, std::span<const fs::path> targets) {
    if (files.size() != targets.size()) throw std::invalid_argument("rename_together: one target per file");
    // Everything that allocates comes first, so that nothing below throws while slots are busy.
    std::vector<fs::path> names(files.size()), backups(files.size());
    std::vector<bool> existed(files.size());
    for (std::size_t i = 0; i < files.size(); ++i) names[i] = hidden_name_beside(targets[i], ".old");
    HoldSignals hold;
    // Busy: a handler running in another thread now waits until the group is in place or rolled back.
    for (TemporaryFile* f : files) {
        int expected = kListed;
        if (f->slot_ >= 0) g_slots[f->slot_].state.compare_exchange_strong(expected, kBusy);
    }
    // The old files stay reachable under a second name until every new one is in place.
    for (std::size_t i = 0; i < files.size(); ++i) {
        struct stat st{};
        existed[i] = ::lstat(targets[i].c_str(), &st) == 0;
        if (existed[i] && ::link(targets[i].c_str(), names[i].c_str()) == 0) backups[i].swap(names[i]);
    }
    std::size_t done = 0;
    int error = 0;
    for (; done < files.size(); ++done) {
        if (::rename(files[done]->path_.c_str(), targets[done].c_str()) != 0) {
            error = errno;
            break;
        }
        files[done]->renamed_ = true;
    }
    // After a failure the targets already replaced get their old files back; an old file that could not
    // be kept (a file system without hard links) or put back is left as it is now, and the message says so.
    std::string not_restored;
    if (error != 0) {
        for (std::size_t i = 0; i < done; ++i) {
            if (!existed[i]) {
                ::unlink(targets[i].c_str());
            } else if (backups[i].empty() || ::rename(backups[i].c_str(), targets[i].c_str()) != 0) {
                not_restored += (not_restored.empty() ? "" : ", ") + targets[i].string();
                if (!backups[i].empty()) not_restored += " (its old file is kept as " + backups[i].string() + ")";
                backups[i].clear();
            } else {
                backups[i].clear();
            }
        }
    }
    for (const fs::path& b : backups)
        if (!b.empty()) ::unlink(b.c_str());
    // Renamed files leave the table; the rest are listed again, for their destructors to remove.
    for (TemporaryFile* f : files) {
        int expected = kBusy;  // a slot the handler took before the group began stays taken
        if (f->slot_ >= 0) g_slots[f->slot_].state.compare_exchange_strong(expected, f->renamed_ ? kFree : kListed);
    }
    for (TemporaryFile* f : files)
        if (f->renamed_) f->slot_ = -1;
    if (error != 0)
        throw std::runtime_error(targets[done].string() + ": cannot rename into place (" + errno_text(error) + "); " +
                                 (not_restored.empty() ? std::string("the files of its group are left as they were")
                                                       : "could not put back the old " + not_restored));
}

void remove_temporary_files() noexcept {
    timespec start{};
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (Slot& slot : g_slots) {
        for (;;) {
            int state = slot.state.load();
            if (state == kListed) {
                if (slot.state.compare_exchange_strong(state, kTaken)) ::unlink(slot.path);
                else continue;  // its owner changed it meanwhile: look again
            } else if (state == kBusy && elapsed_ns(start) < kBusyWaitNanoseconds) {
                continue;
            }
            break;
        }
    }
}

void remove_temporary_files_on_signals() {
    struct sigaction action{};
    action.sa_handler = remove_and_raise_again;
    action.sa_mask = handled_signals();  // one handler at a time per thread
    action.sa_flags = SA_RESTART;
    for (const int s : kSignals) {
        struct sigaction old{};
        if (sigaction(s, nullptr, &old) != 0) continue;
        if ((old.sa_flags & SA_SIGINFO) == 0 && old.sa_handler == SIG_DFL) sigaction(s, &action, nullptr);
    }
}

}  // namespace smoketrace
