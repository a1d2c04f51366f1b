#pragma once
/// @file
/// An assembly of rigid bodies as `rocklab simulate --assembly FILE.toml`
/// and Python's `rocklab.simulate(assembly=...)` take it: the file's
/// reading (every error names the file, the line and the key) and its run.
/// A one-body assembly and a rocking frame are run by the single-block
/// model (pipeline/scenario.h) with the body's alpha, p and mu (the frame's
/// equivalent block, model::stack::FrameEquivalent); a stack of two or more
/// bodies by model::stack::Simulate. The file's keys: docs/commands.md,
/// "simulate --assembly".

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "model/block.h"
#include "model/rocking_model.h"
#include "model/stack.h"
#include "model/variant.h"
#include "pipeline/scenario.h"

namespace rocklab::pipeline {

/// One `[[body]]`, bottom-up.
struct AssemblyBody {
  std::string name;
  double width_m{};   ///< 0 for a polygon section
  double height_m{};  ///< 0 for a polygon section
  double mass_kg{};   ///< mass_kg, or depth_m * width_m * height_m * density_kg_m3 (0 for a polygon)
  std::string polygon_csv;  ///< a section as `params --polygon` takes it (one-body assemblies), relative to the file
};

/// A stack (`[[body]]` tables with optional `[[interface]]` tables) or a
/// frame (`[frame]`).
struct Assembly {
  std::string path;                   ///< the file, for messages and JSON
  std::vector<AssemblyBody> bodies;   ///< bottom-up; empty for a frame
  /// Per interface bottom-up (0: under the bottom body): its restitution, or
  /// < 0 for the angular momentum rule (no `restitution` key).
  std::vector<double> restitution;
  std::optional<model::stack::Frame> frame;

