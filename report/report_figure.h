#pragma once
/// @file
/// The static figure of a recorded test, like the paper's figures 6 to 8:
/// theta in degrees against time in seconds, the experiment and each model
/// variant overlaid (over each ensemble's posterior predictive band, shaded), the table acceleration in a panel below when it is
/// given (same time axis), with caption lines below the plots. gnuplot draws it: the
/// script and the curves (as inline data blocks) go to gnuplot's standard
/// input through a pipe; nothing is plotted by hand.

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace rocklab::report {

/// gnuplot could not be started, failed, or wrote no file. The message is
/// one line naming the output file and gnuplot's own complaint.
class FigureError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class FigureFormat { kSvg, kPng };

/// Runs `gnuplot` (a name looked up on PATH, or a path) on
/// `script_for(output)`, a script that must write the file `output`; every
/// rocklab figure is drawn through it (ThetaFigure::Write, `rocklab
/// sweep-plot`). `output` is a temporary beside `out_path`
/// (common::AtomicFile), renamed to `out_path` once gnuplot has succeeded:
/// a failed drawing leaves `out_path` as it was. `provenance` (when not
/// empty) goes into the file before the rename (common::AddProvenanceToFigure:
/// SVG metadata, PNG tEXt chunks).
/// @returns gnuplot's warnings (empty when it had none), one per line.
/// @throws FigureError when gnuplot is missing, exits non-zero or is killed,
///   or leaves no output file.
std::string RunGnuplot(const std::string& gnuplot,
                       const std::function<std::string(const std::string& output)>& script_for,
                       const std::string& out_path,
                       const std::vector<std::pair<std::string, std::string>>& provenance = {});

/// `text` as a gnuplot single-quoted string ('' for a quote; control
/// characters become spaces).
std::string GnuplotQuoted(const std::string& text);

/// One curve of theta against time.
struct ThetaCurve {
  std::string title;              ///< legend entry (printed as is, no markup)
  std::vector<double> time_s;     ///< s since the record's start
  std::vector<double> theta_deg;  ///< degrees, one per time_s; NaN leaves a gap
  bool reference{};               ///< the experiment: drawn first style, black
};

/// A posterior predictive band of theta (an ensemble's quantiles), drawn
/// under the curves: the 95 % and 68 % ranges shaded, the median dashed.
struct ThetaBand {
  std::string title;              ///< legend stem (printed as is)
  std::vector<double> time_s;     ///< s since the record's start
  std::vector<double> lo95_deg, lo68_deg, median_deg, hi68_deg, hi95_deg;  ///< degrees, one per time_s
};

/// Collects curves and caption lines and draws them with gnuplot.
class ThetaFigure {
 public:
  /// @throws std::invalid_argument when time_s and theta_deg differ in length.
  void AddCurve(ThetaCurve curve);
  /// @throws std::invalid_argument when a quantile's length differs from time_s's.
  void AddBand(ThetaBand band);
  void AddCaptionLine(std::string line) { caption_.push_back(std::move(line)); }
  /// The table acceleration panel under the theta panel: u_g'' (m/s^2) at
  /// times (s, the curves' clock); NaN leaves a gap. Empty: no panel.
  /// @throws std::invalid_argument when the two differ in length.
  void SetTableAcceleration(std::vector<double> time_s, std::vector<double> accel_mps2);
  /// A panel of its own under the theta panel (above the table's), same
  /// time axis: an assembly's upper body, the experiment's and each
  /// variant's curve of it; `label` names the body on the y axis. The theta
  /// panel above holds the bottom body. None: the figure is as before.
  /// @throws std::invalid_argument as AddCurve.
  void AddBodyPanel(std::string label, std::vector<ThetaCurve> curves);
  void set_title(std::string title) { title_ = std::move(title); }
  /// The gnuplot program: a name looked up on PATH (default "gnuplot") or a path.
  void set_gnuplot(std::string program) { gnuplot_ = std::move(program); }
  /// What made the figure (common::ProvenanceFields), written into the file.
  void set_provenance(std::vector<std::pair<std::string, std::string>> fields) { provenance_ = std::move(fields); }

  const std::vector<ThetaCurve>& curves() const { return curves_; }
  const std::vector<ThetaBand>& bands() const { return bands_; }
  const std::vector<std::string>& caption() const { return caption_; }
  bool has_table_panel() const { return !table_time_s_.empty(); }
  std::size_t body_panels() const { return body_panels_.size(); }

  /// The whole gnuplot script Write sends (terminal, layout, data blocks, plot).
  /// Precondition: width_px, height_px >= 200.
  std::string Script(const std::string& out_path, FigureFormat format, int width_px,
                     int height_px) const;

  /// Runs gnuplot on Script(...) and checks that it wrote `out_path`.
  /// @returns gnuplot's warnings (empty when it had none), one per line.
  /// @throws FigureError when gnuplot is missing, exits non-zero or is killed,
  ///   or leaves no output file; std::invalid_argument when the figure has no
  ///   curve, the size is below 200 px, or the height leaves less than 100 px
  ///   for the plot (180 px for the two panels) beside the caption lines.
  std::string Write(const std::string& out_path, FigureFormat format, int width_px,
                    int height_px) const;

 private:
  std::vector<ThetaCurve> curves_;
  std::vector<ThetaBand> bands_;
  std::vector<std::string> caption_;
  std::vector<double> table_time_s_, table_accel_mps2_;
  struct BodyPanel {
    std::string label;
    std::vector<ThetaCurve> curves;
  };
  std::vector<BodyPanel> body_panels_;
  std::string title_;
  std::string gnuplot_{"gnuplot"};
  std::vector<std::pair<std::string, std::string>> provenance_;
};

}  // namespace rocklab::report
