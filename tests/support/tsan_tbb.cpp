// ThreadSanitizer support for oneTBB (linked into smoketrace_tests only when SMOKETRACE_SANITIZE=thread).
//
// Why: Debian's libtbb is not built with -fsanitize=thread, so TSan cannot see how the scheduler hands a task
// from the thread that spawns it to the thread that runs it, nor how the waiting thread learns that the tasks
// have finished. Without that, every parallel_for looks racy: the workers read the scene the caller built
// before the loop, and the caller reads the results the workers wrote (hundreds of reports per test, all
// false). Suppressing them would hide every real race in the same code, so instead this file tells TSan
// about exactly those two hand-overs, per task and per wait, and nothing else:
//  * spawn → execute: r1::spawn (wrapped with the linker's --wrap) releases the task's address; the task's
//    vtable is swapped for a copy whose execute()/cancel() acquire that address before running the original
//    (a task derives from d1::task, whose virtual functions are the two destructors, execute and cancel);
//  * completion → return of the wait: with TBB_USE_PROFILING_TOOLS=2 (set for the whole TSan build) oneTBB's
//    headers report these points to r1::call_itt_notify (wait_context release / acquired after
//    execute_and_wait and wait, the reduction tree's fold, parallel_invoke's join), the hooks Intel Inspector
//    uses; the wrapper maps "releasing" and "acquired" to __tsan_release / __tsan_acquire on the same address.
//    A wait_context's counter (8 bytes in) is decremented just after that notification, and the waiting
//    thread's last read of it happens inside libtbb, so "acquired" also acquires the counter's address;
//    When a task threw, the wait rethrows before that notification: the wrappers of r1::execute_and_wait
//    and r1::wait acquire on that path themselves;
//  * memory reuse: oneTBB recycles task and tree-node memory through its own small-object pool, across
//    threads, and TSan would compare a new task with the accesses to the old one that lived in the same
//    block. AnnotateNewMemory on r1::allocate did not silence that with GCC 12's libtsan, so r1::deallocate
//    is wrapped to keep the block instead (a few hundred bytes per task; a test process spawns well under a
//    million tasks).
// All are happens-before edges the scheduler really provides. A race between two tasks, or between a task
// and code that does not wait for it, is still reported.
#include <oneapi/tbb/detail/_task.h>
#include <sanitizer/tsan_interface.h>

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <unordered_map>

namespace d1 = tbb::detail::d1;

extern "C" {
// The TSan runtime's dynamic annotations: the bookkeeping below must neither race nor synchronise.
void AnnotateIgnoreSyncBegin(const char* file, int line);
void AnnotateIgnoreSyncEnd(const char* file, int line);
void AnnotateIgnoreReadsBegin(const char* file, int line);
void AnnotateIgnoreReadsEnd(const char* file, int line);
void AnnotateIgnoreWritesBegin(const char* file, int line);
void AnnotateIgnoreWritesEnd(const char* file, int line);

// tbb::detail::r1::spawn(d1::task&, d1::task_group_context&) and the overload with a slot id;
// tbb::detail::r1::call_itt_notify(int, void*).
void __real__ZN3tbb6detail2r15spawnERNS0_2d14taskERNS2_18task_group_contextE(d1::task&, d1::task_group_context&);
void __real__ZN3tbb6detail2r15spawnERNS0_2d14taskERNS2_18task_group_contextEt(d1::task&, d1::task_group_context&,
                                                                              unsigned short);
void __real__ZN3tbb6detail2r116execute_and_waitERNS0_2d14taskERNS2_18task_group_contextERNS2_12wait_contextES6_(
    d1::task&, d1::task_group_context&, d1::wait_context&, d1::task_group_context&);
void __real__ZN3tbb6detail2r14waitERNS0_2d112wait_contextERNS2_18task_group_contextE(d1::wait_context&,
                                                                                     d1::task_group_context&);
}

