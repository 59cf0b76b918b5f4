// The canonical workload (docs/performance.md) in Bullet's btSoftBody: one node per quanta
// (1 g), one link per bond (nearest and face-diagonal neighbours), the x = 0 face pinned (mass
// 0), gravity -9.81 m/s² along z, a fixed step. Built and run by bench/peers/run.
//
//   bullet_canonical N H STEPS [PITERATIONS [KDP [EVERY]]]
//
// Prints one line of key=value: quanta, links, seconds_per_step, max_speed (m/s, at the end;
// a run that blew up shows a huge or non-finite speed). KDP is Bullet's velocity damping (each
// step scales the velocities by 1 - KDP; default 0). With EVERY > 0 the run starts at rest with
// no warm-up steps and first prints `tip T X Y Z` every EVERY steps: the free face's (x = (N-1) a)
// centre of mass at time T. Bullet's links are position
// constraints with a stiffness factor in [0, 1], not springs of k N/m: the topology, masses,
// anchors and step are the workload's, the material law is Bullet's own (kLST = 1).
#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <BulletSoftBody/btDefaultSoftBodySolver.h>
#include <btBulletDynamicsCommon.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: bullet_canonical N H STEPS [PITERATIONS [KDP [EVERY]]]\n");
    return 2;
  }
  const int n = std::atoi(argv[1]), steps = std::atoi(argv[3]), piterations = argc > 4 ? std::atoi(argv[4]) : 1;
  const double h = std::atof(argv[2]), a = 0.01, kdp = argc > 5 ? std::atof(argv[5]) : 0;
  const int every = argc > 6 ? std::atoi(argv[6]) : 0;
  if (n < 2 || steps < 1 || !(h > 0) || piterations < 1 || !(kdp >= 0 && kdp <= 1) || every < 0) {
    std::fprintf(stderr, "bullet_canonical: bad arguments\n");
    return 2;
  }
  auto config = std::make_unique<btSoftBodyRigidBodyCollisionConfiguration>();
  auto dispatcher = std::make_unique<btCollisionDispatcher>(config.get());
  auto broadphase = std::make_unique<btDbvtBroadphase>();
  auto constraints = std::make_unique<btSequentialImpulseConstraintSolver>();
  auto soft_solver = std::make_unique<btDefaultSoftBodySolver>();
  btSoftRigidDynamicsWorld world(dispatcher.get(), broadphase.get(), constraints.get(), config.get(), soft_solver.get());
  world.setGravity(btVector3(0, 0, -9.81));
  btSoftBodyWorldInfo& info = world.getWorldInfo();
  info.m_gravity = btVector3(0, 0, -9.81);
  info.m_sparsesdf.Initialize();

  auto* body = new btSoftBody(&info);  // owned by the world once added
  // The material first: appendNode gives each node the body's first material.
  btSoftBody::Material* mat = body->appendMaterial();
  mat->m_kLST = 1;
  auto id = [n](int i, int j, int k) { return (k * n + j) * n + i; };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) body->appendNode(btVector3(i * a, j * a, k * a), i == 0 ? 0 : 1e-3);
  // Nearest neighbours along each axis, and both diagonals of every face square.
  auto link = [&](int p, int q) { body->appendLink(p, q, mat, false); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int p = id(i, j, k);
        if (i + 1 < n) link(p, id(i + 1, j, k));
        if (j + 1 < n) link(p, id(i, j + 1, k));
        if (k + 1 < n) link(p, id(i, j, k + 1));
        if (i + 1 < n && j + 1 < n) link(p, id(i + 1, j + 1, k)), link(id(i + 1, j, k), id(i, j + 1, k));
        if (i + 1 < n && k + 1 < n) link(p, id(i + 1, j, k + 1)), link(id(i + 1, j, k), id(i, j, k + 1));
        if (j + 1 < n && k + 1 < n) link(p, id(i, j + 1, k + 1)), link(id(i, j + 1, k), id(i, j, k + 1));
      }
  body->m_cfg.piterations = piterations;
  body->m_cfg.kDP = kdp;                    // Bullet's own damping: none unless asked
  body->m_cfg.collisions = 0;               // no collision detection: the workload has none
  body->getCollisionShape()->setMargin(0);
  world.addSoftBody(body);

  auto tip = [&](double t) {
    btVector3 c(0, 0, 0);
    int count = 0;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j, ++count) c += body->m_nodes[id(n - 1, j, k)].m_x;
    c /= btScalar(count);
    std::printf("tip %.9g %.9g %.9g %.9g\n", t, double(c.x()), double(c.y()), double(c.z()));
  };
  if (every == 0)
    for (int s = 0; s < 3; ++s) world.stepSimulation(h, 0, h);  // warm up
  const auto t0 = std::chrono::steady_clock::now();
  for (int s = 1; s <= steps; ++s) {
    world.stepSimulation(h, 0, h);
    if (every > 0 && s % every == 0) tip(s * h);
  }
  if (every > 0 && steps % every != 0) tip(steps * h);
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / steps;
  double vmax = 0;
  for (int q = 0; q < body->m_nodes.size(); ++q) {
    const double v = body->m_nodes[q].m_v.length();
    vmax = std::isfinite(v) ? std::max(vmax, v) : INFINITY;
  }
  std::printf("quanta=%d links=%d seconds_per_step=%.9g max_speed=%.6g\n", body->m_nodes.size(), body->m_links.size(), sec,
              vmax);
  world.removeSoftBody(body);
  delete body;
  return 0;
}
