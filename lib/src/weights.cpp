#include "sis/weights.h"

#include <algorithm>
#include <exception>
#include <map>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace sis {

double AxisWeights::sum(long t) const {
  double s = 0;
  for (long e = begin(t); e < end(t); ++e) s += weight[e];
  return s;
}

AxisWeights AxisWeights::transposed() const {
  AxisWeights out;
  out.targets = sources;
  out.sources = targets;
  out.offset.assign(sources + 1, 0);
  for (long i : index) ++out.offset[i + 1];
  for (long s = 0; s < sources; ++s) out.offset[s + 1] += out.offset[s];
  out.index.resize(index.size());
  out.weight.resize(weight.size());
  std::vector<long> fill(out.offset.begin(), out.offset.end() - 1);
  for (long t = 0; t < targets; ++t)  // targets in increasing order: stays sorted
    for (long e = begin(t); e < end(t); ++e) {
      const long pos = fill[index[e]]++;
      out.index[pos] = t;
      out.weight[pos] = weight[e];
    }
  return out;
}

AxisWeights make_axis_weights(long targets, long sources, Boundary boundary,
                              const std::function<std::pair<long, long>(long)>& range,
                              const std::function<double(long, long)>& weight) {
  AxisWeights w;
  w.targets = targets;
  w.sources = sources;
  w.offset.reserve(targets + 1);
  w.offset.push_back(0);
  std::map<long, double> merged;
  for (long t = 0; t < targets; ++t) {
    merged.clear();
    const auto [first, last] = range(t);
    for (long k = first; k <= last; ++k) {
      const double v = weight(t, k);
      if (v != 0.0) merged[extend_index(k, sources, boundary)] += v;
    }
    for (const auto& [i, v] : merged) {
      w.index.push_back(i);
      w.weight.push_back(v);
    }
    w.offset.push_back(static_cast<long>(w.index.size()));
  }
  return w;
}

namespace {

// Worker threads kept for the life of the process: spawning threads for
// every strip cost more than the work of a strip. One parallel call runs at a
// time; a call made while another runs (nested, or from a second thread)
// runs its chunks in the caller instead, which gives the same result.
class WorkerPool {
 public:
  static WorkerPool& instance() {
    static WorkerPool pool;
    return pool;
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
      ++generation_;
    }
    wake_.notify_all();
    drain();
    {
      std::unique_lock<std::mutex> lock(m_);
      done_.wait(lock, [this] { return pending_ == 0; });
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
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }

 private:
  // Takes parts until none is left.
  void drain() {
    std::unique_lock<std::mutex> lock(m_);
    while (part_ && next_ < parts_) {
      const int k = next_++;
      const auto* part = part_;
      auto* errors = errors_;
      lock.unlock();
      try {
        (*part)(k);
      } catch (...) {
        (*errors)[k] = std::current_exception();
      }
      lock.lock();
      if (--pending_ == 0) done_.notify_all();
    }
  }

  void work() {
    long seen = 0;
    std::unique_lock<std::mutex> lock(m_);
    for (;;) {
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      lock.unlock();
      drain();
      lock.lock();
    }
  }

  std::mutex call_, m_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;
  const std::function<void(int)>* part_ = nullptr;
  std::vector<std::exception_ptr>* errors_ = nullptr;
  int parts_ = 0, next_ = 0, pending_ = 0;
  long generation_ = 0;
  bool stop_ = false;
};

}  // namespace

void parallel_for(long n, int threads, const std::function<void(long, long)>& fn) {
  const long t = std::max(1L, std::min<long>(threads, n));
  auto chunk = [&](int k) { fn(n * k / t, n * (k + 1) / t); };
  if (t > 1 && WorkerPool::instance().run(int(t), chunk)) return;
  for (long k = 0; k < t; ++k) chunk(int(k));  // same chunks, in the caller
}

}  // namespace sis
