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

// A new State field must be saved here: update serialize_state, deserialize_state and this size.
static_assert(sizeof(State) == 2 * sizeof(std::vector<Vec3>) + sizeof(Carry) + 2 * sizeof(std::vector<double>) +
                                   sizeof(std::vector<std::uint8_t>) + sizeof(std::vector<FormedBond>) + 2 * 8 +
                                   sizeof(Rng) + sizeof(EnergyLedger) + 8 +
                                   sizeof(std::vector<ObstacleImpulse>),
              "State changed: checkpoints must save the new field");

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
  c.state = deserialize(bytes.substr(l.state_at, l.s), l.version);
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

}  // namespace qbond
