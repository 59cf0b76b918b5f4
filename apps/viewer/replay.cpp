#include "replay.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "qbond/io/files.hpp"

namespace qbond::view {

namespace fs = std::filesystem;

bool is_replay(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return fs::is_regular_file(path / "series.pvd", ec);
  return path.extension() == ".pvd";
}

Replay::Replay(const fs::path& path) : pvd_(fs::is_directory(path) ? path / "series.pvd" : path) {
  entries_ = read_pvd(pvd_);
  index_ = entries_.size();  // nothing loaded yet
  load(0);
}

std::size_t Replay::at_time(double t) const {
  const auto it = std::upper_bound(entries_.begin(), entries_.end(), t, [](double x, const PvdEntry& e) { return x < e.time; });
  return it == entries_.begin() ? 0 : static_cast<std::size_t>(it - entries_.begin() - 1);
}

void Replay::load(std::size_t k) {
  if (k == index_) return;
  VtpFrame f = read_vtp(entries_[k].file);
  if (!frame_.x.empty() && f.x.size() != frame_.x.size())
    throw VtkReadError(entries_[k].file.string() + ": has " + std::to_string(f.x.size()) + " points, the series' first frame " +
                       std::to_string(frame_.x.size()));
  World w;
  std::int32_t bodies = 0;
  for (std::int32_t b : f.body) bodies = std::max(bodies, b + 1);
  for (std::int32_t b = 0; b < std::max(bodies, 1); ++b) w.add_body("body " + std::to_string(b));
  for (std::size_t i = 0; i < f.x.size(); ++i) {
    // Drawing needs only a positive mass for free quanta; the file's masses are kept when present.
    const double m = i < f.mass.size() && f.mass[i] > 0 ? f.mass[i] : 1.0;
    w.add_quanta(f.x[i], f.v[i], f.kinematic[i] ? 0.0 : m, static_cast<Index>(std::max(f.body[i], 0)));
  }
  BondSpec spec;
  spec.stiffness = 1, spec.rest_length = 1;  // never stepped: the frame's strain and tension are drawn
  for (const auto& [i, j] : f.lines) w.add_bond(i, j, spec);
  w.state.time = entries_[k].time;
  frame_ = std::move(f);
  world_ = std::move(w);
  index_ = k;
}

Scene replay_scene(const Replay& replay, std::string& note) {
  Scene scene;
  const fs::path dir = replay.series().parent_path();
  const fs::path run_json = dir / "run.json";
  std::error_code ec;
  if (fs::is_regular_file(run_json, ec)) {
    try {
      const nlohmann::json meta = nlohmann::json::parse(read_file(run_json));
      if (!meta.contains("scene")) throw std::runtime_error("it has no scene");
      scene = parse_scene(meta.at("scene").dump(), run_json.string() + ", its scene");
    } catch (const std::exception& e) {
      note = run_json.string() + " was not used (" + e.what() + "): no obstacles, ground or scene camera";
      scene = Scene{};
    }
  }
  if (scene.name.empty()) scene.name = fs::absolute(dir).filename().string();
  scene.name += " (replay)";
  // The frames hold no model: the scene's obstacles and contact radius held inside the step's
  // solve are kept for drawing.
  World world = replay.world();
  world.model.obstacles = scene.world.model.obstacles;
  world.model.quanta_contact = scene.world.model.quanta_contact;
  scene.world = std::move(world);
  return scene;
}

}  // namespace qbond::view
