#pragma once
// The paper's experiments (docs/experiments.md): each one computes its data, writes it as CSV
// into its output directory with a summary.md of its claims and a results.json of its named
// numbers, and checks each claim against theory or the paper with a number; experiments/plot.py
// draws the PNGs from the CSVs; scripts/experiments_doc.py writes docs/experiments.md from them.
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond::experiments {

struct Options {
  bool fast = false;              ///< smaller sizes and fewer steps (CI)
  std::filesystem::path out;      ///< where the CSVs and summary.md go
  std::string python;             ///< Debian's Python, for the experiments that drive a Python tool
  std::filesystem::path scripts;  ///< the folder of the Python scripts (plot.py, fig11_getfem.py)
};

/// What an experiment found: CSV tables, notes, named values and checked claims, written to `out`.
class Report {
 public:
  explicit Report(std::filesystem::path out, bool fast = false) : out_(std::move(out)), fast_(fast) {}
  /// The paper's claim this experiment tests, quoted, and the system the paper made it for
  /// (`quote` empty: the experiment is not in the paper).
  void paper(const std::string& system, const std::string& quote);
  /// One line of what qbond measures, and how it stands to the paper's claim (the docs' summary).
  void headline(const std::string& measured, const std::string& verdict);
  /// A named number of the results (results.json), which docs/experiments.md quotes.
  void value(const std::string& key, double v);
  /// A line of progress on stdout, flushed at once (the run can take minutes).
  void progress(const std::string& what) const;
  /// Starts a CSV file `name` (in the output directory) with this header line.
  void table(const std::string& name, const std::string& header);
  /// Appends a row of numbers (17 significant digits) to the last table started.
  void row(std::initializer_list<double> values);
  /// Appends a row whose first field is text.
  void row(const std::string& label, std::initializer_list<double> values);
  /// A line of the summary (Markdown).
  void note(const std::string& line);
  /// A claim and whether the numbers bear it out; failed claims fail the experiment.
  void check(const std::string& claim, bool ok);
  /// A measured statement reported but not checked, and why it cannot be (it never fails the run).
  void inform(const std::string& statement, const std::string& why);
  bool passed() const { return failed_ == 0; }
  /// Writes the tables, summary.md (title, the paper's claim, notes, checks) and results.json
  /// (the same with the named values) atomically.
  void write(const std::string& name, const std::string& title) const;

 private:
  std::filesystem::path out_;
  bool fast_;
  std::vector<std::pair<std::string, std::string>> tables_;  // file name, content
  std::vector<std::string> lines_;
  std::string system_, quote_, measured_, verdict_;
  std::vector<std::pair<std::string, double>> values_;
  std::vector<std::pair<std::string, bool>> checks_;
  std::vector<std::pair<std::string, std::string>> informative_;
  int failed_ = 0;
};

struct Experiment {
  const char* name;
  const char* title;
  void (*run)(const Options&, Report&);
};

/// Every experiment, in the order of the paper.
std::span<const Experiment> all();

/// How `run_experiments` runs them.
struct RunOptions {
  bool fast = false;            ///< smaller sizes and fewer steps (CI)
  bool plots = true;            ///< draw the PNGs with plot.py
  bool update_results = false;  ///< allow writing into a source tree's committed experiments/results
  std::filesystem::path out;    ///< results directory: one folder an experiment
  std::string python;           ///< Debian's Python
  std::filesystem::path scripts;  ///< where plot.py and fig11_getfem.py are (empty: not found)
};

/// Runs the experiments of `list` named in `names` ("all": every one), printing progress;
/// returns the number that failed (a claim, or their plots). Throws std::invalid_argument for
/// an unknown name, or when `out` is a qbond source tree's committed experiments/results and
/// `update_results` is not set.
int run_experiments(std::span<const Experiment> list, const std::vector<std::string>& names, const RunOptions& opt);

/// The folder holding plot.py next to the program `exe`: exe's share/qbond (the build tree)
/// or ../share/qbond (an installed program); empty when neither has it.
std::filesystem::path find_scripts(const std::filesystem::path& exe);

/// Student's t quantile t_{0.975}(dof): the half-width of a two-sided 95% confidence interval
/// of a mean is t · s/√n with dof = n − 1.
double student_t975(int dof);

// The experiments (one file each, or one per pair of figures).
void drag(const Options&, Report&);
void fig3(const Options&, Report&);
void fig4_5(const Options&, Report&);
void fig6_7(const Options&, Report&);
void eq14_15(const Options&, Report&);
void cantilever(const Options&, Report&);
void energy_momentum(const Options&, Report&);
void integrator_table(const Options&, Report&);
void fig9(const Options&, Report&);
void fig10(const Options&, Report&);
void fig11(const Options&, Report&);
void fig12(const Options&, Report&);
void gas(const Options&, Report&);

/// An integrator under test, named as in the tables and CSVs.
struct Method {
  const char* name;
  IntegratorConfig config;
};

/// The position of the method called `name` in `methods` (methods.size() when absent).
std::size_t index_of(const std::vector<Method>& methods, std::string_view name);

/// A steel bar (E given, 7850 kg/m³) along x, length L and square side b, calibrated at n quanta
/// across on the default cubic lattice; `clamp` is the x = 0 layer (anchored), `end` the x = L
/// layer (free: the experiment loads or turns it).
struct SteelBar {
  World world;
  std::vector<Index> ids, clamp, end;
  double spacing = 0;
};
SteelBar steel_bar(int n, double L, double b, double E);

/// "%.4g"-style formatting for summaries.
std::string num(double v, int digits = 4);

}  // namespace qbond::experiments
