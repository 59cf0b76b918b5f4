// Built without MPI (QBOND_MPI off): one rank, and a RanksRun is the ordinary run. Started by a
// launcher as one of several ranks, the program says it cannot take part (rather than run the
// same scene once per rank into one directory).
#include <algorithm>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

#include "qbond/distributed/distributed.hpp"

namespace qbond {

MpiSession::MpiSession(int& /*argc*/, char**& /*argv*/) {}
MpiSession::~MpiSession() = default;

namespace {
// The launcher's variable `names` gives (Open MPI's, then PMI's), or `otherwise`.
int launcher_value(const char* ompi, const char* pmi, int otherwise) {
  for (const char* name : {ompi, pmi})
    if (const char* v = std::getenv(name)) return std::atoi(v);
  return otherwise;
}
}  // namespace

bool built_with_mpi() { return false; }
int mpi_rank() { return launcher_value("OMPI_COMM_WORLD_RANK", "PMI_RANK", 0); }
int mpi_ranks() { return std::max(1, launcher_value("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", 1)); }

struct RanksRun::Impl {
  std::optional<Runner> runner;
  RanksStats stats;
};

RanksRun::RanksRun(Scene scene, RunSettings settings) : impl_(std::make_unique<Impl>()) {
  if (mpi_ranks() > 1)
    throw std::invalid_argument("this qbond was built without MPI (QBOND_MPI off) and cannot run over " +
                                std::to_string(mpi_ranks()) + " ranks; run it without mpirun");
  impl_->runner.emplace(std::move(scene), std::move(settings));
}
RanksRun::RanksRun(const std::filesystem::path& checkpoint, const std::function<void(Scene&, RunSettings&)>& adjust,
                   std::uint64_t max_memory)
    : impl_(std::make_unique<Impl>()) {
  if (mpi_ranks() > 1)
    throw std::invalid_argument("this qbond was built without MPI (QBOND_MPI off) and cannot run over " +
                                std::to_string(mpi_ranks()) + " ranks; run it without mpirun");
  impl_->runner.emplace(Runner::resume(checkpoint, adjust, max_memory));
}
RanksRun::~RanksRun() = default;

RunResult RanksRun::run(const std::function<bool()>& stop, const std::function<void(const RunProgress&)>& progress) {
  return impl_->runner->run(stop, progress);
}

const RanksStats& RanksRun::stats() const { return impl_->stats; }
const World& RanksRun::world() const { return impl_->runner->simulation().world(); }
const Scene& RanksRun::scene() const { return impl_->runner->scene(); }
const RunSettings& RanksRun::settings() const { return impl_->runner->settings(); }

}  // namespace qbond
