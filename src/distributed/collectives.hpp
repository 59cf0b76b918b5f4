#pragma once
// The few collective operations a run over ranks needs, over MPI_COMM_WORLD; every rank calls
// each of them at the same point of the run.
#include <span>
#include <string>
#include <vector>

namespace qbond::distributed {

// The element-wise maximum over the ranks of `flags`, into `flags` on every rank.
void max_over_ranks(std::span<int> flags);
// Every rank's `mine`, concatenated in rank order, on every rank.
std::vector<double> all_gather(std::span<const double> mine);
// Every rank's `mine`, concatenated in rank order, on rank 0 (empty on the others).
std::vector<double> gather_to_root(std::span<const double> mine);
// Rank `root`'s `text`, into `text` on every rank.
void broadcast(std::string& text, int root);
// How many ranks run on this rank's machine.
int ranks_on_this_node();
// Ends every rank of the job with exit code `code` (an error one rank met that the others,
// waiting in a collective, would never learn of).
[[noreturn]] void abort_job(int code);

}  // namespace qbond::distributed
