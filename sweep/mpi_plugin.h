#pragma once
/// @file
/// The MPI calls of `rocklab sweep` under mpirun, as a table of functions
/// that the plugin lib/rocklab/plugins/rocklab-mpi.so fills (sweep/mpi_plugin.cpp,
/// the one file that includes mpi.h). runner.cpp opens the plugin only when
/// the process was started by mpirun, so no other command (and no sweep
/// without mpirun) maps OpenMPI's libraries (docs/sweep.md, MPI).

namespace rocklab::sweep {

/// The plugin's entry: `extern "C" const MpiCalls* rocklab_mpi_plugin()`.
inline constexpr const char* kMpiPluginEntry = "rocklab_mpi_plugin";
inline constexpr const char* kMpiPluginFile = "rocklab-mpi.so";
/// MpiCalls::version of this build; a plugin with another is refused.
inline constexpr int kMpiPluginVersion = 1;

/// MPI_COMM_WORLD's calls, C types only. Only the thread that called
/// init makes calls (MPI_THREAD_FUNNELED).
struct MpiCalls {
  int version;
  /// MPI_Init_thread (FUNNELED), then this process's rank and the world's size.
  void (*init)(int* rank, int* size);
  void (*finalize)();
  /// MPI_Abort of the job, exit code 1.
  void (*abort)();
  /// `count` values broadcast from rank 0.
  void (*broadcast)(unsigned long long* values, int count);
  /// `count` doubles to rank 0, tag 0.
  void (*send_to_root)(const double* values, int count);
  /// 1 when `count` doubles from any rank (tag 0) were waiting and were received into `values`; else 0.
  int (*try_receive)(double* values, int count);
};

}  // namespace rocklab::sweep
