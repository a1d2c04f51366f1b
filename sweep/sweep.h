#pragma once
/// @file
/// A rocking campaign (`rocklab sweep`): every (record, block, scale) case of
/// a set of ground-motion records, a family of blocks and a range of scales,
/// run through the model library as `rocklab simulate` runs one scenario
/// (pipeline::RunScenario), one result row per case.
///
/// Cases are numbered in one fixed order, record outermost, then block, then
/// scale: case i = (record r, block b, scale s) with i = (r * blocks + b) *
/// scales + s. Whatever runs them (threads, MPI ranks, shards), rows are
/// written in that order and formatted by FormatRow alone, so the same plan
/// gives the same bytes.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/cancel.h"
#include "model/block.h"
#include "model/rocking_model.h"
#include "model/stack.h"
#include "pipeline/assembly.h"

namespace rocklab::sweep {

/// One ground-motion record, read once.
struct Record {
  std::string path;                ///< as given on the command line
  std::string name;                ///< the file's name, the `record` column
  std::vector<double> time_s;      ///< s, strictly increasing
  std::vector<double> accel_mps2;  ///< table acceleration, m/s^2
  double pga_mps2{};               ///< max |accel|, m/s^2; > 0
};

/// Reads a record through model::ReadAccelerationRows (the reader of
/// `simulate --accel`: `time,accel` CSV, and whatever formats it learns).
/// @throws pipeline::OptionError "--records: FILE:LINE: ..." on a bad file, a
///   record that is all zeros, or a name a CSV field cannot hold (, " or a
///   control character).
Record ReadRecord(const std::string& path);

/// One block of the family: the model's parameters and a label.
struct Block {
  model::BlockParams params;  ///< alpha (rad), p (rad/s), mu; `minus` for an asymmetric section
  std::string label;          ///< the `block` column: "-" for listed parameters, "WxH" (m), or the polygon's file name
};

/// How the scale grid is read.
enum class ScaleKind {
  kFactor,  ///< the grid values multiply each record
  kPgaG,    ///< the grid values are the target PGA in g (--pga-g)
};

/// The whole campaign, validated.
struct Plan {
  std::vector<Record> records;
  std::vector<Block> blocks;
  std::vector<double> scales;  ///< grid values (factor, or target PGA in g)
  ScaleKind scale_kind{ScaleKind::kFactor};
  model::ModelKind model{model::ModelKind::kHousner};
  /// Simulated time per case, s; nullopt: each record's last sample time + kDefaultTail_s.
  std::optional<double> duration_s;
  double rate_hz{1000.0};  ///< rate at which the peak |theta| is sampled, Hz
  double l{model::kDefaultL};  ///< complex formulation momentum, 1
  double rtol{model::ModelOptions{}.rtol};  ///< CVODE relative tolerance, 1
  /// --assembly: what every case runs (then `blocks` holds its one row
  /// block, labelled by the file's name: the single block of a one-body
  /// assembly or a frame, a stack's StackRowParams); nullopt otherwise.
  std::optional<pipeline::Assembly> assembly;
  /// The assembly file in the definition: "NAME BYTES fnv1a64:HEX" (its
  /// name, size in bytes and the FNV-1a 64-bit hash of its bytes).
  std::string assembly_identity;

  static constexpr double kDefaultTail_s = 10.0;

