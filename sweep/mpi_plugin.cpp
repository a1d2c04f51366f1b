// lib/rocklab/plugins/rocklab-mpi.so: sweep's MPI calls (sweep/mpi_plugin.h), the
// only place rocklab includes mpi.h and links OpenMPI.
// The C interface only: OpenMPI's deprecated C++ bindings do not compile
// cleanly under -Wextra.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>

#include <cstdio>

#include "sweep/mpi_plugin.h"

namespace rocklab::sweep {
namespace {

void Init(int* rank, int* size) {
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, rank);
  MPI_Comm_size(MPI_COMM_WORLD, size);
}

void Finalize() { MPI_Finalize(); }

// Every stdio stream flushed first: what this rank printed is not lost
// when MPI_Abort ends it.
void Abort() {
  std::fflush(nullptr);
  MPI_Abort(MPI_COMM_WORLD, 1);
}

void Broadcast(unsigned long long* values, int count) {
  MPI_Bcast(values, count, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
}

void SendToRoot(const double* values, int count) {
  MPI_Send(values, count, MPI_DOUBLE, 0, 0, MPI_COMM_WORLD);
}

int TryReceive(double* values, int count) {
  int flag = 0;
  MPI_Status status;
  MPI_Iprobe(MPI_ANY_SOURCE, 0, MPI_COMM_WORLD, &flag, &status);
  if (!flag) return 0;
  MPI_Recv(values, count, MPI_DOUBLE, status.MPI_SOURCE, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return 1;
}

const MpiCalls kCalls{kMpiPluginVersion, &Init, &Finalize, &Abort, &Broadcast, &SendToRoot, &TryReceive};

}  // namespace
}  // namespace rocklab::sweep

extern "C" __attribute__((visibility("default"))) const rocklab::sweep::MpiCalls* rocklab_mpi_plugin() {
  return &rocklab::sweep::kCalls;
}
