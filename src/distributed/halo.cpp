#include "distributed/halo.hpp"

#include <mpi.h>

#include <stdexcept>

namespace qbond::distributed {

void Halo::transfer(const HaloPlan& plan) {
  constexpr int kTag = 1;  // the ghost exchange's messages
  std::vector<MPI_Request> requests(2 * plan.peers.size());
  for (std::size_t p = 0; p < plan.peers.size(); ++p)
    MPI_Irecv(recv_[p].data(), static_cast<int>(recv_[p].size()), MPI_DOUBLE, plan.peers[p], kTag, MPI_COMM_WORLD,
              &requests[2 * p]);
  for (std::size_t p = 0; p < plan.peers.size(); ++p) {
    MPI_Isend(send_[p].data(), static_cast<int>(send_[p].size()), MPI_DOUBLE, plan.peers[p], kTag, MPI_COMM_WORLD,
              &requests[2 * p + 1]);
    sent_ += send_[p].size();
  }
  if (MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE) != MPI_SUCCESS)
    throw std::runtime_error("ghost exchange between ranks failed");
}

}  // namespace qbond::distributed
