// Built without MPI (QBOND_MPI off): one rank, and a RanksRun is the ordinary run.
#include <optional>

#include "qbond/distributed/distributed.hpp"

namespace qbond {

MpiSession::MpiSession(int& /*argc*/, char**& /*argv*/) {}
MpiSession::~MpiSession() = default;

bool built_with_mpi() { return false; }
int mpi_rank() { return 0; }
int mpi_ranks() { return 1; }

struct RanksRun::Impl {
  std::optional<Runner> runner;
  RanksStats stats;
};

RanksRun::RanksRun(Scene scene, RunSettings settings) : impl_(std::make_unique<Impl>()) {
  impl_->runner.emplace(std::move(scene), std::move(settings));
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
