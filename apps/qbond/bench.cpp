#include "bench.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "machine.hpp"
#include "qbond/io/files.hpp"

namespace qbond::cli {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// qbond_bench is built next to qbond (bench/CMakeLists.txt).
fs::path bench_program() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const fs::path p = (ec ? fs::path(".") : self.parent_path()) / "qbond_bench";
  if (!fs::exists(p))
    throw std::runtime_error("qbond bench: " + p.string() + " not found (build the qbond_bench target)");
  return p;
}

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

double seconds(const json& b, const char* key = "real_time") {
  const std::string unit = b.value("time_unit", "ns");
  const double scale = unit == "ms" ? 1e-3 : unit == "us" ? 1e-6 : unit == "s" ? 1.0 : 1e-9;
  return b.at(key).get<double>() * scale;
}

// Google Benchmark writes a not-a-number (an aggregate's 0/0) as a bare nan or -nan, which is
// not JSON: such values become null.
std::string nan_to_null(std::string s) {
  for (std::size_t p = s.find("nan"); p != std::string::npos; p = s.find("nan", p + 1)) {
    const std::size_t begin = p > 0 && s[p - 1] == '-' ? p - 1 : p, end = p + 3;
    std::size_t q = begin;
    while (q > 0 && s[q - 1] == ' ') --q;
    const bool value = q > 0 && s[q - 1] == ':' && (end == s.size() || !std::isalnum(static_cast<unsigned char>(s[end])));
    if (!value) continue;  // part of a name or a string
    s.replace(begin, end - begin, "null");
    p = begin;
  }
  return s;
}

bool is_triad(const json& b) { return b.at("run_name").get<std::string>().rfind("triad", 0) == 0; }

// The method and lattice size of a run named "KIND/METHOD/n:N[/...]" (as qbond_bench names them).
struct RunName {
  std::string method, n;
};
RunName parse_run_name(const json& b) {
  const std::string name = b.at("run_name");
  const auto s1 = name.find('/'), s2 = name.find('/', s1 + 1), s3 = name.find('/', s2 + 1);
  return {name.substr(s1 + 1, s2 - s1 - 1), name.substr(s2 + 3, s3 == std::string::npos ? s3 : s3 - s2 - 3)};
}

// The triad's bandwidth [B/s] on each thread count it ran on ("triad/threads:T").
std::map<int, double> triad_bandwidths(const json& report, const auto& wanted) {
  std::map<int, double> bandwidth;
  for (const json& b : report.at("benchmarks"))
    if (wanted(b) && is_triad(b))
      bandwidth[static_cast<int>(b.at("threads").get<double>())] = b.at("bytes_per_iteration").get<double>() / seconds(b);
  if (bandwidth.empty()) throw std::runtime_error("qbond bench: the triad did not run");
  return bandwidth;
}

// Rows "step/INTEGRATOR/n:N/threads:T": time per step against the bandwidth bound on as many
// threads, and against the same step on one thread when that ran too.
json step_table(const json& report, const auto& wanted, double h, const std::map<int, double>& bandwidth) {
  std::printf("qbond bench: canonical workload (n^3 cubic lattice, face diagonals, x = 0 anchored, h = %g s)\n", h);
  std::printf("memory bandwidth (STREAM triad, this run):");
  for (const char* sep = " "; const auto& [threads, bw] : bandwidth) {
    std::printf("%s%d thread%s %.2f GB/s", sep, threads, threads == 1 ? "" : "s", bw * 1e-9);
    if (threads != 1 && bandwidth.contains(1)) std::printf(" (%.2fx one)", bw / bandwidth.at(1));
    sep = "; ";
  }
  std::printf("\nbound = bytes a step must move / the bandwidth on as many threads; vs 1T = speed-up over one thread\n\n");
  std::printf("%-10s %-16s %8s %8s %7s %10s %11s %12s %11s %9s %7s\n", "workload", "integrator", "quanta", "bonds",
              "threads", "ms/step", "ns/bond", "ns/quanta", "bytes/qnt", "x bound", "vs 1T");
  std::map<std::string, double> one_thread;  // seconds a step on one thread, by run name without threads
  auto key = [](const json& b) {
    const std::string name = b.at("run_name");
    const auto t = name.find("/threads:"), end = name.find('/', t + 1);
    return name.substr(0, t) + (end == std::string::npos ? "" : name.substr(end));
  };
  for (const json& b : report.at("benchmarks"))
    if (wanted(b) && !is_triad(b) && b.at("threads").get<double>() == 1) one_thread[key(b)] = seconds(b);
  json rows = json::array();
  for (const json& b : report.at("benchmarks")) {
    if (!wanted(b) || is_triad(b)) continue;
    auto [integrator, n] = parse_run_name(b);
    const bool as_run = b.at("run_name").get<std::string>().find("/as_run") != std::string::npos;
    if (as_run) integrator += "+run";
    const double t = seconds(b), quanta = b.at("quanta"), bonds = b.at("bonds"), threads = b.at("threads"),
                 bytes = b.at("bytes_per_step");
    const auto bw = bandwidth.find(static_cast<int>(threads));
    const double bytes_per_second = bw != bandwidth.end() ? bw->second : bandwidth.begin()->second;
    const double ratio = t / (bytes / bytes_per_second);
    const auto one = one_thread.find(key(b));
    const double speedup = one != one_thread.end() ? one->second / t : NAN;
    std::printf("%-10s %-16s %8.0f %8.0f %7.0f %10.4f %11.3f %12.2f %11.1f %9.2f %7.2f\n", ("n=" + n).c_str(),
                integrator.c_str(), quanta, bonds, threads, t * 1e3, t / bonds * 1e9, t / quanta * 1e9, bytes / quanta,
                ratio, speedup);
    rows.push_back({{"workload", "lattice n=" + n},
                    {"integrator", integrator},
                    {"as_run", as_run},
                    {"quanta", std::llround(quanta)},
                    {"bonds", std::llround(bonds)},
                    {"threads", std::llround(threads)},
                    {"timestep", b.at("timestep").get<double>()},
                    {"seconds_per_step", t},
                    {"ns_per_bond_step", t / bonds * 1e9},
                    {"ns_per_quanta_step", t / quanta * 1e9},
                    {"bytes_per_quanta_step", bytes / quanta},
                    {"bandwidth_bytes_per_second", bytes_per_second},
                    {"ratio_to_bandwidth_bound", ratio},
                    {"speedup_over_one_thread", std::isnan(speedup) ? json(nullptr) : json(speedup)}});
  }
  return rows;
}

