#pragma once
/// Selections of quanta for anchors, loads, bonds and probes (docs/scene-format.md).
#include <optional>
#include <utility>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// A set of quanta chosen by criteria that must all hold (an intersection), on current positions.
struct Selection {
  std::optional<std::vector<Index>> ids;            ///< user ids (Model::quanta_id), or body-local
                                                    ///< (creation order) when `body` is set
  std::optional<Index> body;                        ///< body id
  std::optional<std::pair<Vec3, Vec3>> box;         ///< [min, max], inclusive
  std::optional<std::pair<Vec3, double>> sphere;    ///< centre, radius (inclusive)
  std::optional<std::pair<Vec3, Vec3>> half_space;  ///< point, normal: (x − point)·normal ≥ 0
  bool all = false;                                 ///< every quanta
};

/// The quanta a selection picks, in increasing index order. Ids out of range throw
/// std::out_of_range naming the id and the valid range.
std::vector<Index> select(const World& world, const Selection& s);

}  // namespace qbond
