#pragma once
/// @file
/// `rocklab report`: a recorded test (an LCM log) as a self-contained page and
/// a static figure. Every event of the log goes through the live monitor's
/// state (monitor::LiveState over the whole record), so the page shows the
/// same views as `rocklab monitor`: it inlines the monitor's web assets and
/// the state's Snapshot(). The figure (theta in degrees against time, the
/// experiment and each model variant overlaid, like the paper's figures 6 to
/// 8, and the table acceleration in a panel below) is drawn from the same
/// snapshot.
///
/// One pass over the log; memory bounded by max_points per series (the
/// snapshot's series halve their resolution when they reach it), whatever
/// the record's length.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "report/report_figure.h"

namespace rocklab {
class table_state_t;
}

namespace rocklab::report {

/// The log cannot be reported: unreadable, not an LCM log, or no RL_THETA.
/// The message is one line naming the file.
class ReportInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ReportOptions {
  double series_rate_hz{100.0};        ///< points kept per second per series, Hz; > 0
  std::size_t max_points{20000};       ///< points per series at most; >= 16
  /// The time window reported, s after the record's first sample (t = 0 of
  /// the page and the figure); 0 <= start_s < end_s, end_s infinity: to the end.
  double start_s{0.0};
  double end_s{std::numeric_limits<double>::infinity()};
  std::string channel_prefix{"RL_"};   ///< as the nodes publish
};

/// The table motion's peaks over the time window (RL_TABLE), for the caption.
struct TablePeaks {
  std::int64_t samples{};        ///< RL_TABLE messages decoded
  std::int64_t decode_errors{};  ///< RL_TABLE messages that did not decode
  double accel_mps2{};           ///< max |u_g''|, m/s^2
  double disp_m{};               ///< max |u_g|, m
  void Add(const rocklab::table_state_t& message);
};

/// What one pass over a log leaves.
struct RecordReport {
  std::string log_path;
  /// What made the page (common::ProvenanceFields): shown at its foot;
  /// empty: no foot.
  std::vector<std::pair<std::string, std::string>> provenance;
  nlohmann::json snapshot;     ///< monitor::LiveState::Snapshot() after the last event
  TablePeaks table;
  std::int64_t events{};       ///< LCM events read
  std::int64_t decode_errors{};///< events of known channels that did not decode (all channels)
  /// Messages missing by their publishers' sequence numbers, all channels
  /// (counters.seq_missing: lost before the log was written).
  std::int64_t seq_missing{};
  std::int64_t damaged_regions{};  ///< damaged regions of the log skipped
  std::int64_t damaged_bytes{};    ///< bytes in them
  std::int64_t damaged_events{};   ///< events lost in them
  std::vector<std::string> problems;  ///< one line per damaged region, with its file offset
};

/// Reads the log once, streaming: memory is bounded by options.max_points
/// per series and the events kept (at most 20000), never the number of
/// events. With a finite end_s the read stops soon after it. Damaged regions
/// are skipped and listed in `problems` (the rest is read).
/// @throws ReportInputError naming the file when it cannot be read, holds no
///   LCM event, or has no RL_THETA message.
RecordReport ReadRecordLog(const std::string& log_path, const ReportOptions& options = {});

/// The caption: one line per variant (model, alpha, p, mu, l for the complex
/// formulation, nrms), then the scenario (rig, calibration, record duration,
/// peak table acceleration and displacement).
std::vector<std::string> CaptionLines(const RecordReport& record);

/// The figure: the measured theta (the reference curve) and each variant's,
/// the table acceleration in a panel below (when the log has RL_TABLE), with
/// the caption.
ThetaFigure ReportFigure(const RecordReport& record);

/// The self-contained page: no network, the monitor's page script and styles
/// and the snapshot (as window.ROCKLAB_SNAPSHOT) inline.
/// @throws std::runtime_error when a monitor asset is missing from the build.
std::string ReportPage(const RecordReport& record);

}  // namespace rocklab::report
