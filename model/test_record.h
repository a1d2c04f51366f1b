#pragma once
/// @file
/// A recorded rocking test as the fitting code sees it: theta(t) of the
/// block and, for forced tests, the table acceleration. Read from a CSV with a
/// `time,theta` header (extra columns allowed, e.g. those of
/// `rocklab reconstruct`) or from a rocklab LCM log (RL_THETA, RL_TABLE).

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace rocklab::model {

/// A record that cannot be used as it is (unreadable, ragged, non-finite
/// time, non-monotonic time, too few samples). The message starts with "file:line: " (LCM logs: the
/// event number stands in for the line).
class RecordError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Samples missing from a series: a step longer than max_step_ratio times
/// the median step, a jump in an LCM `seq`, or a sample whose value is not a
/// number (left out of the series).
struct GapCount {
  int64_t missing_samples{};  ///< samples missing in all, 1
  int64_t gaps{};             ///< places where samples are missing, 1
  double longest_s{};         ///< longest time between two present samples across a gap, s
  int64_t first_line{};       ///< line (CSV) or event number (LCM) of the first sample after the first gap; 0: none
};

/// One test. Sample times are strictly increasing; missing samples are left
/// out (the time grid may have holes) and counted.
struct RockingRecord {
  std::string source;              ///< file it came from (for messages)
  std::vector<double> time_s;      ///< s
  std::vector<double> theta;       ///< rocking angle, rad (> 0 about the +x corner)
  std::vector<int64_t> line;       ///< line (CSV) or event number (LCM) of each sample
  /// Table acceleration u_g'' (not the inertial -u_g''), m/s^2, at its own
  /// sample times (s); empty for a free-rocking record.
  std::vector<double> table_time_s;
  std::vector<double> table_accel_mps2;
  GapCount theta_gaps;  ///< theta samples missing
  GapCount table_gaps;  ///< table samples missing

  bool has_table() const { return !table_time_s.empty(); }
  std::size_t size() const { return time_s.size(); }
};

/// Options of the readers and of the record checks.
struct RecordOptions {
  std::string theta_channel{"RL_THETA"};  ///< LCM: block_state_t channel
  std::string table_channel{"RL_TABLE"};  ///< LCM: table_state_t channel
  /// A step longer than this many times the median sample step is a gap of
  /// round(step / median) - 1 missing samples (at least 1).
  double max_step_ratio{1.5};
  /// Fewest theta samples accepted.
  int min_samples{20};
};

/// Reads `path` as an LCM log when it starts with the LCM sync word, else as
/// a CSV, then checks it with CheckRecord.
/// @throws RecordError naming the file and line of the first problem.
RockingRecord ReadRecord(const std::string& path, const RecordOptions& options = {});

/// CSV: a header row naming at least `time` (s) and `theta` (rad), in any
/// order; other columns are ignored; blank lines and lines starting with '#'
/// are skipped. Every row must have the header's number of fields and a
/// numeric time; a theta that is not a finite number ("nan", empty) is a lost
/// sample: left out and counted in theta_gaps.
/// @throws RecordError "file:line: ..." on the first problem.
RockingRecord ReadThetaCsv(const std::string& path);

/// rocklab LCM log: block_state_t on options.theta_channel (theta, utime),
/// table_state_t on options.table_channel (acceleration, utime). A jump in a
/// channel's `seq` counts its missing samples (theta_gaps, table_gaps), and
/// so does a sample whose value is not finite (left out).
/// @throws RecordError "file:event N: ..." on the first problem.
RockingRecord ReadThetaLcmLog(const std::string& path, const RecordOptions& options = {});

/// Adds the table acceleration of a CSV with the header `time,accel` (s,
/// m/s^2, as `rocklab simulate --accel` reads) to a record that has none.
/// @throws RecordError "file:line: ..." on the first problem, or when the
///         record already has a table channel.
void AddTableCsv(const std::string& path, RockingRecord& record);

/// Checks the record: enough samples, finite values, strictly increasing
/// time (theta and table separately). Gaps are not errors: see CountGaps.
/// @throws RecordError naming the file and line of the first problem.
void CheckRecord(const RockingRecord& record, const RecordOptions& options = {});

/// Missing samples of a strictly increasing series from its time steps: a
/// step longer than max_step_ratio times the median step holds
/// max(1, round(step / median) - 1) missing samples. `line` names the
/// samples (CSV line or LCM event number).
GapCount CountGaps(const std::vector<double>& time_s, const std::vector<int64_t>& line,
                   double max_step_ratio = RecordOptions{}.max_step_ratio);

/// Keeps the samples (theta and table) whose time lies in [t0 + start_s,
/// t0 + end_s], t0 the first theta sample's time (`fit --start/--end`:
/// the free rocking of a longer test), and counts the gaps of what is kept
/// again. A window that keeps everything changes nothing.
/// @throws std::invalid_argument for start_s < 0 or end_s < start_s (naming
///         --start/--end); RecordError (CheckRecord) when too few samples are left.
void WindowRecord(RockingRecord& record, double start_s, double end_s, const RecordOptions& options = {});

/// Writes `time,theta` rows (s, rad), full precision.
/// @throws RecordError naming the file when it cannot be written.
void WriteThetaCsv(const std::string& path, const RockingRecord& record);

}  // namespace rocklab::model
