#include "qbond/io/checkpoint.hpp"

#include <cstring>

#include "integrators/bond_forces.hpp"  // verlet_carry_size
#include "qbond/io/files.hpp"

namespace qbond {
namespace {

// A new State field must be saved here: update serialize_state, deserialize_state and this size.
static_assert(sizeof(State) == 3 * sizeof(std::vector<Vec3>) + 2 * sizeof(std::vector<double>) +
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

class Writer {
 public:
  template <class T>
  void pod(const T& v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T, class A>
  void vec(const std::vector<T, A>& v) {
    pod<std::uint64_t>(v.size());
    if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string out;
};

class Reader {
 public:
  explicit Reader(std::string_view b) : bytes(b) {}
  template <class T>
  T pod() {
    T v;
    need(sizeof v);
    std::memcpy(&v, bytes.data(), sizeof v);
    bytes.remove_prefix(sizeof v);
    return v;
  }
  template <class T, class A = std::allocator<T>>
  std::vector<T, A> vec() {
    const auto n = pod<std::uint64_t>();
    if (n > bytes.size() / sizeof(T)) throw CheckpointError("state: a vector runs past the end");
    std::vector<T, A> v(n);
    if (n > 0) std::memcpy(static_cast<void*>(v.data()), bytes.data(), n * sizeof(T));  // T is plain data (doubles)
    bytes.remove_prefix(n * sizeof(T));
    return v;
  }
  void need(std::size_t n) const {
    if (bytes.size() < n) throw CheckpointError("truncated: the file ends inside its header");
  }
  std::string_view bytes;
};

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
  w.vec(s.warm);
  w.vec(s.obstacle_impulse);
  return std::move(w.out);
}

State deserialize_state(std::string_view bytes) {
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
    for (double* d : {&f.stiffness, &f.damping, &f.rest0}) *d = r.pod<double>();
    for (double& d : f.shape) d = r.pod<double>();
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
  s.warm = r.vec<Vec3, LineAllocator<Vec3>>();
  s.obstacle_impulse = r.vec<ObstacleImpulse>();
  if (!r.bytes.empty()) throw CheckpointError("state: " + std::to_string(r.bytes.size()) + " unexpected bytes at the end");
  if (s.v.size() != s.x.size() || s.alive.size() != s.rest.size() || s.bond_time.size() != s.rest.size() ||
      (!s.warm.empty() && s.warm.size() != s.x.size() && s.warm.size() != 2 * s.x.size() + 1 &&
       s.warm.size() != verlet_carry_size(s.x.size()) &&
       s.warm.size() != 3 * s.x.size() + 1))  // velocity_verlet's older layout, which a step then drops
    throw CheckpointError("state: inconsistent array lengths");
  return s;
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
    if (version != kCheckpointVersion)
      throw CheckpointError("unsupported checkpoint version " + std::to_string(version) + " (this build reads " +
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
    c.state = deserialize_state(std::string_view(bytes).substr(state_at, s));
    return c;
  } catch (const CheckpointError& e) {
    throw CheckpointError(name + e.what());
  }
}

}  // namespace qbond
