#pragma once
/// @file
/// `rocklab report`: a recorded test (an LCM log) as a self-contained page and
/// a static figure. Every event of the log goes through the live monitor's
/// state (monitor::LiveState over the whole record), so the page shows the
/// same views as `rocklab monitor`: it inlines the monitor's web assets and
/// the state's Snapshot(). The figure (theta in degrees against time, the
/// experiment and each model variant overlaid, like the paper's figures 6 to
/// 8) is drawn from the same snapshot.

#include <cstdint>
#include <stdexcept>
#include <string>
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
  std::string channel_prefix{"RL_"};   ///< as the nodes publish
};

/// The table motion's peaks over the whole log (RL_TABLE), for the caption.
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
  nlohmann::json snapshot;     ///< monitor::LiveState::Snapshot() after the last event
  TablePeaks table;
  std::int64_t events{};       ///< LCM events read
  std::int64_t decode_errors{};///< events of known channels that did not decode (all channels)
  std::int64_t damaged_regions{};  ///< damaged regions of the log skipped
  std::int64_t damaged_bytes{};    ///< bytes in them
  std::int64_t damaged_events{};   ///< events lost in them
  std::vector<std::string> problems;  ///< one line per damaged region, with its file offset
};

/// Reads the whole log, streaming: memory grows with the decimated series
/// only, never with the number of events. Damaged regions are skipped and
/// listed in `problems` (the rest is read).
/// @throws ReportInputError naming the file when it cannot be read, holds no
///   LCM event, or has no RL_THETA message.
RecordReport ReadRecordLog(const std::string& log_path, const ReportOptions& options = {});

/// The caption: one line per variant (model, alpha, p, mu, l for the complex
/// formulation, nrms), then the scenario (rig, calibration, record duration,
/// peak table acceleration and displacement).
std::vector<std::string> CaptionLines(const RecordReport& record);

/// The figure: the measured theta (the reference curve) and each variant's,
/// with the caption.
ThetaFigure ReportFigure(const RecordReport& record);

/// The self-contained page: no network, the monitor's page script and styles
/// and the snapshot (as window.ROCKLAB_SNAPSHOT) inline.
/// @throws std::runtime_error when a monitor asset is missing from the build.
std::string ReportPage(const RecordReport& record);

}  // namespace rocklab::report
