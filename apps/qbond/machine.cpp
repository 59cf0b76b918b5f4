#include "machine.hpp"

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace qbond::cli {

std::string machine() {
  char host[256] = "unknown";
  gethostname(host, sizeof host - 1);
  return std::string(host) + ", " + std::to_string(sysconf(_SC_NPROCESSORS_ONLN)) + " cores";
}

namespace {
// A dependent chain of multiply-adds: a core's arithmetic speed, out of memory's way.
double spin(long n) {
  volatile double seed = 1.000000001;
  double x = seed;
  for (long k = 0; k < n; ++k) x = x * 0.999999999 + 1e-9;
  return x;
}

double seconds_to_spin(long n) {
  const auto t0 = std::chrono::steady_clock::now();
  volatile double sink = spin(n);
  (void)sink;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

int CoreSpeeds::fastest() const {
  const auto best = std::max_element(speed.begin(), speed.end());
  return best == speed.end() ? -1 : cpus[static_cast<std::size_t>(best - speed.begin())];
}

double CoreSpeeds::slowest() const {
  return speed.empty() ? 1 : *std::min_element(speed.begin(), speed.end());
}

CoreSpeeds core_speeds() {
  CoreSpeeds s;
  cpu_set_t allowed;
  if (pthread_getaffinity_np(pthread_self(), sizeof allowed, &allowed) != 0) return s;
  std::vector<double> seconds;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (!CPU_ISSET(cpu, &allowed)) continue;
    const PinToCore pin(cpu);
    double best = HUGE_VAL;
    for (int run = 0; run < 5; ++run) best = std::min(best, seconds_to_spin(4'000'000));  // a few ms each
    s.cpus.push_back(cpu);
    seconds.push_back(best);
  }
  const double fastest = seconds.empty() ? 0 : *std::min_element(seconds.begin(), seconds.end());
  for (double t : seconds) s.speed.push_back(fastest / t);
  return s;
}

PinToCore::PinToCore(int cpu) {
  if (cpu < 0 || cpu >= CPU_SETSIZE) return;
  cpu_set_t before, one;
  if (pthread_getaffinity_np(pthread_self(), sizeof before, &before) != 0) return;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  if (pthread_setaffinity_np(pthread_self(), sizeof one, &one) != 0) return;
  saved_.resize(sizeof before);
  std::memcpy(saved_.data(), &before, sizeof before);
  pinned_ = true;
}

PinToCore::~PinToCore() {
  if (!pinned_) return;
  cpu_set_t before;
  std::memcpy(&before, saved_.data(), sizeof before);
  pthread_setaffinity_np(pthread_self(), sizeof before, &before);
}

}  // namespace qbond::cli
