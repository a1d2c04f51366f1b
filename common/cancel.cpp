#include "common/cancel.h"

#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <vector>

namespace rocklab::common {
namespace {
// The file readers' hook of this thread (ThreadCancelScope) and the calls
// left before PollThreadCancel polls it.
thread_local const CancelHook* t_reader_cancel = nullptr;
thread_local unsigned t_reader_polls_left = kReadPollRows;
}  // namespace

CancelToken::CancelToken(CancelHook hook) : hook_(std::move(hook)), owner_(std::this_thread::get_id()) {}

bool CancelToken::Check() const {
  if (cancelled_.load(std::memory_order_relaxed)) return true;
  if (hook_ && std::this_thread::get_id() == owner_ && hook_()) Cancel();
  return cancelled_.load(std::memory_order_relaxed);
}

void RunOnThreads(int threads, const CancelToken& token, const std::function<void(int)>& work) {
  std::mutex mutex;
  std::condition_variable finished;
  int running = threads - 1;
  std::exception_ptr error;
  auto keep_first = [&](std::exception_ptr e) {
    token.Cancel();  // the others stop early: the call fails anyway
    const std::lock_guard<std::mutex> lock(mutex);
    if (!error) error = std::move(e);
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads > 1 ? threads - 1 : 0));
  for (int t = 1; t < threads; ++t) {
    pool.emplace_back([&, t] {
      try {
        work(t);
      } catch (...) {
        keep_first(std::current_exception());
      }
      const std::lock_guard<std::mutex> lock(mutex);
      --running;
      finished.notify_one();
    });
  }
  try {
    work(0);
  } catch (...) {
    keep_first(std::current_exception());
  }
  {
    std::unique_lock<std::mutex> lock(mutex);
    while (running > 0) {
      if (finished.wait_for(lock, std::chrono::milliseconds(10), [&] { return running == 0; })) break;
      lock.unlock();
      (void)token.Check();  // the hook, on this (the token's) thread; workers see the flag
      lock.lock();
    }
  }
  for (std::thread& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

ThreadCancelScope::ThreadCancelScope(CancelHook hook) : previous_(t_reader_cancel), hook_(std::move(hook)) {
  t_reader_cancel = &hook_;
}

ThreadCancelScope::~ThreadCancelScope() { t_reader_cancel = previous_; }

void PollThreadCancel() {
  const CancelHook* hook = t_reader_cancel;
  if (hook == nullptr || --t_reader_polls_left > 0) return;
  t_reader_polls_left = kReadPollRows;
  if (*hook && (*hook)()) throw ReadCancelled{};
}

}  // namespace rocklab::common
