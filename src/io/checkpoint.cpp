#include "qbond/io/checkpoint.hpp"

#include <algorithm>
#include <cstring>
#include <functional>
#include <optional>

#include "qbond/io/binary.hpp"
#include "qbond/io/checksum.hpp"
#include "qbond/io/files.hpp"

namespace qbond {
namespace {

// A new State or Bonds field must be saved here: update serialize_state, deserialize_state and
// these sizes.
static_assert(sizeof(State) == 2 * sizeof(std::vector<Vec3>) + sizeof(Bonds) + sizeof(Carry) + 3 * 8 + sizeof(Rng) +
                                   sizeof(EnergyLedger) + sizeof(std::vector<ObstacleImpulse>),
              "State changed: checkpoints must save the new field");
static_assert(sizeof(Bonds) == 3 * sizeof(std::vector<Index>) + sizeof(std::vector<Law>) +
                                   sizeof(std::vector<DampingModel>) + 5 * sizeof(std::vector<double>) +
                                   sizeof(std::vector<std::uint32_t>) + sizeof(std::vector<std::uint8_t>) + 8,
              "Bonds changed: checkpoints must save the new field");
static_assert(sizeof(Law) == 1 && sizeof(DampingModel) == 1, "bond laws are saved as one byte");

// Obstacle impulses are written as raw bytes: four doubles, no padding.
static_assert(sizeof(ObstacleImpulse) == 4 * sizeof(double), "ObstacleImpulse has padding");

constexpr char kMagic[8] = {'Q', 'B', 'O', 'N', 'D', 'C', 'K', 'P'};

// The checksum a file of `version` carries: XXH64 from version 6, FNV-1a (checksum.hpp) before.
std::uint64_t checksum(std::string_view bytes, std::uint32_t version) {
  return version >= 6 ? xxh64(bytes) : fnv1a_version5(bytes);
}

std::uint64_t u64_at(std::string_view bytes, std::size_t at) {
  std::uint64_t v = 0;
  std::memcpy(&v, bytes.data() + at, 8);
  return v;
}

}  // namespace

namespace {

void save_bonds(Writer& w, const Bonds& b) {
  w.pod<std::uint64_t>(b.first_formed);
  w.vec(b.i);
  w.vec(b.j);
  w.vec(b.id);
  w.vec(b.law);
  w.vec(b.damping_model);
  w.vec(b.strength);
  w.vec(b.damping);
  w.vec(b.rest0);
  w.vec(b.shape);
  w.vec(b.rest);
  w.vec(b.alive);
  w.vec(b.time);
}

// The bonds as save_bonds wrote them, for a state of n quanta; shape rows are checked against a
// model later (adopt_scene_bonds).
Bonds load_bonds(Reader& r, std::size_t n) {
  Bonds b;
  b.first_formed = r.pod<std::uint64_t>();
  b.i = r.vec<Index>();
  b.j = r.vec<Index>();
  b.id = r.vec<Index>();
  b.law = r.vec<Law>();
  b.damping_model = r.vec<DampingModel>();
  b.strength = r.vec<double>();
  b.damping = r.vec<double>();
  b.rest0 = r.vec<double>();
  b.shape = r.vec<std::uint32_t>();
  b.rest = r.vec<double>();
  b.alive = r.vec<std::uint8_t>();
  b.time = r.vec<double>();
  const std::size_t nb = b.i.size();
  for (std::size_t size : {b.j.size(), b.id.size(), b.law.size(), b.damping_model.size(), b.strength.size(),
                           b.damping.size(), b.rest0.size(), b.shape.size(), b.rest.size(), b.alive.size(),
                           b.time.size()})
    if (size != nb) throw CheckpointError("state: the bonds' arrays differ in length");
  if (b.first_formed > nb) throw CheckpointError("state: more scene bonds than bonds");
  for (std::size_t k = 0; k < nb; ++k)
    if (b.i[k] == b.j[k] || b.i[k] >= n || b.j[k] >= n || !is_law_id(static_cast<std::uint8_t>(b.law[k])) ||
        static_cast<int>(b.damping_model[k]) > 1 || b.alive[k] > 1)
      throw CheckpointError("state: bond " + std::to_string(k) + " is invalid");
  return b;
}

// Before version 6: the rest lengths, alive flags and times of every bond, then the formed
// bonds' entries (version 4: eps where later files save the shape).
void load_bonds_before_v6(Reader& r, std::uint32_t version, State& s, std::vector<SavedFormedBond>& formed) {
  s.bonds.rest = r.vec<double>();
  s.bonds.alive = r.vec<std::uint8_t>();
  s.bonds.time = r.vec<double>();
  const auto count = r.pod<std::uint64_t>();
  if (count > s.bonds.rest.size()) throw CheckpointError("state: more formed bonds than bonds");
  formed.resize(count);
  for (SavedFormedBond& f : formed) {
    f.i = r.pod<Index>();
    f.j = r.pod<Index>();
    f.law = r.pod<Law>();
    f.damping_model = r.pod<DampingModel>();
    if (version == 4) {  // stiffness, damping, eps, rest0: eps is the inverse law's one shape parameter
      double eps = 0;
      for (double* d : {&f.strength, &f.damping, &eps, &f.rest0}) *d = r.pod<double>();
      f.shape = f.law == Law::inverse ? LawShape{eps, 0} : LawShape{};
    } else {
      for (double* d : {&f.strength, &f.damping, &f.rest0}) *d = r.pod<double>();
      for (double& d : f.shape) d = r.pod<double>();
    }
    if (f.i == f.j || f.i >= s.x.size() || f.j >= s.x.size() || !is_law_id(static_cast<std::uint8_t>(f.law)) ||
        static_cast<int>(f.damping_model) > 1)
      throw CheckpointError("state: a formed bond is invalid");
    if (const std::string why = invalid_law_shape(f.law, f.shape); !why.empty())
      throw CheckpointError("state: a formed bond's law is invalid: " + why);
  }
  if (s.bonds.alive.size() != s.bonds.rest.size() || s.bonds.time.size() != s.bonds.rest.size())
    throw CheckpointError("state: inconsistent array lengths");
}

}  // namespace

// Restores what only the state's mutators change otherwise.
struct StateFile {
  static void set_topology_version(State& s, std::uint64_t v) { s.topology_version_ = v; }
};

std::string serialize_state(const State& s) {
  Writer w;
  w.vec(s.x);
  w.vec(s.v);
  save_bonds(w, s.bonds);
  w.pod(s.time);
  w.pod(s.step);
  w.pod(s.rng);
  const EnergyLedger& e = s.energy;
  for (double d : {e.initial_total, e.initial_gravity, e.initial_time, e.work_loads, e.work_anchors,
                   e.dissipated_damping, e.dissipated_heuristics})
    w.pod(d);
  w.pod<std::uint8_t>(e.initialised);
  w.pod(s.topology_version());
  save_carry(w, s.carry);
  w.vec(s.obstacle_impulse);
  // The solve's contact accounts and backward Euler's numerical damping, only when a run has
  // them: other checkpoints keep their bytes.
  if (e.dissipated_contact != 0 || e.contact_stored != 0 || e.numerical_damping != 0) {
    w.pod(e.dissipated_contact);
    w.pod(e.contact_stored);
  }
  if (e.numerical_damping != 0) w.pod(e.numerical_damping);
  return std::move(w.out);
}

namespace {

// The state as a file of `version` wrote it: this build's, or versions 4 and 5 (their carry-over
// and formed bonds converted: `formed` receives the formed bonds' entries).
State deserialize(std::string_view bytes, std::uint32_t version, std::optional<std::vector<SavedFormedBond>>& formed) {
  Reader r(bytes);
  State s;
  s.x = r.vec<Vec3>();
  s.v = r.vec<Vec3>();
  if (s.v.size() != s.x.size()) throw CheckpointError("state: inconsistent array lengths");
  if (version >= 6) {
    s.bonds = load_bonds(r, s.x.size());
  } else {
    formed.emplace();
    load_bonds_before_v6(r, version, s, *formed);
  }
  s.time = r.pod<double>();
  s.step = r.pod<std::uint64_t>();
  s.rng = r.pod<Rng>();
  EnergyLedger& e = s.energy;
  for (double* d : {&e.initial_total, &e.initial_gravity, &e.initial_time, &e.work_loads, &e.work_anchors,
                    &e.dissipated_damping, &e.dissipated_heuristics})
    *d = r.pod<double>();
  e.initialised = r.pod<std::uint8_t>() != 0;
  StateFile::set_topology_version(s, r.pod<std::uint64_t>());
  s.carry = version == 4 ? carry_from_version4(r.vec<Vec3, LineAllocator<Vec3>>(), s.x.size())
                         : load_carry(r, s.x.size());
  s.obstacle_impulse = r.vec<ObstacleImpulse>();
  if (version >= 6 && (r.bytes.size() == 2 * sizeof(double) || r.bytes.size() == 3 * sizeof(double))) {
    e.dissipated_contact = r.pod<double>();
    e.contact_stored = r.pod<double>();
    if (!r.bytes.empty()) e.numerical_damping = r.pod<double>();
  }
  if (!r.bytes.empty()) throw CheckpointError("state: " + std::to_string(r.bytes.size()) + " unexpected bytes at the end");
  return s;
}

}  // namespace

State deserialize_state(std::string_view bytes) {
  std::optional<std::vector<SavedFormedBond>> none;
  return deserialize(bytes, kCheckpointVersion, none);
}

void save_checkpoint(const std::filesystem::path& path, std::string_view metadata, const State& state) {
  Writer w;
  w.out.append(kMagic, sizeof kMagic);
  w.pod(kCheckpointVersion);
  w.pod<std::uint32_t>(0);
  w.pod<std::uint64_t>(metadata.size());
  w.out.append(metadata);
  const std::string s = serialize_state(state);
  w.pod<std::uint64_t>(s.size());
  w.out.append(s);
  w.pod(checksum(w.out, kCheckpointVersion));
  write_file_atomic(path, w.out);
}

namespace {

// Where a checkpoint's parts are, from its size and header alone (read(offset, length) gives the
// bytes); throws CheckpointError, without the file's name, when they do not fit the size.
struct Layout {
  std::uint32_t version = 0;
  std::uint64_t meta_at = 0, m = 0, state_at = 0, s = 0;
};

Layout check_layout(std::uint64_t size, const std::function<std::string(std::uint64_t, std::uint64_t)>& read) {
  constexpr std::uint64_t kHeader = 24;  // magic, version, reserved, metadata length
  const std::string head = read(0, std::min(size, kHeader));
  if (head.size() < 8 || std::memcmp(head.data(), kMagic, 8) != 0)
    throw CheckpointError("not a qbond checkpoint (no QBONDCKP header)");
  auto truncated = [&](std::uint64_t at_least) {
    return CheckpointError("truncated: expected at least " + std::to_string(at_least) + " bytes, got " +
                           std::to_string(size));
  };
  if (head.size() < kHeader) throw truncated(kHeader);
  Layout l;
  std::memcpy(&l.version, head.data() + 8, 4);
  if (l.version != kCheckpointVersion && l.version != 5 && l.version != 4)
    throw CheckpointError("unsupported checkpoint version " + std::to_string(l.version) +
                          " (this build reads 4, 5 and " + std::to_string(kCheckpointVersion) + ")");
  l.meta_at = kHeader;
  l.m = u64_at(head, 16);
  if (l.m > size || kHeader + l.m + 8 > size) throw truncated(l.m > size ? l.m : kHeader + l.m + 8);
  l.s = u64_at(read(kHeader + l.m, 8), 0);
  l.state_at = kHeader + l.m + 8;
  if (l.s > size || l.state_at + l.s + 8 > size) throw truncated(l.s > size ? l.s : l.state_at + l.s + 8);
  if (size != l.state_at + l.s + 8)
    throw CheckpointError("corrupted: " + std::to_string(size - (l.state_at + l.s + 8)) + " bytes after the checksum");
  return l;
}

Checkpoint parse(std::string_view bytes, const Layout& l) {
  if (u64_at(bytes, l.state_at + l.s) != checksum(bytes.substr(0, l.state_at + l.s), l.version))
    throw CheckpointError("corrupted: checksum mismatch");
  Checkpoint c;
  c.version = l.version;
  c.metadata = std::string(bytes.substr(l.meta_at, l.m));
  c.state = deserialize(bytes.substr(l.state_at, l.s), l.version, c.formed_before_v6);
  return c;
}

}  // namespace

Checkpoint parse_checkpoint(std::string_view bytes, const std::string& name) {
  try {
    return parse(bytes, check_layout(bytes.size(), [&](std::uint64_t at, std::uint64_t n) {
                   return std::string(bytes.substr(at, n));
                 }));
  } catch (const CheckpointError& e) {
    throw CheckpointError(name + ": " + e.what());
  }
}

Checkpoint load_checkpoint(const std::filesystem::path& path, std::uint64_t max_bytes) {
  const std::string name = path.string() + ": ";
  try {
    // The layout is checked against the file's size from its header alone: a file that is not a
    // checkpoint, or claims sizes it does not have, is refused before the rest is read.
    std::optional<InputFile> file;
    try {
      file.emplace(path);
    } catch (const std::exception& e) {
      throw CheckpointError(e.what());
    }
    const std::uint64_t size = file->size();
    Layout l;
    try {
      l = check_layout(size, [&](std::uint64_t at, std::uint64_t n) { return file->read(at, n); });
      if (size > max_bytes)
        throw CheckpointError(std::to_string(size) + " bytes, more than the " + std::to_string(max_bytes) +
                              " this run may take");
    } catch (const CheckpointError& e) {
      throw CheckpointError(name + e.what());
    }
    const std::string bytes = file->read(0, size);
    try {
      return parse(bytes, l);
    } catch (const CheckpointError& e) {
      throw CheckpointError(name + e.what());
    }
  } catch (const CheckpointError&) {
    throw;
  } catch (const std::exception& e) {  // a read failing after the file was opened
    throw CheckpointError(e.what());
  }
}

void adopt_scene_bonds(Checkpoint& c, World& scene) {
  State& s = c.state;
  const Bonds& given = scene.state.bonds;
  const std::size_t scene_bonds = given.first_formed;
  if (s.x.size() != scene.num_quanta())
    throw CheckpointError("state does not match its scene (" + std::to_string(s.x.size()) +
                          " quanta saved, the scene has " + std::to_string(scene.num_quanta()) + ")");
  if (c.formed_before_v6) {
    const std::vector<SavedFormedBond>& formed = *c.formed_before_v6;
    if (s.bonds.rest.size() - formed.size() != scene_bonds)
      throw CheckpointError("state does not match its scene (" + std::to_string(s.bonds.rest.size() - formed.size()) +
                            " scene bonds saved, the scene has " + std::to_string(scene_bonds) + ")");
    // The scene's bonds (ends, laws, rest0) with the saved rest lengths, alive flags and times.
    Bonds b = given;
    b.rest = std::move(s.bonds.rest);
    b.alive = std::move(s.bonds.alive);
    b.time = std::move(s.bonds.time);
    b.i.resize(b.rest.size());
    b.j.resize(b.rest.size());
    b.id.resize(b.rest.size());
    b.law.resize(b.rest.size());
    b.damping_model.resize(b.rest.size());
    b.strength.resize(b.rest.size());
    b.damping.resize(b.rest.size());
    b.rest0.resize(b.rest.size());
    b.shape.resize(b.rest.size());
    for (std::size_t k = 0; k < formed.size(); ++k) {
      const SavedFormedBond& f = formed[k];
      const std::size_t slot = scene_bonds + k;
      b.i[slot] = f.i;
      b.j[slot] = f.j;
      b.id[slot] = static_cast<Index>(slot);
      b.law[slot] = f.law;
      b.damping_model[slot] = f.damping_model;
      b.strength[slot] = f.strength;
      b.damping[slot] = f.damping;
      b.rest0[slot] = f.rest0;
      b.shape[slot] = scene.model.intern_shape(f.shape);
    }
    s.bonds = std::move(b);
    c.formed_before_v6.reset();
  }
  if (s.bonds.first_formed != scene_bonds)
    throw CheckpointError("state does not match its scene (" + std::to_string(s.bonds.first_formed) +
                          " scene bonds saved, the scene has " + std::to_string(scene_bonds) + ")");
  const std::vector<LawShape>& shapes = scene.model.shapes;
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {
    if (s.bonds.shape[k] >= shapes.size())
      throw CheckpointError("state: bond " + std::to_string(k) + "'s law shape is not one its scene has");
    if (const std::string why = invalid_law_shape(s.bonds.law[k], shapes[s.bonds.shape[k]]); !why.empty())
      throw CheckpointError("state: bond " + std::to_string(k) + "'s law is invalid: " + why);
  }
}

}  // namespace qbond
