#include "qbond/io/checkpoint.hpp"

#include <cstring>

#include "qbond/io/binary.hpp"
#include "qbond/io/files.hpp"

namespace qbond {
namespace {

// A new State field must be saved here: update serialize_state, deserialize_state and this size.
static_assert(sizeof(State) == 2 * sizeof(std::vector<Vec3>) + sizeof(Carry) + 2 * sizeof(std::vector<double>) +
                                   sizeof(std::vector<std::uint8_t>) + sizeof(std::vector<FormedBond>) + 2 * 8 +
                                   sizeof(Rng) + sizeof(EnergyLedger) + 8 +
                                   sizeof(std::vector<ObstacleImpulse>),
              "State changed: checkpoints must save the new field");

// Obstacle impulses are written as raw bytes: four doubles, no padding.
static_assert(sizeof(ObstacleImpulse) == 4 * sizeof(double), "ObstacleImpulse has padding");

constexpr char kMagic[8] = {'Q', 'B', 'O', 'N', 'D', 'C', 'K', 'P'};

std::uint64_t fnv1a(std::string_view bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  return h;
}

}  // namespace

std::string serialize_state(const State& s) {
  Writer w;
  w.vec(s.x);
  w.vec(s.v);
  w.vec(s.rest);
  w.vec(s.alive);
  w.vec(s.bond_time);
  // Field by field: FormedBond has padding, whose bytes are not data.
  w.pod<std::uint64_t>(s.formed.size());
  for (const FormedBond& f : s.formed) {
    w.pod(f.i);
    w.pod(f.j);
    w.pod(f.law);
    w.pod(f.damping_model);
    for (double d : {f.stiffness, f.damping, f.rest0}) w.pod(d);
    for (double d : f.shape) w.pod(d);
  }
  w.pod(s.time);
  w.pod(s.step);
  w.pod(s.rng);
  const EnergyLedger& e = s.energy;
  for (double d : {e.initial_total, e.initial_gravity, e.initial_time, e.work_loads, e.work_anchors,
                   e.dissipated_damping, e.dissipated_heuristics})
    w.pod(d);
  w.pod<std::uint8_t>(e.initialised);
  w.pod(s.topology_version);
  save_carry(w, s.carry);
  w.vec(s.obstacle_impulse);
  return std::move(w.out);
}

namespace {

// The state as a file of `version` wrote it: this build's, or version 4 (its carry-over converted).
State deserialize(std::string_view bytes, std::uint32_t version) {
  Reader r(bytes);
  State s;
  s.x = r.vec<Vec3>();
  s.v = r.vec<Vec3>();
  s.rest = r.vec<double>();
  s.alive = r.vec<std::uint8_t>();
  s.bond_time = r.vec<double>();
  const auto formed = r.pod<std::uint64_t>();
  if (formed > s.rest.size()) throw CheckpointError("state: more formed bonds than bonds");
  s.formed.resize(formed);
  for (FormedBond& f : s.formed) {
    f.i = r.pod<Index>();
    f.j = r.pod<Index>();
    f.law = r.pod<Law>();
    f.damping_model = r.pod<DampingModel>();
    if (version == 4) {  // stiffness, damping, eps, rest0: eps is the inverse law's one shape parameter
      double eps = 0;
      for (double* d : {&f.stiffness, &f.damping, &eps, &f.rest0}) *d = r.pod<double>();
      f.shape = f.law == Law::inverse ? LawShape{eps, 0} : LawShape{};
    } else {
      for (double* d : {&f.stiffness, &f.damping, &f.rest0}) *d = r.pod<double>();
      for (double& d : f.shape) d = r.pod<double>();
    }
    if (f.i == f.j || f.i >= s.x.size() || f.j >= s.x.size() || !is_law_id(static_cast<std::uint8_t>(f.law)) ||
        static_cast<int>(f.damping_model) > 1)
      throw CheckpointError("state: a formed bond is invalid");
    if (const std::string why = invalid_law_shape(f.law, f.shape); !why.empty())
      throw CheckpointError("state: a formed bond's law is invalid: " + why);
  }
  s.time = r.pod<double>();
  s.step = r.pod<std::uint64_t>();
  s.rng = r.pod<Rng>();
  EnergyLedger& e = s.energy;
  for (double* d : {&e.initial_total, &e.initial_gravity, &e.initial_time, &e.work_loads, &e.work_anchors,
                    &e.dissipated_damping, &e.dissipated_heuristics})
    *d = r.pod<double>();
  e.initialised = r.pod<std::uint8_t>() != 0;
  s.topology_version = r.pod<std::uint64_t>();
  s.carry = version == 4 ? carry_from_version4(r.vec<Vec3, LineAllocator<Vec3>>(), s.x.size())
                         : load_carry(r, s.x.size());
  s.obstacle_impulse = r.vec<ObstacleImpulse>();
  if (!r.bytes.empty()) throw CheckpointError("state: " + std::to_string(r.bytes.size()) + " unexpected bytes at the end");
  if (s.v.size() != s.x.size() || s.alive.size() != s.rest.size() || s.bond_time.size() != s.rest.size())
    throw CheckpointError("state: inconsistent array lengths");
  return s;
}

}  // namespace

State deserialize_state(std::string_view bytes) { return deserialize(bytes, kCheckpointVersion); }

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
  w.pod(fnv1a(w.out));
  write_file_atomic(path, w.out);
}

Checkpoint load_checkpoint(const std::filesystem::path& path) {
  std::string bytes;
  try {
    bytes = read_file(path);
  } catch (const std::exception& e) {
    throw CheckpointError(e.what());
  }
  const std::string name = path.string() + ": ";
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw CheckpointError(name + "not a qbond checkpoint (no QBONDCKP header)");
  try {
    Reader r(std::string_view(bytes).substr(8));
    const auto version = r.pod<std::uint32_t>();
    if (version != kCheckpointVersion && version != 4)
      throw CheckpointError("unsupported checkpoint version " + std::to_string(version) + " (this build reads 4 and " +
                            std::to_string(kCheckpointVersion) + ")");
    r.pod<std::uint32_t>();
    const auto m = r.pod<std::uint64_t>();
    const std::size_t meta_at = bytes.size() - r.bytes.size();
    // Sizes come from the file; check them against its length before trusting them.
    auto expect = [&](std::uint64_t length, std::uint64_t at_least) {
      if (length > bytes.size() || at_least > bytes.size())
        throw CheckpointError("truncated: expected at least " + std::to_string(at_least) + " bytes, got " +
                              std::to_string(bytes.size()));
    };
    expect(m, meta_at + m + 8);
    std::uint64_t s = 0;
    std::memcpy(&s, bytes.data() + meta_at + m, 8);
    const std::size_t state_at = meta_at + m + 8;
    expect(s, state_at + s + 8);
    if (bytes.size() != state_at + s + 8)
      throw CheckpointError("corrupted: " + std::to_string(bytes.size() - (state_at + s + 8)) +
                            " bytes after the checksum");
    std::uint64_t sum = 0;
    std::memcpy(&sum, bytes.data() + state_at + s, 8);
    if (sum != fnv1a(std::string_view(bytes).substr(0, state_at + s)))
      throw CheckpointError("corrupted: checksum mismatch");
    Checkpoint c;
    c.metadata = bytes.substr(meta_at, m);
    c.state = deserialize(std::string_view(bytes).substr(state_at, s), version);
    return c;
  } catch (const CheckpointError& e) {
    throw CheckpointError(name + e.what());
  }
}

}  // namespace qbond
