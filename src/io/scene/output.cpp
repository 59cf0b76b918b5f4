// Builder: the `output` section.
#include "io/scene/builder.hpp"

namespace qbond::scene_detail {

OutputSpec Builder::output(const json& j, std::uint64_t steps, const World& w) {
  Obj o(j, "output", keys_of("output"));
  OutputSpec out;
  if (o.has("dir")) out.dir = string(o["dir"], o.at("dir"));
  if (out.dir.empty()) bad(o.at("dir"), "must not be empty");
  out.every = o.has("every") ? integer(o["every"], o.at("every"), 1) : std::max<std::uint64_t>(1, steps / 100);
  if (o.has("vtk")) out.vtk = boolean(o["vtk"], o.at("vtk"));
  if (o.has("checkpoint_every")) out.checkpoint_every = integer(o["checkpoint_every"], o.at("checkpoint_every"), 0);
  if (o.has("probes")) {
    const json& a = array(o["probes"], o.at("probes"));
    std::map<std::string, std::size_t> seen;
    for (std::size_t k = 0; k < a.size(); ++k) {
      Obj p(a[k], item(o.at("probes"), k), keys_of("probe"));
      ProbeSpec s;
      s.name = string(p.required("name"), p.at("name"));
      if (s.name.empty() || !std::all_of(s.name.begin(), s.name.end(), [](char c) {
            return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
          }))
        bad(p.at("name"), "must be letters, digits and '_' only (it names CSV columns), got '" + s.name + "'");
      if (auto [it, fresh] = seen.emplace(s.name, k); !fresh)
        bad(p.at("name"), "duplicate probe name '" + s.name + "' (also probes[" + std::to_string(it->second) + "])");
      s.quanta = selection(p.required("select"), p.at("select"), w);
      if (p.has("about")) s.about = vec3(p["about"], p.at("about"));
      out.probes.push_back(std::move(s));
    }
  }
  return out;
}

}  // namespace qbond::scene_detail