  /// Bodies in the output: 1 for a frame.
  int output_bodies() const { return frame ? 1 : static_cast<int>(bodies.size()); }
  /// The name of output body k (a frame's: "frame").
  std::string body_name(int k) const;
  /// "block" (one body), "frame" or "stack".
  const char* kind() const;
};

/// Reads an assembly file. @throws OptionError "--assembly: PATH:LINE: key
/// 'KEY' ..." for a missing, unknown or mistyped key, a value out of range,
/// mass given both ways, or a polygon in a stack of several bodies.
Assembly ReadAssembly(const std::string& path);
/// The same from TOML text; `name` stands for the file in messages and
/// resolves a relative polygon path (its folder).
Assembly ParseAssembly(const std::string& text, const std::string& name);

/// The single block that a one-body assembly or a frame is (the symmetric
/// section's alpha, p and mu, or the interface's restitution as mu);
/// nullopt for a stack of several bodies. @throws OptionError naming the
/// file for a section the single block cannot take (asymmetric polygon).
std::optional<model::BlockParams> EquivalentBlock(const Assembly& assembly);

/// An event of an assembly's run.
struct AssemblyEvent {
  double time_s{};
  model::EventKind kind{};
  int interface{};  ///< 0: the table; k: under output body k (the body it names)
  std::string mode;  ///< the contact states after it (ModeName)
};

/// An assembly's run: samples at t = k / rate, angles in the single block's
/// convention (theta > 0 rocking on the +x corner).
struct AssemblyRun {
  std::string kind;                 ///< Assembly::kind()
  std::vector<std::string> names;   ///< output bodies, bottom-up
  std::vector<double> time_s;
  std::vector<std::vector<double>> theta;      ///< [body][sample], rad
  std::vector<std::vector<double>> theta_dot;  ///< [body][sample], rad/s
  std::vector<std::string> mode;    ///< per sample: C closed, L/R pivot per interface bottom-up
  std::vector<AssemblyEvent> events;
  std::optional<model::BlockParams> block;  ///< the single block run (block, frame)
  std::string forcing_description;
  long steps{};                     ///< the integrator's
  /// A stack's impacts resolved within the contacts' preloads, and with
  /// pivots held (a block that would jump kept on its pivot): the stack
  /// model's assumptions (docs/models.md, "Impacts: the contact states after").
  int impacts_preload{};
  int impacts_held_pivots{};
};

/// Runs `assembly` from rest under the options' table motion, for their
/// duration at their rate (their model, tolerance, l and hand-off; alpha, p,
/// mu and theta0 are not read). A stack's rows stop at an overturning (its
/// model stops there); a single block's go on to the end, as `simulate`'s.
/// @throws OptionError for a bad option (--model complex on a stack of
/// several bodies), std::runtime_error when the integration fails.
AssemblyRun RunAssembly(const Assembly& assembly, const ScenarioOptions& options);

/// Refuses a model the assembly cannot run: anything but housner or
/// complex, and complex on a stack of several bodies (eq. (10)'s extension
/// is not derived). @throws OptionError naming the file.
void CheckAssemblyModel(const Assembly& assembly, const std::string& model);

/// Runs a stack of two or more bodies (EquivalentBlock is nullopt) from
/// rest under `forcing` (described by `forcing_description`) for the
/// options' duration at their rate, with their tolerance: RunAssembly's
/// stack path, which `sweep --assembly` shares with `simulate --assembly`.
/// `cancelled` is polled every model::stack::kCancelPollOutputs samples.
/// @throws OptionError as RunAssembly, std::runtime_error when the
/// integration fails, model::Cancelled when `cancelled` says stop.
AssemblyRun RunStackUnder(const Assembly& assembly, const ScenarioOptions& options, const model::Forcing& forcing,
                          const std::string& forcing_description, const model::CancelHook& cancelled = {});

/// A stack of two or more bodies (EquivalentBlock is nullopt) as the model
/// integrates it: each body's rectangle and mass.
model::stack::Stack StackOf(const Assembly& assembly);

/// Fills an assembly variant (`NAME:MODEL:FILE.toml`, VariantSpec::
/// assembly_path set) from its file: a one-body assembly or a frame its
/// single block's params; a stack its stack, restitution, body names and
/// the summary params (StackRowParams). @throws OptionError naming the
/// file, line and key, or the model a stack cannot take.
void ResolveAssemblyVariant(model::VariantSpec& variant);

/// The single-block parameters that name a stack of two or more bodies in
/// a sweep's rows (docs/sweep.md, "Assemblies"): alpha the stack's uplift
/// from rest, tan(alpha) = min over interfaces k of c_k M_k / S_k (M_k the
/// mass above interface k, S_k its first moment about the interface's
/// height, c_k the contact face's half-width); p and mu those of the stack
/// rocking as one body on its base corner, p^2 = M g R / I_O, mu = 1 - 2 M
/// c_0^2 / I_O (or the first interface's restitution when given). A single
/// rectangle gives its own alpha, p and 1 - 1.5 sin^2(alpha).
/// @throws OptionError for a frame or a one-body assembly (EquivalentBlock).
model::BlockParams StackRowParams(const Assembly& assembly);

/// What a user checks first in an assembly's run.
struct AssemblySummary {
  std::vector<double> peak_abs_theta;  ///< per output body, rad
  std::vector<double> peak_time_s;     ///< per output body, s
  std::optional<double> uplift_time_s; ///< the first uplift, s
  int impacts{};
  std::optional<double> overturn_time_s;  ///< the first overturning, s
  std::string overturned_body;            ///< the body on the interface that overturned
  std::set<std::string> modes;            ///< the modes of the samples
  int mode_changes{};                     ///< between successive samples
};
AssemblySummary Summarise(const AssemblyRun& run);

/// The run's summary as `simulate --assembly --json` prints it and Python's
/// result holds it (JSON text, indented by 2; keys: docs/commands.md).
std::string AssemblySummaryJson(const ScenarioOptions& options, const std::string& path, const AssemblyRun& run,
                                const AssemblySummary& summary, double cpu_s);

}  // namespace rocklab::pipeline
