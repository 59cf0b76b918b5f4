#pragma once
// The ghost exchange: each rank sends its peers the values of the owned quanta they hold as
// ghosts and writes what it receives into its own ghosts' rows (point to point, MPI_COMM_WORLD).
#include <vector>

#include "distributed/local_world.hpp"

namespace qbond::distributed {

class Halo {
 public:
  // Sends `width` doubles per quanta of each peer's send list, written by pack(q, out), and hands
  // each quanta of the recv lists its values, unpack(q, in): q is a local quanta index.
  template <class Pack, class Unpack>
  void exchange(const HaloPlan& plan, std::size_t width, Pack&& pack, Unpack&& unpack) {
    send_.resize(plan.peers.size());
    recv_.resize(plan.peers.size());
    for (std::size_t p = 0; p < plan.peers.size(); ++p) {
      send_[p].resize(width * plan.send[p].size());
      recv_[p].resize(width * plan.recv[p].size());
      for (std::size_t k = 0; k < plan.send[p].size(); ++k) pack(plan.send[p][k], send_[p].data() + width * k);
    }
    transfer(plan);
    for (std::size_t p = 0; p < plan.peers.size(); ++p)
      for (std::size_t k = 0; k < plan.recv[p].size(); ++k) unpack(plan.recv[p][k], recv_[p].data() + width * k);
  }
  // Doubles this rank sent in its exchanges so far.
  std::size_t doubles_sent() const { return sent_; }

 private:
  void transfer(const HaloPlan& plan);  // every send_ to its peer, every recv_ from its peer
  std::vector<std::vector<double>> send_, recv_;
  std::size_t sent_ = 0;
};

}  // namespace qbond::distributed