// Rows "solve/SOLVER/n:N": one backward-Euler step at h = 1/60 s to a relative residual of 1e-6;
// multigrid's and PETSc's also with their set-up and CG times apart and their levels.
template <class Wanted>
json solve_table(const json& report, const Wanted& wanted) {
  std::printf("qbond bench --solve: one backward-Euler step of the canonical workload at h = 1/60 s, solved to a\n"
              "relative residual of 1e-6 (Cholesky: exact), the system's assembly included; ratio = time / qbond_cg's;\n"
              "qbond_mg, petsc_*: set-up (the hierarchy; PETSc's: the copy into PETSc too) and CG apart;\n"
              "residual: the true ||b - A y|| / ||b|| of every row\n\n");
  std::printf("%-8s %-16s %8s %11s %12s %12s %8s %10s %10s %7s\n", "workload", "solver", "quanta", "iterations",
              "residual", "ms", "ratio", "setup ms", "solve ms", "levels");
  json rows = json::array();
  std::map<std::string, double> qbond_time;  // by n
  for (const json& b : report.at("benchmarks"))
    if (wanted(b) && parse_run_name(b).method == "qbond_cg") qbond_time[parse_run_name(b).n] = seconds(b);
  for (const json& b : report.at("benchmarks")) {
    if (!wanted(b)) continue;
    const auto [solver, n] = parse_run_name(b);
    const double t = seconds(b), t_q = qbond_time[n];
    const bool mg = b.contains("setup_seconds");
    std::printf("%-8s %-16s %8.0f %11.0f %12.3g %12.3f %8.2f", ("n=" + n).c_str(), solver.c_str(),
                b.at("quanta").get<double>(), b.value("solver_iterations", 0.0), b.at("residual").get<double>(), t * 1e3,
                t_q > 0 ? t / t_q : NAN);
    if (mg)
      std::printf(" %10.3f %10.3f %7.0f", b.at("setup_seconds").get<double>() * 1e3,
                  b.at("solve_seconds").get<double>() * 1e3, b.value("levels", 0.0));
    std::printf("\n");
    json row = {{"workload", "lattice n=" + n},
                {"solver", solver},
                {"quanta", std::llround(b.at("quanta").get<double>())},
                {"iterations", b.value("solver_iterations", 0.0)},
                {"relative_residual", b.at("residual").get<double>()},
                {"seconds", t},
                // The timing thread's CPU time: on a loaded host, wall time over it tells the load.
                {"cpu_seconds", seconds(b, "cpu_time")},
                {"ratio_to_qbond_cg", t_q > 0 ? t / t_q : NAN}};
    if (mg) {
      row["setup_seconds"] = b.at("setup_seconds").get<double>();
      row["solve_seconds"] = b.at("solve_seconds").get<double>();
      if (b.contains("setup_cpu_seconds")) {
        row["setup_cpu_seconds"] = b.at("setup_cpu_seconds").get<double>();
        row["solve_cpu_seconds"] = b.at("solve_cpu_seconds").get<double>();
      }
      if (b.contains("levels")) row["levels"] = std::llround(b.at("levels").get<double>());
    }
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

int bench(const BenchArgs& a) {
  const fs::path program = bench_program();
  const fs::path out = fs::temp_directory_path() / ("qbond_bench_" + std::to_string(getpid()) + ".json");
  std::string cmd = quoted(program.string()) + " --benchmark_out=" + quoted(out.string()) +
                    " --benchmark_out_format=json --benchmark_format=console";
  const int reps = a.quick ? 1 : std::max(1, a.repetitions);
  cmd += " --benchmark_min_time=" + std::string(a.quick ? "0.01" : "0.3");
  // Repetitions in random order: the host's speed drifts over a run (another tenant, the memory
  // bandwidth), and a drift then moves every row's median alike, not the later rows' alone — the
  // ratios (× bound, vs 1T) compare rows measured in the same stretch of time.
  if (reps > 1)
    cmd += " --benchmark_repetitions=" + std::to_string(reps) +
           " --benchmark_report_aggregates_only=true --benchmark_enable_random_interleaving=true";
  cmd += " --n=" + quoted(a.sizes.empty() ? (a.quick ? "10" : "10,20,40") : a.sizes);
  if (a.solve) {
    cmd += " --solve";
  } else {
    cmd += " --threads=" + quoted(a.threads);
    if (!a.integrators.empty()) cmd += " --integrators=" + quoted(a.integrators);
    if (a.as_run) cmd += " --as-run";
  }
  if (a.dt > 0) {
    char h[40];
    std::snprintf(h, sizeof h, "%.17g", a.dt);
    cmd += std::string(" --dt=") + h;
  }
  cmd += " >&2";  // Google Benchmark's own report goes to stderr, the table to stdout
  if (std::system(cmd.c_str()) != 0) {
    fs::remove(out);
    throw std::runtime_error("qbond bench: qbond_bench failed (" + cmd + ")");
  }
  json report = json::parse(nan_to_null(read_file(out)));
  fs::remove(out);
  // Debian builds its libbenchmark without NDEBUG, and the library then warns about itself.
  if (report.contains("context") && report["context"].value("library_build_type", "") == "debug")
    std::fprintf(stderr,
                 "qbond bench: the \"Library was built as DEBUG\" warning above is about the timing library "
                 "(Google Benchmark, whose Debian package is built without NDEBUG), not the code it times: "
                 "qbond_bench is built %s\n",
#ifdef NDEBUG
                 "optimised, without assertions");
#else
                 "with assertions (a debug build of qbond: its timings are not representative)");
#endif
  // In the order the benchmarks were registered (integrator, size, threads), not the random one
  // they ran in.
  auto order = [](const json& b) {
    return std::pair(b.value("family_index", 0.0), b.value("per_family_instance_index", 0.0));
  };
  std::stable_sort(report.at("benchmarks").begin(), report.at("benchmarks").end(),
                   [&](const json& a, const json& b) { return order(a) < order(b); });

  // The median of the repetitions (or the single run).
  const auto wanted = [&](const json& b) {
    if (b.contains("error_occurred") && b["error_occurred"].get<bool>())
      throw std::runtime_error("qbond bench: " + b.at("run_name").get<std::string>() + ": " +
                               b.value("error_message", "failed"));
    return reps > 1 ? b.value("aggregate_name", "") == "median" : b.value("run_type", "iteration") == "iteration";
  };
  std::map<int, double> bandwidth;  // [B/s] by thread count; the solver comparison runs no triad
  if (!a.solve) bandwidth = triad_bandwidths(report, wanted);
  const json rows = a.solve ? solve_table(report, wanted) : step_table(report, wanted, a.dt > 0 ? a.dt : 1e-4, bandwidth);
  if (!a.json.empty()) {
    const std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    json by_threads = json::object();  // the triad's bandwidth by thread count
    for (const auto& [threads, bw] : bandwidth) by_threads[std::to_string(threads)] = bw;
    const json doc = {{"date", date},
                      {"machine", machine()},
                      {"repetitions", reps},
                      {"nice", getpriority(PRIO_PROCESS, 0)},
                      {"triad_bytes_per_second", bandwidth.contains(1) ? json(bandwidth.at(1)) : json(nullptr)},
                      {"triad_bytes_per_second_by_threads", by_threads},
                      {"rows", rows}};
    write_file_atomic(a.json, doc.dump(1) + "\n");
  }
  return 0;
}

}  // namespace qbond::cli
