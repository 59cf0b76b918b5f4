#include "qbond/model/selection.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "qbond/model/ordering.hpp"

namespace qbond {

std::vector<Index> select(const World& world, const Selection& s) {
  const std::size_t n = world.num_quanta();
  const Model& m = world.model;
  std::vector<std::uint8_t> picked(n, 1);
  if (s.ids) {
    // Ids are the user's (creation order), whatever the world's numbering (ordering.hpp):
    // members[k] is the quanta of user id k, or the body's k-th in creation order.
    std::vector<Index> members = quanta_by_id(m);
    if (s.body) std::erase_if(members, [&](Index i) { return m.body[i] != *s.body; });
    const std::size_t range = members.size();
    std::fill(picked.begin(), picked.end(), 0);
    for (Index id : *s.ids) {
      if (id >= range)
        throw std::out_of_range("id " + std::to_string(id) + " is out of range (valid: 0.." +
                                std::to_string(range == 0 ? 0 : range - 1) + ")");
      picked[members[id]] = 1;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!picked[i]) continue;
    const Vec3& x = world.state.x[i];
    bool ok = !s.body || m.body[i] == *s.body;
    if (s.box) ok = ok && (x.array() >= s.box->first.array()).all() && (x.array() <= s.box->second.array()).all();
    if (s.sphere) ok = ok && (x - s.sphere->first).norm() <= s.sphere->second;
    if (s.half_space) ok = ok && (x - s.half_space->first).dot(s.half_space->second) >= 0;
    picked[i] = ok;
  }
  std::vector<Index> out;
  for (std::size_t i = 0; i < n; ++i)
    if (picked[i]) out.push_back(static_cast<Index>(i));
  return out;
}

}  // namespace qbond
