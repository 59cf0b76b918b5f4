// Stepping in real time: as many steps of the scene's timestep per frame as the wall clock asks
// and the frame budget allows (headless runs: a fixed number per frame).
#include <algorithm>
#include <cmath>

#include "qbond/analysis/analysis.hpp"
#include "qbond/integrators/adaptive.hpp"
#include "viewer_app.hpp"

namespace qbond::view {

double Viewer::advance(Timing& timing) {
  if (replay_) return advance_replay(timing);
  const auto t0 = Clock::now();
  int steps = 0;
  if (opt_.frames > 0) {  // headless: a fixed number of steps, the same for every run
    steps = opt_.steps_per_frame > 0 ? opt_.steps_per_frame
                                     : std::max(1, static_cast<int>(std::lround(1 / (kFrameRate * h_))));
    if (paused_ && !single_step_) steps = 0;
    if (single_step_) steps = 1;
    for (int k = 0; k < steps && blowup_.empty(); ++k) step();
  } else {  // interactive: keep up with the wall clock while the budget lasts
    const double wall = last_frame_ ? std::min(seconds_since(*last_frame_), 0.1) : 1 / kFrameRate;
    last_frame_ = Clock::now();
    if (single_step_) {
      step(), steps = 1;
    } else if (!paused_ && blowup_.empty()) {
      debt_ += wall;
      while (debt_ >= h_ && blowup_.empty()) {
        if (seconds_since(t0) > kPhysicsBudget / kFrameRate) {
          debt_ = 0;  // fall behind rather than stutter: the panel shows the real-time factor
          break;
        }
        step(), ++steps, debt_ -= h_;
      }
    }
    rt_samples_.push_back({wall, steps * h_});
    if (rt_samples_.size() > 60) rt_samples_.pop_front();
  }
  single_step_ = false;
  const double spent = seconds_since(t0);
  timing.steps += static_cast<std::uint64_t>(steps);
  timing.simulated += steps * h_;
  steps_last_frame_ = steps;
  if (steps > 0) push_history(step_ms_, 1e3 * spent / steps);
  const Energies e = energies(world().model, world().state);
  push_history(energy_, e.total());
  push_history(kinetic_, e.kinetic);
  return spent;
}

void Viewer::step() {
  auto forces = [&] {
    if (drag_) sim_->add_force(drag_->quanta, drag_->force(world().state));
    if (push_) sim_->add_force(push_->first, push_->second);
  };
  StepReport r;
  if (scene_.adaptive.enabled) {
    const double t1 = world().state.time + h_;
    while (world().state.time < t1 && r.status == StepReport::Status::ok) r = adaptive_step(*sim_, scene_.adaptive, t1, forces).step;
  } else {
    forces();
    r = sim_->step();
  }
  if (r.status == StepReport::Status::blowup) {
    blowup_ = r.message;
    paused_ = true;
  }
}

double Viewer::advance_replay(Timing& timing) {
  const auto t0 = Clock::now();
  const std::size_t before = replay_->index();
  if (opt_.frames > 0) {  // headless: one recorded frame per viewer frame, the same for every run
    if (replay_frames_++ > 0 && (!paused_ || single_step_)) show_frame(replay_->index() + 1);
  } else {  // interactive: the recorded times at the panel's speed
    const double wall = last_frame_ ? std::min(seconds_since(*last_frame_), 0.1) : 0.0;
    last_frame_ = Clock::now();
    if (single_step_) {
      show_frame(replay_->index() + 1);
    } else if (!paused_) {
      const double clock = replay_clock_ + wall * replay_speed_;
      show_frame(replay_->at_time(clock));
      replay_clock_ = clock;
      if (replay_->index() + 1 == replay_->size()) paused_ = true;  // the end: space plays it again
    }
  }
  single_step_ = false;
  timing.simulated += replay_->time(replay_->index()) - replay_->time(before);
  if (replay_->index() != before || kinetic_.empty()) {
    const Energies e = energies(world().model, world().state);
    push_history(kinetic_, e.kinetic);
  }
  return seconds_since(t0);
}

double Viewer::real_time_factor() const {
  double wall = 0, sim = 0;
  for (const auto& [w, s] : rt_samples_) wall += w, sim += s;
  return wall > 0 ? sim / wall : 0;
}

}  // namespace qbond::view
