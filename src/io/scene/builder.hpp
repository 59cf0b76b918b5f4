#pragma once
// The scene builder: reads a scene's JSON document section by section (each section's member
// functions are defined in the file named above them) into a Scene, and records the resolved
// scene, with every default filled in.
#include <map>
#include <span>
#include <string_view>

#include "io/scene/json_reader.hpp"
#include "io/scene/scene_keys.hpp"
#include "qbond/builders/packing.hpp"
#include "qbond/io/scene.hpp"

namespace qbond::scene_detail {

inline constexpr double kMaxQuanta = 5e7;  // a scene larger than this is a typo, not a simulation

std::uint64_t pair_key(Index a, Index b);

struct Material {
  BondSpec bond;              ///< stiffness 0 when the material is given by a modulus
  double youngs_modulus = 0;  ///< [Pa]; > 0: bond stiffness from the body's lattice (materials.hpp)
  double density = 0;         ///< [kg/m³]; > 0: quanta masses from the body's lattice
};

struct BodyEntry;  // one `bodies` entry as its type's builder reads it (body_entry.hpp)
struct HeuristicEntry;  // one `heuristics` entry as its type's reader reads it (heuristic_entry.hpp)

// One scene type of the `heuristics` section: the type, what it does, the keys it accepts (in
// the order error messages list them) and its reader, which appends the rule(s) an entry makes.
// Each rule's file lists its types (heuristic_entry.hpp).
struct HeuristicReader {
  const char* type;
  const char* doc;
  std::vector<SceneKey> keys;
  void (*read)(const HeuristicEntry& e);
};

class Builder {
 public:
  // builder.cpp: the scene's top level and its scene-wide sections (integrator, adaptive, limits)
  Builder(const json& root, std::string default_name, SceneFiles files = {});

  // Renumbers the built world for locality (ordering.hpp), and with it every per-quanta list the
  // scene holds; ids in the scene stay the user's (Model::quanta_id).
  static void renumber_for_locality(Scene& s);

  Scene build();

  // The heuristic types' table: each registered rule's scene types (QBOND_HEURISTICS), in the
  // registry's order.
  static std::span<const HeuristicReader> heuristic_readers();

  // One row of the body types' table (bodies.cpp): the type, what it makes, the keys it accepts
  // and its builder.
  struct BodyReader {
    const char* type;
    const char* doc;
    std::vector<SceneKey> keys;
    std::vector<Index> (*build)(const BodyEntry& e);
  };
  static std::span<const BodyReader> body_readers();

  // The public list (scene.hpp) of a table's types and their keys' names.
  template <class Row>
  static std::vector<SceneType> scene_types(std::span<const Row> rows) {
    std::vector<SceneType> t;
    for (const Row& r : rows) {
      std::vector<std::string_view> keys;
      for (const SceneKey& k : r.keys) keys.emplace_back(k.name);
      t.push_back({r.type, r.doc, std::move(keys)});
    }
    return t;
  }

 private:
  friend struct BodyEntry;
  friend struct HeuristicEntry;

  IntegratorConfig integrator(const json& j);

  // Adds a body's quanta and (an estimate of) its bonds to the world planned so far, and refuses
  // it at `path` when the run would then need more memory than allowed (before it is built).
  void plan_memory(const std::string& path, double quanta, double bonds);
  void check_memory(const std::string& path, double quanta, double bonds) const;
  // How many more bonds than planned so far fit in the memory limit.
  std::size_t bonds_left() const;
  std::uint64_t memory_limit() const;

  AdaptiveConfig adaptive(const json& j, double timestep, double horizon);

  BlowupLimits limits(const json& j);
  /// The `camera` section.
  CameraSpec camera(const json& j);

  // materials.cpp: the `materials` section: named bond materials
  // Each material's law and its keys come from the law registry (laws/registry.hpp): the law's
  // strength and shape parameters, with their defaults and checks.
  void materials(const json& j, json& res);

  // A material for a single bond: it must say its stiffness (a modulus needs a lattice).
  BondSpec bond_material(const json& j, const std::string& path);

  const Material& material(const json& j, const std::string& path);

  // bodies.cpp: the `bodies` section: lattices, sheets, chains, quanta, packings, meshes and gases
  void bodies(const json& j, json& res, World& w);

  void body(const json& j, const std::string& path, json& res, World& w);

  /// What a packing or mesh body does with quanta left without a bond.
  Isolated isolated(const json& j, const std::string& path, json& res);

  /// Builders that learn their quanta count only once built (packings, meshes) make 1 kg quanta;
  /// this gives them their mass, `mass_of(count, ρ V)` (whose key checks ran before building),
  /// and the volume each quanta stands for.
  template <class MassOf>
  void set_masses(World& w, const std::vector<Index>& ids, const MassOf& mass_of, const Material& mat, double volume);

  /// A `gas` body: unbonded quanta at random positions with thermal velocities (gas.hpp).
  template <class MassOf>
  std::vector<Index> gas_body(const json& j, const std::string& path, json& res, World& w, Index id,
                              const MassOf& mass_of);

  /// A `packing` body: Poisson-disk or random points bonded within a radius (packing.hpp).
  template <class MassOf>
  std::vector<Index> packing_body(const json& j, const std::string& path, json& res, World& w, Index id,
                                  const MassOf& mass_of, const Material& mat);

  /// The bytes of a file the scene names, and how the resolved scene names it: an absolute path,
  /// or "builtin:REL" for a file compiled in from scenes/ (which a resumed run finds again).
  std::pair<std::string, std::string> scene_file(const std::string& file, const std::string& path);

  /// A `mesh` body: a closed OBJ/STL mesh voxelised into a simple-cubic lattice (packing.hpp).
  template <class MassOf>
  std::vector<Index> mesh_body(const json& j, const std::string& path, json& res, World& w, Index id,
                               const MassOf& mass_of, const Material& mat);

  // connections.cpp: selections, and the `bonds`, `anchors` and `loads` sections
  std::vector<Index> selection(const json& j, const std::string& path, const World& w);

  void bonds(const json& j, World& w);

  void check_overlaps(const World& w);

  void anchors(const json& j, World& w);
  /// An anchor's keyframed motion (`motion.keyframes`).
  Motion keyframes(const json& j, const std::string& path);

  void loads(const json& j, World& w);

  // heuristics.cpp: the `heuristics` section, each entry read by its type's reader (the rule's
  // own file); obstacles solved inside the step join the model instead.
  std::vector<HeuristicSpec> heuristics(const json& j, World& w);

  // output.cpp: the `output` section
  OutputSpec output(const json& j, std::uint64_t steps, const World& w);

  const json& root_;
  std::string default_name_;
  std::map<std::string, Material> materials_;
  std::map<std::string, Index> body_index_;
  SceneFiles files_;
  std::size_t obstacles_ = 0;  // obstacles numbered so far (their Obstacle::record)
  IntegratorConfig integrator_;  // the scene's (obstacles solved in the step need coupled_implicit)
  double planned_quanta_ = 0, planned_bonds_ = 0;  // of the bodies so far (plan_memory)
};

}  // namespace qbond::scene_detail
