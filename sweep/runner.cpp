#include "sweep/runner.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "common/plugin.h"
#include "common/progress.h"
#include "pipeline/option_error.h"
#include "sweep/mpi_plugin.h"

namespace rocklab::sweep {
namespace {

using pipeline::OptionError;
using Clock = std::chrono::steady_clock;

// Cases a worker may run ahead of the writer: enough to keep every core
// busy past a slow case, few enough that the waiting outcomes stay small.
constexpr std::size_t kWindow = 4096;

bool StartedByMpirun() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

int WorldSizeFromEnvironment() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    if (const char* v = std::getenv(name)) return std::atoi(v);
  }
  return 1;
}

// An outcome on the wire between ranks: its place in the slice and eight
// doubles, then an assembly's first overturned body and its peaks per body.
constexpr int kWireDoubles = 10 + model::stack::kMaxBodies;
void Pack(std::size_t place, const Outcome& o, double* w) {
  w[0] = static_cast<double>(place);  // exact below 2^53 (plans hold at most 1e8 cases)
  w[1] = o.peak_theta_over_alpha;
  w[2] = o.peak_time_s;
  w[3] = o.overturned ? 1.0 : 0.0;
  w[4] = o.overturn_time_s;
  w[5] = static_cast<double>(o.impacts);
  w[6] = o.uplift_time_s ? 1.0 : 0.0;
  w[7] = o.uplift_time_s.value_or(0.0);
  w[8] = o.beyond_pi_over_2 ? 1.0 : 0.0;
  w[9] = static_cast<double>(o.first_overturned);
  for (std::size_t k = 0; k < o.peak_abs_theta_rad.size(); ++k) w[10 + k] = o.peak_abs_theta_rad[k];
}
std::size_t Unpack(const double* w, Outcome& o) {
  o.peak_theta_over_alpha = w[1];
  o.peak_time_s = w[2];
  o.overturned = w[3] != 0.0;
  o.overturn_time_s = w[4];
  o.impacts = static_cast<int>(w[5]);
  o.uplift_time_s.reset();
  if (w[6] != 0.0) o.uplift_time_s = w[7];
  o.beyond_pi_over_2 = w[8] != 0.0;
  o.first_overturned = static_cast<int>(w[9]);
  for (std::size_t k = 0; k < o.peak_abs_theta_rad.size(); ++k) o.peak_abs_theta_rad[k] = w[10 + k];
  return static_cast<std::size_t>(w[0]);
}

// The worker threads of one process and the outcomes they produced, keyed by
// their place in the slice.
class Workers {
 public:
  Workers(const Plan& plan, const Slice& slice, std::vector<std::size_t> places, unsigned threads)
      : plan_(plan), slice_(slice), places_(std::move(places)) {
    for (unsigned t = 0; t < threads; ++t) threads_.emplace_back([this] { Work(); });
  }
  ~Workers() { Stop(); }

  // Waits for the outcome of places_[position] (or any failure) and takes it.
  // Returns false when a worker failed (its message in error()).
  bool Take(std::size_t position, Outcome& out) {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return failed_ || done_.count(position) != 0; });
    if (failed_) return false;
    out = done_[position];
    done_.erase(position);
    taken_ = position + 1;
    room_.notify_all();
    return true;
  }
  // Takes the outcome of places_[position] if it is ready; never waits.
  enum class Poll { kReady, kNotYet, kFailed };
  Poll TryTake(std::size_t position, Outcome& out) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (failed_) return Poll::kFailed;
    const auto it = done_.find(position);
    if (it == done_.end()) return Poll::kNotYet;
    out = it->second;
    done_.erase(it);
    taken_ = position + 1;
    room_.notify_all();
    return Poll::kReady;
  }
  std::string error() {
    std::lock_guard<std::mutex> lock(mutex_);
    return error_;
  }
  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    room_.notify_all();
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
  }

 private:
  void Work() {
    for (;;) {
      const std::size_t position = next_.fetch_add(1);
      if (position >= places_.size()) return;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        room_.wait(lock, [&] { return stop_ || position < taken_ + kWindow; });
        if (stop_) return;
      }
      Outcome o;
      try {
        o = RunCase(plan_, slice_.index(places_[position]));
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!failed_) error_ = e.what();
        failed_ = true;
        ready_.notify_all();
        return;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      done_[position] = o;
      ready_.notify_all();
    }
  }

  const Plan& plan_;
  const Slice slice_;
  const std::vector<std::size_t> places_;  // places in the slice this process runs, ascending
  std::atomic<std::size_t> next_{0};
  std::mutex mutex_;
  std::condition_variable ready_, room_;
  std::map<std::size_t, Outcome> done_;
  std::size_t taken_{0};
  bool failed_{false}, stop_{false};
  std::string error_;
  std::vector<std::thread> threads_;
};

[[noreturn]] void AbortJob(const MpiSession& mpi, const std::string& message) {
  std::fprintf(stderr, "rocklab: %s\n", message.c_str());
  std::fflush(stderr);
  if (mpi.calls() != nullptr) mpi.calls()->abort();
  std::exit(1);
}

}  // namespace

