// The ImGui panel: the scene's state, the integrator and its options (from the integrator table),
// the physics factors, colourings with their legend, and plots of energy and step time.
#include "gl.hpp"
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <cfloat>
#include <cstdio>
#include <vector>

#include "viewer_app.hpp"

namespace qbond::view {

namespace {

void plot(const char* label, const std::deque<float>& d, const char* overlay) {
  const std::vector<float> v(d.begin(), d.end());
  ImGui::PlotLines(label, v.data(), static_cast<int>(v.size()), 0, overlay, FLT_MAX, FLT_MAX, ImVec2(0, 50));
}

}  // namespace

void push_history(std::deque<float>& d, double x) {
  d.push_back(static_cast<float>(x));
  if (d.size() > kHistory) d.pop_front();
}

void Viewer::panel() {
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(fb_w_ - kPanelWidth), 0));
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, static_cast<float>(fb_h_)));
  ImGui::Begin("qbond", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  const World& w = world();
  ImGui::Text("%s", scene_.name.c_str());
  if (replay_) ImGui::Text("t = %.4g s   frame %zu of %zu", w.state.time, replay_->index() + 1, replay_->size());
  else ImGui::Text("t = %.3f s   step %llu", w.state.time, static_cast<unsigned long long>(w.state.step));
  const std::size_t alive = w.num_alive_bonds();
  if (replay_) ImGui::Text("quanta %zu  bonds %zu", w.num_quanta(), alive);
  else ImGui::Text("quanta %zu  bonds %zu  broken %zu", w.num_quanta(), alive, w.num_bonds() - alive);
  if (!blowup_.empty()) ImGui::TextColored(ImVec4(1, 0.3f, 0.3f, 1), "BLOW-UP (r resets):\n%s", blowup_.c_str());
  else if (paused_) ImGui::TextColored(ImVec4(1, 0.8f, 0.2f, 1), "paused (space)");
  if (opt_.frames == 0 && !replay_) {
    const double rt = real_time_factor();
    if (rt < 0.95 && !paused_) ImGui::TextColored(ImVec4(1, 0.5f, 0.2f, 1), "behind: %.2fx real time", rt);
    else ImGui::Text("%.2fx real time", rt);
  }
  if (replay_) ImGui::Text("%.1f fps", static_cast<double>(ImGui::GetIO().Framerate));
  else ImGui::Text("%.1f fps, %d steps/frame", static_cast<double>(ImGui::GetIO().Framerate), steps_last_frame_);
  ImGui::Separator();

  if (replay_) replay_controls();
  else physics_controls(), ImGui::SameLine();
  ImGui::Checkbox("camera follows", &follow_);
  ImGui::Separator();
  int bc = static_cast<int>(bond_color_), qc = static_cast<int>(quanta_color_);
  if (ImGui::Combo("bonds", &bc, kBondColorNames, IM_ARRAYSIZE(kBondColorNames))) {
    bond_color_ = static_cast<BondColor>(bc);
    bond_range_.reset();
  }
  // Stress needs the quanta's volumes; a replay has it when the run wrote it (0 where unknown).
  const std::vector<double>& known = replay_ ? replay_->frame().von_mises : w.model.volume;
  const bool volumes = std::any_of(known.begin(), known.end(), [](double v) { return v > 0; });
  if (ImGui::Combo("quanta", &qc, kQuantaColorNames, IM_ARRAYSIZE(kQuantaColorNames))) {
    quanta_color_ = static_cast<QuantaColor>(qc);
    if (quanta_color_ == QuantaColor::von_mises && !volumes) quanta_color_ = QuantaColor::body;
    quanta_range_.reset();
  }
  if (!volumes) ImGui::TextDisabled("no quanta volumes: no stress colouring");
  legend();
  ImGui::Separator();
  char label[64];
  std::snprintf(label, sizeof label, "%.4g J", energy_.empty() ? 0.0 : static_cast<double>(energy_.back()));
  if (!replay_) plot("total energy", energy_, label);
  std::snprintf(label, sizeof label, "%.4g J", kinetic_.empty() ? 0.0 : static_cast<double>(kinetic_.back()));
  plot("kinetic", kinetic_, label);
  std::snprintf(label, sizeof label, "%.3g ms", step_ms_.empty() ? 0.0 : static_cast<double>(step_ms_.back()));
  if (!replay_) plot("step time", step_ms_, label);
  ImGui::Separator();
  ImGui::TextDisabled(replay_ ? "h: help   space: play/pause   r: start\n.: next frame   ,: previous   f: frame"
                              : "h: help   space: pause   .: step   r: reset   f: frame");
  ImGui::End();
}