namespace {

// Itanium C++ ABI vtable of d1::task: offset-to-top and typeinfo, then the complete and deleting
// destructors, execute and cancel. Derived tasks add no virtual functions.
constexpr int kHeader = 2, kSlots = 4, kExecute = 2, kCancel = 3;
using TaskFn = d1::task* (*)(d1::task*, d1::execution_data&);

struct PatchedVtable {
    void* entries[kHeader + kSlots];
    TaskFn execute;
    TaskFn cancel;
};

PatchedVtable& patched_of(d1::task* t) {
    void** vptr = *reinterpret_cast<void***>(t);
    return *reinterpret_cast<PatchedVtable*>(vptr - kHeader);
}

d1::task* execute_after_acquire(d1::task* t, d1::execution_data& ed) {
    __tsan_acquire(t);
    return patched_of(t).execute(t, ed);
}

d1::task* cancel_after_acquire(d1::task* t, d1::execution_data& ed) {
    __tsan_acquire(t);
    return patched_of(t).cancel(t, ed);
}

// One patched copy per task type (original vtable), created on first spawn and kept for the process.
void** patched_vptr(void** original) {
    static std::mutex mutex;
    static std::unordered_map<void**, PatchedVtable*> tables;
    std::lock_guard<std::mutex> lock(mutex);
    PatchedVtable*& p = tables[original];
    if (!p) {
        p = new PatchedVtable;
        for (int i = 0; i < kHeader + kSlots; ++i) p->entries[i] = original[i - kHeader];
        p->execute = reinterpret_cast<TaskFn>(original[kExecute]);
        p->cancel = reinterpret_cast<TaskFn>(original[kCancel]);
        p->entries[kHeader + kExecute] = reinterpret_cast<void*>(&execute_after_acquire);
        p->entries[kHeader + kCancel] = reinterpret_cast<void*>(&cancel_after_acquire);
    }
    return p->entries + kHeader;
}

void hand_over(d1::task& t) {
    AnnotateIgnoreSyncBegin(__FILE__, __LINE__);
    AnnotateIgnoreReadsBegin(__FILE__, __LINE__);
    AnnotateIgnoreWritesBegin(__FILE__, __LINE__);
    void*** vptr = reinterpret_cast<void***>(&t);
    if ((*vptr)[kExecute] != reinterpret_cast<void*>(&execute_after_acquire)) *vptr = patched_vptr(*vptr);
    AnnotateIgnoreWritesEnd(__FILE__, __LINE__);
    AnnotateIgnoreReadsEnd(__FILE__, __LINE__);
    AnnotateIgnoreSyncEnd(__FILE__, __LINE__);
    __tsan_release(&t);  // after the vtable swap: the swap itself is handed over too
}

}  // namespace

extern "C" {

void __wrap__ZN3tbb6detail2r15spawnERNS0_2d14taskERNS2_18task_group_contextE(d1::task& t, d1::task_group_context& ctx) {
    hand_over(t);
    __real__ZN3tbb6detail2r15spawnERNS0_2d14taskERNS2_18task_group_contextE(t, ctx);
}

void __wrap__ZN3tbb6detail2r15spawnERNS0_2d14taskERNS2_18task_group_contextEt(d1::task& t, d1::task_group_context& ctx,
                                                                              unsigned short slot) {
    hand_over(t);
    __real__ZN3tbb6detail2r15spawnERNS0_2d14taskERNS2_18task_group_contextEt(t, ctx, slot);
}

// oneTBB's notify types (profiling.h): prepare 0, cancel 1, acquired 2, releasing 3, destroy 4.
void __wrap__ZN3tbb6detail2r115call_itt_notifyEiPv(int type, void* ptr) {
    if (type == 3) {
        __tsan_release(ptr);
    } else if (type == 2) {
        __tsan_acquire(ptr);
        __tsan_acquire(static_cast<char*>(ptr) + sizeof(std::uint64_t));  // d1::wait_context::m_ref_count
    }
}

// tbb::detail::r1::execute_and_wait() and wait(): when a task threw, they rethrow its exception, and the
// header's "acquired" after them never runs; the tasks have all finished by then all the same (they refer to
// the waiting thread's stack), so the acquire is made here on that path.
void __wrap__ZN3tbb6detail2r116execute_and_waitERNS0_2d14taskERNS2_18task_group_contextERNS2_12wait_contextES6_(
    d1::task& t, d1::task_group_context& t_ctx, d1::wait_context& wait_ctx, d1::task_group_context& w_ctx) {
    try {
        __real__ZN3tbb6detail2r116execute_and_waitERNS0_2d14taskERNS2_18task_group_contextERNS2_12wait_contextES6_(
            t, t_ctx, wait_ctx, w_ctx);
    } catch (...) {
        __wrap__ZN3tbb6detail2r115call_itt_notifyEiPv(2, &wait_ctx);
        throw;
    }
}
void __wrap__ZN3tbb6detail2r14waitERNS0_2d112wait_contextERNS2_18task_group_contextE(d1::wait_context& wait_ctx,
                                                                                     d1::task_group_context& ctx) {
    try {
        __real__ZN3tbb6detail2r14waitERNS0_2d112wait_contextERNS2_18task_group_contextE(wait_ctx, ctx);
    } catch (...) {
        __wrap__ZN3tbb6detail2r115call_itt_notifyEiPv(2, &wait_ctx);
        throw;
    }
}

// tbb::detail::r1::deallocate(d1::small_object_pool&, void*, std::size_t[, const d1::execution_data&]): kept.
void __wrap__ZN3tbb6detail2r110deallocateERNS0_2d117small_object_poolEPvm(d1::small_object_pool&, void*, std::size_t) {}
void __wrap__ZN3tbb6detail2r110deallocateERNS0_2d117small_object_poolEPvmRKNS2_14execution_dataE(
    d1::small_object_pool&, void*, std::size_t, const d1::execution_data&) {}

}  // extern "C"
