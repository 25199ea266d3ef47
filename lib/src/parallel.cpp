#include "sis/parallel.h"

#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <new>
#include <thread>
#include <vector>

namespace sis {

namespace {

// A waiter polls for this long (yielding the core to anything runnable)
// before it sleeps. Waking a sleeping thread costs tens to hundreds of
// microseconds on a virtual machine, as long as the work of a strip split in
// two; the acquisition calls parallel_for once per strip, strip after strip.
constexpr auto kSpin = std::chrono::microseconds(200);

template <typename Done>
bool spin_until(const Done& done) {
  const auto until = std::chrono::steady_clock::now() + kSpin;
  do {
    if (done()) return true;
    std::this_thread::yield();
  } while (std::chrono::steady_clock::now() < until);
  return done();
}

// Set on a thread while it runs parts of a job: a parallel_for made from
// inside a part runs its chunks in that thread.
thread_local bool in_part = false;

// Worker threads kept for the life of the process: spawning threads for
// every strip cost more than the work of a strip. One parallel call runs at a
// time; a call made while another runs (nested, or from a second thread)
// runs its chunks in the caller instead, which gives the same result. The
// mutex guards the job; the atomics only let waiters poll without it.
// A child made by fork() has none of the parent's workers: it starts with
// an empty pool (after_fork), which makes workers again as it needs them.
class WorkerPool {
 public:
  static WorkerPool& instance() {
    static WorkerPool pool;
    return pool;
  }

  WorkerPool() {
    static const int registered = pthread_atfork(nullptr, nullptr, [] { instance().after_fork(); });
    (void)registered;
    keep_fork_safe();
  }

  // Runs part(k) for k in [0, parts) on the caller and parts - 1 workers.
  // Returns false, having run nothing, when another call holds the pool.
  bool run(int parts, const std::function<void(int)>& part) {
    std::unique_lock<std::mutex> call(call_, std::try_to_lock);
    if (!call.owns_lock()) return false;
    std::vector<std::exception_ptr> errors(parts);
    {
      std::lock_guard<std::mutex> lock(m_);
      while (int(workers_.size()) < parts - 1) workers_.emplace_back([this] { work(); });
      part_ = &part;
      errors_ = &errors;
      parts_ = parts;
      next_ = 0;
      pending_ = parts;
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    drain();
    if (!spin_until([this] { return pending_.load(std::memory_order_acquire) == 0; })) {
      std::unique_lock<std::mutex> lock(m_);
      done_.wait(lock, [this] { return pending_ == 0; });
    }
    {
      std::lock_guard<std::mutex> lock(m_);
      part_ = nullptr;
    }
    for (auto& e : errors)
      if (e) std::rethrow_exception(e);
    return true;
  }

  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }

 private:
  // In the child of a fork, whose only thread is the one that forked: the
  // parent's workers are not there to join, and a lock or a job they held
  // at the fork is held by no one. Their thread objects are let go
  // unjoined (left allocated: destroying a joinable std::thread ends the
  // process), the locks and the job made anew.
  void after_fork() {
    new std::vector<std::thread>(std::move(workers_));
    workers_.clear();
    new (&call_) std::mutex;
    new (&m_) std::mutex;
    new (&wake_) std::condition_variable;
    new (&done_) std::condition_variable;
    part_ = nullptr;
    errors_ = nullptr;
    parts_ = next_ = 0;
    pending_.store(0);
    stop_ = false;
    in_part = false;
  }

  // Takes parts until none is left.
  void drain() {
    std::unique_lock<std::mutex> lock(m_);
    while (part_ && next_ < parts_) {
      const int k = next_++;
      const auto* part = part_;
      auto* errors = errors_;
      lock.unlock();
      in_part = true;
      try {
        (*part)(k);
      } catch (...) {
        (*errors)[k] = std::current_exception();
      }
      in_part = false;
      lock.lock();
      if (--pending_ == 0) done_.notify_all();
    }
  }

  void work() {
    long seen = 0;
    for (;;) {
      spin_until([&] { return generation_.load(std::memory_order_acquire) != seen; });
      {
        std::unique_lock<std::mutex> lock(m_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      drain();
    }
  }

  std::mutex call_, m_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;
  const std::function<void(int)>* part_ = nullptr;
  std::vector<std::exception_ptr>* errors_ = nullptr;
  int parts_ = 0, next_ = 0;
  std::atomic<int> pending_{0};
  std::atomic<long> generation_{0};
  bool stop_ = false;
};

}  // namespace

void parallel_for(long n, int threads, const std::function<void(long, long)>& fn) {
  const long t = std::max(1L, std::min<long>(threads, n));
  auto chunk = [&](int k) { fn(n * k / t, n * (k + 1) / t); };
  if (t > 1 && !in_part && WorkerPool::instance().run(int(t), chunk)) return;
  for (long k = 0; k < t; ++k) chunk(int(k));  // same chunks, in the caller
}

}  // namespace sis