void Viewer::physics_controls() {
  // Every integrator by name, and the options the chosen one reads (integrators.hpp's table).
  int type = integrator_menu_.index(config_.type);
  const std::vector<const char*> types = integrator_menu_.labels();
  bool changed = ImGui::Combo("integrator", &type, types.data(), static_cast<int>(types.size()));
  config_.type = integrator_menu_.values[static_cast<std::size_t>(type)];
  const IntegratorInfo& info = integrator_info(config_.type);
  if (info.reads(IntegratorOption::neighbours)) {
    int nm = neighbour_menu_.index(config_.neighbours);
    const std::vector<const char*> models = neighbour_menu_.labels();
    changed |= ImGui::Combo("neighbours", &nm, models.data(), static_cast<int>(models.size()));
    config_.neighbours = neighbour_menu_.values[static_cast<std::size_t>(nm)];
  }
  if (info.reads(IntegratorOption::solver)) {
    const Menu<CoupledSolver> solvers = solver_menu(config_.type);
    int sv = solvers.index(config_.solver);
    const std::vector<const char*> labels = solvers.labels();
    changed |= ImGui::Combo("solver", &sv, labels.data(), static_cast<int>(labels.size()));
    config_.solver = solvers.values[static_cast<std::size_t>(sv)];
  }
  if (info.reads(IntegratorOption::preconditioner) && config_.solver == CoupledSolver::cg) {
    int pc = preconditioner_menu_.index(config_.preconditioner);
    const std::vector<const char*> labels = preconditioner_menu_.labels();
    changed |= ImGui::Combo("preconditioner", &pc, labels.data(), static_cast<int>(labels.size()));
    config_.preconditioner = preconditioner_menu_.values[static_cast<std::size_t>(pc)];
  }
  if (info.reads(IntegratorOption::iterations)) changed |= ImGui::SliderInt("sweeps", &config_.iterations, 1, 50);
  if (info.reads(IntegratorOption::max_iterations))
    changed |= ImGui::SliderInt("max CG iter.", &config_.max_iterations, 0, 500);
  if (info.reads(IntegratorOption::newton_iterations))
    changed |= ImGui::SliderInt("Newton iter.", &config_.newton_iterations, 1, 50);
  // A warm start the scene chose for another integrator may not be one this one takes.
  if (info.reads(IntegratorOption::warm_start) &&
      std::find(info.warm_starts.begin(), info.warm_starts.end(), config_.warm_start) == info.warm_starts.end())
    config_.warm_start = WarmStart::automatic;
  if (changed) sim_->set_integrator(config_);
  float h = static_cast<float>(h_);
  if (ImGui::SliderFloat("timestep [s]", &h, 1e-6f, 0.05f, "%.2e", ImGuiSliderFlags_Logarithmic)) {
    h_ = h;
    sim_->set_timestep(h_);
  }
  // Both sliders drawn every frame, so no short-circuit between them.
  const bool stiffness = ImGui::SliderFloat("stiffness x", &stiffness_scale_, 0.01f, 100, "%.2f",
                                            ImGuiSliderFlags_Logarithmic);
  const bool damping = ImGui::SliderFloat("damping x", &damping_scale_, 0.0f, 100, "%.2f", ImGuiSliderFlags_Logarithmic);
  if (stiffness || damping) rescale();
  ImGui::SliderFloat("pull [Hz]", &pull_hz_, 0.5f, 20, "%.1f", ImGuiSliderFlags_Logarithmic);
  Vec3f g = gravity_.cast<float>();
  if (ImGui::InputFloat3("gravity", g.data(), "%.2f")) sim_->world().model.gravity = gravity_ = g.cast<double>();
  if (ImGui::Checkbox("heuristics", &heuristics_on_)) {
    sim_->clear_heuristics();
    if (heuristics_on_)
      for (const HeuristicSpec& hs : scene_.heuristics) sim_->add_heuristic(make_heuristic(hs));
  }
  ImGui::SameLine();
  ImGui::TextDisabled("(%zu)", scene_.heuristics.size());
}

