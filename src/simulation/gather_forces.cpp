#include "core/parallel.hpp"
#include "simulation/stages.hpp"

namespace qbond::stage {

void gather_forces(const Model& m, const StepIntegrator& integrator, bool in_place, StepScratch& k) {
  // Gravity alone, in a step advanced in place, is formed by an integrator that can in its own
  // passes: no pass over the quanta to fill f_ext, and none of its reads.
  k.gravity_alone = in_place && !k.forces_queued && m.loads.empty() && integrator.forms_gravity();
  if (k.gravity_alone) return;
  const std::size_t n = m.num_quanta();
  k.f_ext.resize(n);
  const bool user = k.forces_queued;  // else f_user is all zero and not read
  parallel_for(n, integrator.config().threads, [&](std::size_t i) {
    k.f_ext[i] = m.mass[i] * m.gravity;
    if (user) k.f_ext[i] += k.f_user[i];
  });
  for (const Load& load : m.loads) {
    if (load.quanta.empty()) continue;
    const Vec3 share = load.share();
    for (Index i : load.quanta) k.f_ext[i] += share;
  }
}

}  // namespace qbond::stage
