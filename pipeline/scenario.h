#pragma once
/// @file
/// One scenario of a model under a table motion, as `rocklab simulate`,
/// `synth` and `demo` run it: the option values, their checks, the model and
/// its forcing, a streaming run and its summary, the events CSV. The
/// command-line flags that fill its options are pipeline/scenario_flags.h.

#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "model/excitation.h"
#include "model/rocking_model.h"

namespace rocklab::pipeline {

/// Values of the scenario options, as parsed (AddScenarioOptions).
struct ScenarioOptions {
  std::string model{"housner"};         ///< housner | complex
  double alpha{};                       ///< rad
  double p{};                           ///< rad/s
  double mu{};                          ///< 1
  double theta0{};                      ///< initial rocking angle, rad
  std::vector<std::string> excitations; ///< --excitation specs (summed)
  std::string accel_csv;                ///< --accel FILE.csv (time,accel)
  double duration_s{};                  ///< s
  double rate_hz{};                     ///< output rate, Hz
  double l{model::ModelOptions{}.l};    ///< complex formulation momentum, 1
  double rtol{model::ModelOptions{}.rtol};  ///< CVODE relative tolerance, 1
  /// Complex formulation, opt-in approximation: the l -> 0 limit below this
  /// multiple of the energy floor V_min (0: off, eq. (10) throughout), 1.
  double complex_handoff{0.0};
};

/// A scenario ready to run: the model and its forcing.
struct Scenario {
  std::unique_ptr<model::RockingModel> model;
  std::unique_ptr<model::Forcing> forcing;
  std::string forcing_description;  ///< for captions and JSON
};

/// Checks the values (throws OptionError naming the option) and builds the
/// model and the forcing (reading --accel; file errors throw OptionError).
Scenario BuildScenario(const ScenarioOptions& options);

/// The table motion of the options (--excitation summed, plus --accel; no
/// motion without either) and its description for captions and JSON.
/// @throws OptionError naming --excitation or --accel.
std::unique_ptr<model::Forcing> BuildForcing(const ScenarioOptions& options, std::string& description);

/// What a user checks first in a run.
struct RunSummary {
  std::optional<double> uplift_time_s;  ///< first uplift, s
  double peak_abs_theta{};              ///< max |theta| over the outputs, rad
  double peak_time_s{};                 ///< time of that peak, s
  int impacts{};                        ///< impacts during the run
  bool overturned{};                    ///< whether the block overturned
  std::optional<double> overturn_time_s;
  std::size_t samples{};                ///< output rows
};

/// Runs `scenario` from t = 0 (theta0 from the options, at rest when 0) for
/// duration_s, calling `on_sample(t, theta, theta_dot)` at t = k / rate_hz,
/// k = 0 .. floor(duration * rate). Memory stays bounded: nothing is kept
/// per sample. The model's events are left in scenario.model->events().
RunSummary RunScenario(Scenario& scenario, const ScenarioOptions& options,
                       const std::function<void(double, double, double)>& on_sample);

/// Writes `time,kind` rows (s, event name) of the model's events to `path`.
/// @throws std::runtime_error naming the file when it cannot be written.
void WriteEventsCsv(const std::string& path, const std::vector<model::ModelEvent>& events);

/// An output file written beside `path` (common::AtomicFile) that gets its
/// name only at Close(), complete; destroyed without Close() (an error
/// before the end), it is removed and `path` keeps what it held. Throws
/// naming the path when it cannot be created or written. "-" is standard
/// output (written as it goes; Close() flushes it).
class OutputFile {
 public:
  explicit OutputFile(const std::string& path);
  std::FILE* get() const { return file_; }
  /// Flushes, syncs and renames to the path; throws naming the path on a
  /// write error (the path then keeps what it held).
  void Close();

 private:
  std::unique_ptr<common::AtomicFile> out_;
  std::FILE* file_{};
};

}  // namespace rocklab::pipeline
