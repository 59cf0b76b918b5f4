// MPI's life in the program, and the collectives of collectives.hpp (built with MPI).
#include <mpi.h>

#include <cstdlib>
#include <stdexcept>

#include "distributed/collectives.hpp"
#ifdef QBOND_DISTRIBUTED_IMPLICIT
#include "distributed/coupled_over_ranks.hpp"
#endif
#include "qbond/distributed/distributed.hpp"

namespace qbond {

namespace {
bool g_started = false;  // this object started MPI (it then finalises it)

// Whether a launcher (mpirun, mpiexec, srun) started this process as one of a job's ranks.
bool launched_as_rank() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "PMI_RANK"})
    if (std::getenv(name)) return true;
  return false;
}
}  // namespace

MpiSession::MpiSession(int& argc, char**& argv) {
  int ready = 0;
  MPI_Initialized(&ready);
  if (ready || !launched_as_rank()) return;
  if (MPI_Init(&argc, &argv) != MPI_SUCCESS) throw std::runtime_error("MPI_Init failed");
  g_started = true;
}

MpiSession::~MpiSession() {
#ifdef QBOND_DISTRIBUTED_IMPLICIT
  distributed::end_petsc();  // PETSc ends before the MPI it runs on
#endif
  if (!g_started) return;
  int done = 0;
  MPI_Finalized(&done);
  if (!done) MPI_Finalize();
  g_started = false;
}

bool built_with_mpi() { return true; }

int mpi_rank() {
  int ready = 0;
  MPI_Initialized(&ready);
  if (!ready) return 0;
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int mpi_ranks() {
  int ready = 0;
  MPI_Initialized(&ready);
  if (!ready) return 1;
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

}  // namespace qbond

namespace qbond::distributed {

void max_over_ranks(std::span<int> flags) {
  MPI_Allreduce(MPI_IN_PLACE, flags.data(), static_cast<int>(flags.size()), MPI_INT, MPI_MAX, MPI_COMM_WORLD);
}

namespace {
// Counts and displacements of a gather of `mine` from every rank (on every rank).
std::vector<int> counts_of(std::span<const double> mine, std::vector<int>& displs) {
  const int ranks = mpi_ranks();
  std::vector<int> counts(static_cast<std::size_t>(ranks));
  int n = static_cast<int>(mine.size());
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  displs.assign(counts.size(), 0);
  for (std::size_t r = 1; r < counts.size(); ++r) displs[r] = displs[r - 1] + counts[r - 1];
  return counts;
}
}  // namespace

std::vector<double> all_gather(std::span<const double> mine) {
  std::vector<int> displs;
  const std::vector<int> counts = counts_of(mine, displs);
  std::vector<double> all(static_cast<std::size_t>(displs.back() + counts.back()));
  MPI_Allgatherv(mine.data(), static_cast<int>(mine.size()), MPI_DOUBLE, all.data(), counts.data(), displs.data(),
                 MPI_DOUBLE, MPI_COMM_WORLD);
  return all;
}

std::vector<double> gather_to_root(std::span<const double> mine) {
  std::vector<int> displs;
  const std::vector<int> counts = counts_of(mine, displs);
  const bool root = mpi_rank() == 0;
  std::vector<double> all(root ? static_cast<std::size_t>(displs.back() + counts.back()) : 0);
  MPI_Gatherv(mine.data(), static_cast<int>(mine.size()), MPI_DOUBLE, all.data(), counts.data(), displs.data(),
              MPI_DOUBLE, 0, MPI_COMM_WORLD);
  return all;
}

void broadcast(std::string& text, int root) {
  int n = static_cast<int>(text.size());
  MPI_Bcast(&n, 1, MPI_INT, root, MPI_COMM_WORLD);
  text.resize(static_cast<std::size_t>(n));
  MPI_Bcast(text.data(), n, MPI_CHAR, root, MPI_COMM_WORLD);
}

int ranks_on_this_node() {
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int n = 1;
  MPI_Comm_size(node, &n);
  MPI_Comm_free(&node);
  return n;
}

void abort_job(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::abort();  // MPI_Abort does not return; this tells the compiler so
}

}  // namespace qbond::distributed