  std::size_t size() const { return records.size() * blocks.size() * scales.size(); }
  /// Bodies in a row's per-body columns: the assembly's output bodies, 0 without one.
  int bodies() const { return assembly ? assembly->output_bodies() : 0; }
  /// A stack of several bodies, run by the stack model.
  bool stack() const { return assembly && !assembly->frame && assembly->bodies.size() > 1; }
};

/// The values of the command line, before they become a Plan.
struct PlanOptions {
  std::vector<std::string> records;
  std::string scale{"1:1:1"};  ///< A:B:N
  bool pga_g{};
  std::vector<double> alpha, p, mu;      ///< rad, rad/s, 1 (mu empty: Housner's 1 - 1.5 sin^2 alpha)
  std::vector<double> width, height;     ///< m
  std::vector<std::string> polygons;
  std::string assembly;  ///< an assembly file (TOML, as `simulate --assembly`), instead of the blocks above
  std::string model;
  std::optional<double> duration_s;
  double rate_hz{1000.0};
  double l{model::kDefaultL};
  double rtol{model::ModelOptions{}.rtol};  ///< CVODE relative tolerance, 1
};

/// N values from A to B, A + (B - A) k / (N - 1), k = 0..N-1 (N = 1: A).
/// @throws pipeline::OptionError naming --scale for a malformed text, N < 1,
///   N > 1e6, non-finite or non-positive values.
std::vector<double> ParseScaleGrid(const std::string& text);

/// Checks the options (throws pipeline::OptionError naming the option, and
/// file and line for a bad record or polygon) and reads the records.
Plan MakePlan(const PlanOptions& options);

/// Where case `index` sits in the plan.
struct CaseIndex {
  std::size_t record{}, block{}, scale{};
};
CaseIndex Locate(const Plan& plan, std::size_t index);

/// What a user checks in a case.
struct Outcome {
  double peak_theta_over_alpha{};  ///< max |theta| / alpha of the side it rocks on, 1
  double peak_time_s{};            ///< s
  bool overturned{};
  double overturn_time_s{};        ///< s; meaningful when overturned
  int impacts{};
  std::optional<double> uplift_time_s;  ///< first uplift, s
  /// |theta| went past pi/2 without an overturn event: the model left its
  /// domain. Seen once, at an uplift where the table acceleration only
  /// touched g tan alpha (fixed in the models; RockingModelTest.
  /// UpliftTheTableDoesNotSustainEndsAtRest); kept as a guard: the row is
  /// written as computed and the run counts it and warns.
  bool beyond_pi_over_2{};
  /// Assemblies: per body bottom-up, max over the samples of |theta|, rad
  /// (a stack's samples stop at its overturning).
  std::array<double, model::stack::kMaxBodies> peak_abs_theta_rad{};
  /// Assemblies: the body that overturned first (0 the bottom one), -1 none.
  int first_overturned{-1};
};

/// The factor applied to the record of case `index` and its PGA in g.
struct Scaling {
  double factor{};  ///< multiplies the record, 1
  double pga_g{};   ///< the scaled record's PGA, g (the grid value itself under --pga-g)
};
Scaling ScalingOf(const Plan& plan, std::size_t index);

/// Runs case `index` through pipeline::RunScenario from rest at t = 0.
/// `token` (may be null) is polled every 256 output samples: one case of a
/// long record runs for seconds.
/// @throws std::runtime_error when the integrator fails, naming the case;
///         common::Cancelled when the token says stop.
Outcome RunCase(const Plan& plan, std::size_t index, const common::CancelToken* token = nullptr);

/// The model options every case of `plan` runs with (RunCase's): the
/// plan's l and rtol, ModelOptions' defaults for the rest.
model::ModelOptions CaseModelOptions(const Plan& plan);

/// What defines a sweep's cases beyond the key columns of its rows: the
/// model and its integration knobs, the sampling rate, the duration, the
/// scale kind, the grid's size and each record's samples (by hash). Written
/// into every results file (CSV: `# key: value` lines before the header;
/// HDF5: root attributes `sweep_<key>`), compared by --merge and --resume.
struct DefinitionField {
  std::string key;    ///< [a-z0-9_]+
  std::string value;  ///< one line of printable text
  bool operator==(const DefinitionField& o) const { return key == o.key && value == o.value; }
};
using Definition = std::vector<DefinitionField>;

/// `plan`'s definition, in a fixed order: model, integrator, rtol, atol,
/// max_step_s, rest_impact_interval_s, l, rate_hz, duration_s, scale_kind,
/// cases, records, then record_1..record_N ("NAME SAMPLES fnv1a64:HEX", the
/// FNV-1a 64-bit hash of the samples' time and acceleration doubles).
/// Doubles are printed with %.17g (they read back to the same double).
Definition DefinitionOf(const Plan& plan);

/// The CSV form of a definition: a "# rocklab sweep definition" line, then
/// one "# key: value" line per field, each with its newline.
std::string DefinitionText(const Definition& d);
/// Reads one line of DefinitionText (without its newline) into `d`: true
/// for its title line (nothing added) and a "# key: value" line, false for
/// any other.
bool ParseDefinitionLine(const std::string& line, Definition& d);

/// What made a results file (common::ProvenanceFields: version, command,
/// time, source files): written beside the definition, never part of it
/// (it differs between the shards and runs of one sweep).
using ProvenanceLines = std::vector<std::pair<std::string, std::string>>;
/// The CSV form: a "# rocklab provenance ..." title line, then one
/// "# provenance.KEY: value" line per field (control characters in a value
/// written as '?'), each with its newline; "" for no field.
/// ParseDefinitionLine takes these lines and adds nothing for them.
std::string ProvenanceText(const ProvenanceLines& p);

/// The key of the first field where `a` and `b` differ (a's keys in order,
/// then b's), "" when they are equal; `a_value` and `b_value` get the two
/// values ("(none)" for a key one of them lacks). The caller names files.
std::string FirstDifference(const Definition& a, const Definition& b, std::string& a_value, std::string& b_value);

/// The CSV header of a sweep of blocks (no newline).
const std::string& Header();
/// The CSV header of `plan`'s rows: Header(), and for an assembly the
/// columns after it, first_overturned_body and peak_abs_theta_1..N.
std::string HeaderOf(const Plan& plan);
/// The first columns of case `index`'s row, up to and including `model,`:
/// they name the case (record,scale,pga_g,alpha,p,mu,model,).
std::string KeyPrefix(const Plan& plan, std::size_t index);
/// The whole row of case `index`, with its newline.
std::string FormatRow(const Plan& plan, std::size_t index, const Outcome& outcome);

}  // namespace rocklab::sweep