void Viewer::replay_controls() {
  const std::size_t n = replay_->size(), k = replay_->index();
  ImGui::TextDisabled("replay of %s", replay_->series().string().c_str());
  int frame = static_cast<int>(k);
  char label[64];
  std::snprintf(label, sizeof label, "%%d / %zu", n - 1);
  if (ImGui::SliderInt("frame", &frame, 0, static_cast<int>(n) - 1, label)) show_frame(static_cast<std::size_t>(frame));
  float t = static_cast<float>(replay_clock_);
  if (ImGui::SliderFloat("time [s]", &t, static_cast<float>(replay_->time(0)), static_cast<float>(replay_->time(n - 1)), "%.4g"))
    show_frame(replay_->at_time(t)), replay_clock_ = t;
  if (ImGui::Button("|<")) show_frame(0);
  ImGui::SameLine();
  if (ImGui::Button("<") && k > 0) show_frame(k - 1);
  ImGui::SameLine();
  if (ImGui::Button(paused_ ? "play" : "pause")) key(GLFW_KEY_SPACE);
  ImGui::SameLine();
  if (ImGui::Button(">")) single_step_ = true;
  ImGui::SameLine();
  if (ImGui::Button(">|")) show_frame(n - 1);
  ImGui::SliderFloat("speed x", &replay_speed_, 0.01f, 100, "%.2f", ImGuiSliderFlags_Logarithmic);
}

void Viewer::legend() {
  const bool in_panel = opt_.ui;
  if (!in_panel) {
    ImGui::SetNextWindowPos(ImVec2(10, static_cast<float>(fb_h_) - 10), ImGuiCond_Always, ImVec2(0, 1));
    ImGui::SetNextWindowBgAlpha(0.6f);
    ImGui::Begin("legend", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoInputs);
  }
  auto bar = [](const char* title, double lo, double hi, bool div) {
    ImGui::TextUnformatted(title);
    ImDrawList* dl = ImGui::GetWindowDrawList();
    const ImVec2 p = ImGui::GetCursorScreenPos();
    const float w = 220, h = 14;
    constexpr int kSteps = 32;
    for (int k = 0; k < kSteps; ++k) {
      const double t = (k + 0.5) / kSteps;
      const Vec3f c = div ? diverging(2 * t - 1) : sequential(t);
      const ImU32 col = IM_COL32(static_cast<int>(255 * c.x()), static_cast<int>(255 * c.y()), static_cast<int>(255 * c.z()), 255);
      dl->AddRectFilled(ImVec2(p.x + w * static_cast<float>(k) / kSteps, p.y), ImVec2(p.x + w * static_cast<float>(k + 1) / kSteps, p.y + h), col);
    }
    ImGui::Dummy(ImVec2(w, h));
    ImGui::Text("%-12.3g%*s%.3g", lo, 14, "", hi);
  };
  if (bond_color_ != BondColor::none) bar(kBondColorNames[static_cast<int>(bond_color_)], -bond_range_.hi, bond_range_.hi, true);
  if (quanta_color_ != QuantaColor::body) bar(kQuantaColorNames[static_cast<int>(quanta_color_)], 0, quanta_range_.hi, false);
  ImGui::TextColored(ImVec4(0.95f, 0.45f, 0.05f, 1), "o");
  ImGui::SameLine();
  ImGui::TextUnformatted("anchored or prescribed quanta");
  if (!in_panel) ImGui::End();
}

void Viewer::help() {
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(viewport_width()) / 2, static_cast<float>(fb_h_) / 2),
                          ImGuiCond_Always, ImVec2(0.5f, 0.5f));
  ImGui::Begin("help", &help_, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoCollapse);
  ImGui::Text(
      "left-drag a quanta    pull it with a spring (drawn in yellow)\n"
      "left-drag elsewhere   orbit\n"
      "right/shift-drag      pan\n"
      "wheel                 zoom\n"
      "f                     frame the scene\n"
      "space                 pause / run\n"
      ".                     one step (a replay: one frame)\n"
      ",                     a replay: one frame back\n"
      "r                     reset the scene (a replay: its first frame)\n"
      "h                     this help\n\n"
      "orange spheres are anchored or prescribed quanta");
  ImGui::End();
}

}  // namespace qbond::view