MpiSession::MpiSession() {
  if (!StartedByMpirun()) return;
  const int world = WorldSizeFromEnvironment();
  std::string why = "this rocklab was built without MPI (configure with -DROCKLAB_MPI=ON and libopenmpi-dev "
                    "installed)";
  const MpiCalls* calls =
      Built() ? common::OpenPlugin<MpiCalls>(kMpiPluginFile, kMpiPluginEntry, kMpiPluginVersion, why, /*global=*/true)
              : nullptr;
  if (calls == nullptr) {
    if (world <= 1) return;  // one rank: the threaded run, no MPI needed
    if (Built()) why = "its MPI plugin does not load: " + why + " (apt-get install --reinstall rocklab)";
    throw OptionError("started by mpirun with " + std::to_string(world) + " ranks, but " + why +
                      "; every rank would write the same file");
  }
  calls->init(&rank_, &size_);  // only the calling (writer) thread makes MPI calls
  calls_ = calls;
}

MpiSession::~MpiSession() {
  if (calls_ != nullptr) calls_->finalize();
}

bool MpiSession::Built() {
#ifdef ROCKLAB_MPI
  return true;
#else
  return false;
#endif
}

RunReport RunSweep(const Plan& plan, const std::string& out_path, const RunOptions& options,
                   const MpiSession& mpi) {
  const auto start = Clock::now();
  RunReport report;
  report.cases = options.slice.count();
  report.ranks = mpi.size();
  const int rank = mpi.rank(), size = mpi.size();

  // Rank 0 opens the output (and, resuming, learns how many rows are kept).
  std::unique_ptr<RowWriter> writer;
  std::string open_error;
  if (rank == 0) {
    try {
      writer = OpenRowWriter(out_path, plan, options.slice, options.resume, options.provenance);
      report.resumed = writer->rows_done();
    } catch (const std::exception& e) {
      if (size == 1) throw;
      open_error = e.what();
    }
  }
  if (size > 1) {
    unsigned long long shared[2] = {report.resumed, open_error.empty() ? 0ull : 1ull};
    mpi.calls()->broadcast(shared, 2);
    report.resumed = static_cast<std::size_t>(shared[0]);
    if (shared[1] != 0) {
      if (rank == 0) throw OptionError(open_error);
      report.open_failed_on_rank0 = true;  // rank 0 says why
      return report;
    }
  }

  // Places in the slice this process runs: resumed, resumed + 1, ... dealt round-robin.
  std::vector<std::size_t> places;
  for (std::size_t k = report.resumed + static_cast<std::size_t>(rank); k < report.cases;
       k += static_cast<std::size_t>(size)) {
    places.push_back(k);
  }
  unsigned threads = options.threads;
  if (threads == 0) threads = size > 1 ? 1 : std::max(1u, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, std::max<std::size_t>(places.size(), 1)));
  report.threads = threads;
  Workers workers(plan, options.slice, places, threads);

  if (rank != 0) {
    double wire[kWireDoubles];
    for (std::size_t position = 0; position < places.size(); ++position) {
      Outcome o;
      if (!workers.Take(position, o)) AbortJob(mpi, workers.error());
      Pack(places[position], o, wire);
      mpi.calls()->send_to_root(wire, kWireDoubles);
    }
    workers.Stop();
    report.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    return report;
  }

  // Rank 0: write every place in order, its own outcomes and the others'.
  // The commands' one progress display (common/progress.h), in rows.
  common::Progress bar("sweep", static_cast<std::int64_t>(report.cases), !options.progress, 2, "rows");
  bar.SetBase(static_cast<std::int64_t>(report.resumed));
  std::map<std::size_t, Outcome> received;  // from other ranks, by place
  std::size_t own = 0;                      // next position in `places`
  for (std::size_t k = report.resumed; k < report.cases; ++k) {
    Outcome o;
    if (size == 1) {
      if (!workers.Take(own, o)) throw std::runtime_error(workers.error());
      ++own;
    } else {
      for (;;) {
        if (own < places.size() && places[own] == k) {
          const Workers::Poll poll = workers.TryTake(own, o);
          if (poll == Workers::Poll::kFailed) AbortJob(mpi, workers.error());
          if (poll == Workers::Poll::kReady) {
            ++own;
            break;
          }
        } else if (const auto it = received.find(k); it != received.end()) {
          o = it->second;
          received.erase(it);
          break;
        }
        double wire[kWireDoubles];
        if (mpi.calls()->try_receive(wire, kWireDoubles) != 0) {
          Outcome r;
          const std::size_t place = Unpack(wire, r);
          received[place] = r;
        } else {
          std::this_thread::sleep_for(std::chrono::microseconds(500));
        }
      }
    }
    try {
      writer->Write(options.slice.index(k), o);
    } catch (const std::exception& e) {
      if (size > 1) AbortJob(mpi, e.what());
      throw;
    }
    ++report.run;
    if (o.overturned) ++report.overturned;
    if (o.beyond_pi_over_2) {
      if (report.beyond_pi_over_2++ == 0) report.first_beyond_pi_over_2 = KeyPrefix(plan, options.slice.index(k));
    }
    bar.Update(static_cast<std::int64_t>(k + 1));
  }
  bar.Finish();
  workers.Stop();
  writer->Close();
  report.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

}  // namespace rocklab::sweep
