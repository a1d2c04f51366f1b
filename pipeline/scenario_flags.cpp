#include "pipeline/scenario_flags.h"

#include <exception>

#include <CLI/CLI.hpp>

#include "model/excitation.h"
#include "pipeline/option_error.h"

namespace rocklab::pipeline {

void AddScenarioOptions(CLI::App& cmd, ScenarioOptions& o, const std::string& accel_formats) {
  cmd.add_option("--model", o.model, "housner | complex")->capture_default_str();
  cmd.add_option("--alpha", o.alpha, "slenderness angle, rad, in (0, pi/2)")->required();
  cmd.add_option("--p", o.p, "frequency parameter, rad/s, > 0")->required();
  cmd.add_option("--mu", o.mu, "coefficient of restitution, in (0, 1]")->required();
  cmd.add_option("--theta0", o.theta0, "initial rocking angle, rad (0: at rest)")
      ->capture_default_str();
  cmd.add_option("--excitation", o.excitations,
                 "table motion, repeatable (summed): sine:amp=M,freq=HZ,duration=S,start=S "
                 "or hanning:amp=M,freq=HZ,duration=S,start=S")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd.add_option("--accel", o.accel_csv, "table acceleration record: " + accel_formats);
  cmd.add_option("--duration", o.duration_s,
                 "simulated time, s, >= 0 (default with --accel: the record's end + 10 s, as sweep; "
                 "required otherwise)");
  cmd.add_option("--rate", o.rate_hz, "output rate, Hz, > 0")->required();
  cmd.add_option("--l", o.l, "complex formulation momentum, > 0")->capture_default_str();
  cmd.add_option("--rtol", o.rtol, "CVODE relative tolerance, in (0, 1e-3]")->capture_default_str();
  cmd.add_option("--complex-handoff", o.complex_handoff,
                 "complex formulation, opt-in approximation: integrate eq. (10)'s l -> 0 limit "
                 "(Housner's equations) below K times the energy floor V_min ~ l^(2/3); "
                 "0 (default): eq. (10) throughout")
      ->capture_default_str();
}

void ResolveDuration(const CLI::App& cmd, ScenarioOptions& o) {
  if (cmd.count("--duration") > 0) return;
  if (o.accel_csv.empty()) {
    throw OptionError("--duration is required (without --accel; with it, the default is the record's end + 10 s)");
  }
  try {
    o.duration_s = model::ReadAccelerationRows(o.accel_csv).time_s.back() + kDefaultTail_s;
  } catch (const std::exception& e) {
    throw OptionError(std::string("--accel: ") + e.what());
  }
}

}  // namespace rocklab::pipeline
