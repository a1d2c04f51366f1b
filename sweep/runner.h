#pragma once
/// @file
/// Runs a sweep's cases on all cores (threads) and, when rocklab is built
/// with ROCKLAB_MPI (the MPI plugin) and started by mpirun, over MPI ranks,
/// writing the rows
/// in case order.
///
/// Threading model: worker threads take the next case of this process from
/// an atomic counter and put its Outcome in a map keyed by the case's place
/// in the slice; the calling thread (the writer) takes them out in order and
/// hands them to the RowWriter. Workers run at most kWindow cases ahead of
/// the writer, so the map stays bounded when one case is slow.
///
/// MPI: the slice's remaining cases are dealt round-robin to the ranks
/// (place k to rank k mod size). Every rank runs its cases on its threads;
/// ranks other than 0 send each Outcome (its place and its values as doubles) to
/// rank 0, whose writer thread receives them beside its own and writes
/// everything in order, so the file is the threaded run's, byte for byte.
/// Only rank 0 opens the output; it tells the others how many rows
/// --resume kept. A failure on any rank prints its message and aborts the
/// job (MPI_Abort), after the rows written so far were flushed.

#include <cstddef>
#include <string>
#include <vector>

#include "sweep/row_writer.h"
#include "sweep/sweep.h"

namespace rocklab::sweep {

/// MPI for the life of a command: initialised when the process was started
/// by mpirun (OpenMPI's OMPI_COMM_WORLD_SIZE, or PMI_SIZE / PMIX_RANK, in
/// the environment), finalised by the destructor. The MPI calls are in the
/// plugin lib/rocklab/plugins/rocklab-mpi.so (mpi_plugin.h), opened only then.
/// Without the plugin (a build without ROCKLAB_MPI, or the file missing) a
/// process started by mpirun with more than one rank throws, so ranks never
/// write one file side by side.
struct MpiCalls;
class MpiSession {
 public:
  /// @throws pipeline::OptionError when started by mpirun with more than one
  ///   rank and the MPI plugin is missing or does not load (naming the file
  ///   and why).
  MpiSession();
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Whether this build has MPI (ROCKLAB_MPI): the plugin was built.
  static bool Built();
  /// MPI's calls while initialised; nullptr for a single process.
  const MpiCalls* calls() const { return calls_; }

 private:
  int rank_{0};
  int size_{1};
  const MpiCalls* calls_{nullptr};
};

struct RunOptions {
  unsigned threads{0};  ///< worker threads per process; 0: all cores (1 per rank under MPI)
  Slice slice;          ///< this run's cases (a shard, or the whole plan)
  bool resume{};        ///< keep the output's complete rows and run the rest
  bool progress{};      ///< draw a progress bar on stderr (rank 0)
  ProvenanceLines provenance;  ///< what made the output (OpenRowWriter)
};

struct RunReport {
  std::size_t cases{};       ///< in the slice
  std::size_t resumed{};     ///< rows kept from the output
  std::size_t run{};         ///< cases run now (over all ranks)
  std::size_t overturned{};  ///< of the cases run now
  /// Of the cases run now, those whose |theta| passed pi/2 without an
  /// overturn event (Outcome::beyond_pi_over_2), and the first one's key.
  std::size_t beyond_pi_over_2{};
  std::string first_beyond_pi_over_2;
  unsigned threads{};        ///< per process
  int ranks{1};
  double wall_s{};           ///< s
  /// MPI, ranks other than 0: rank 0 could not open the output (and says
  /// why); nothing ran.
  bool open_failed_on_rank0{};
};

/// Runs the slice's cases and writes their rows to `out_path` (rank 0).
/// @throws pipeline::OptionError for a bad output (OpenRowWriter);
///   std::runtime_error when a case fails (after the rows before it were written).
RunReport RunSweep(const Plan& plan, const std::string& out_path, const RunOptions& options,
                   const MpiSession& mpi);

/// Interleaves shard files of `plan` (each written by `--shard I/N` with the
/// same options and complete; CSV or HDF5, told by content, mixed as they
/// come) into `out_path`, in case order: CSV, or HDF5 for a name ending .h5
/// or .hdf5 (OpenRowWriter's choice). Every cell is kept: CSV lines into a
/// CSV are copied as written, HDF5 values into an HDF5 as their datasets
/// hold them, HDF5 into CSV printed as the CSV writer prints them (exact),
/// CSV into HDF5 the double nearest each field (an empty field NaN), so
/// the result is the unsharded file (merge.cpp says which trips are exact).
/// The output appears whole or not at all; on an error `out_path` keeps
/// what it held.
/// Every shard's definition (DefinitionOf) must equal the first shard's and
/// the plan's; a shard without one (an older rocklab's) is merged with a
/// warning, and then the output carries no definition.
/// @throws pipeline::OptionError naming the file and line (HDF5: row, from
///   1) of a row that does not belong to the plan, is there twice or that
///   sweep-plot would refuse (RowProblem), a header (HDF5: /results
///   columns) that is not a sweep's, a torn last line, the first case that
///   no file holds; naming the field, the two files and their values for
///   shards of different definitions; a directory among `parts`, or a part
///   that is `out_path` itself.
struct MergeReport {
  std::vector<std::string> warnings;  ///< one line each, naming the file
};
/// `provenance`: what made the merged file (the merge's command and its
/// parts), written beside the definition (the shards' own are not compared).
MergeReport MergeShards(const Plan& plan, const std::vector<std::string>& parts, const std::string& out_path,
                        const ProvenanceLines& provenance = {});

}  // namespace rocklab::sweep
