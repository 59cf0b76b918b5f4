// The experiments' runner: a failed claim fails the run (and is written as such), an
// informative statement does not, and a source tree's committed results are not overwritten
// unless asked. Experiments defined here stand in for the paper's, which ctest runs as
// experiment.NAME.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "experiment.hpp"

namespace ex = qbond::experiments;
namespace fs = std::filesystem;

namespace {

void holds(const ex::Options&, ex::Report& rep) {
  rep.paper("a test system", "a quoted claim");
  rep.value("answer", 42);
  rep.check("two and two make four", 2 + 2 == 4);
  rep.inform("the machine is shared", "not measurable here");
}

void fails(const ex::Options&, ex::Report& rep) {
  rep.paper("a test system", "");
  rep.check("two and two make five", 2 + 2 == 5);
}

const ex::Experiment kList[] = {{"holds", "An experiment whose claim holds", holds},
                                {"fails", "An experiment whose claim fails", fails}};

fs::path fresh(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("qbond_experiments_test_" + std::to_string(getpid())) / name;
  fs::remove_all(d);
  return d;
}

std::string read(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

ex::RunOptions options(const fs::path& out) {
  ex::RunOptions o;
  o.fast = true;
  o.plots = false;
  o.out = out;
  return o;
}

}  // namespace

TEST(Experiments, AFailedClaimFailsTheRunAndIsWrittenSo) {
  const fs::path out = fresh("fails");
  EXPECT_EQ(ex::run_experiments(kList, {"fails"}, options(out)), 1);
  EXPECT_NE(read(out / "fails" / "summary.md").find("- **FAIL**: two and two make five"), std::string::npos);
  const auto j = nlohmann::json::parse(read(out / "fails" / "results.json"));
  EXPECT_FALSE(j["passed"].get<bool>());
  EXPECT_FALSE(j["checks"][0]["pass"].get<bool>());
  EXPECT_EQ(j["paper"]["quote"], "");
  EXPECT_EQ(ex::run_experiments(kList, {"all"}, options(out)), 1);  // one of the two fails
}

TEST(Experiments, HeldClaimsAndInformativeStatementsPass) {
  const fs::path out = fresh("holds");
  EXPECT_EQ(ex::run_experiments(kList, {"holds"}, options(out)), 0);
  const std::string md = read(out / "holds" / "summary.md");
  EXPECT_NE(md.find("**The paper**, for a test system:\n\n> a quoted claim"), std::string::npos);
  EXPECT_NE(md.find("- **informative** (not checked: not measurable here): the machine is shared"), std::string::npos);
  const auto j = nlohmann::json::parse(read(out / "holds" / "results.json"));
  EXPECT_TRUE(j["passed"].get<bool>());
  EXPECT_TRUE(j["fast"].get<bool>());
  EXPECT_EQ(j["values"]["answer"].get<double>(), 42);
  EXPECT_EQ(j["informative"].size(), 1u);
}

TEST(Experiments, UnknownNamesAreRefused) {
  EXPECT_THROW(ex::run_experiments(kList, {"nonesuch"}, options(fresh("unknown"))), std::invalid_argument);
}

TEST(Experiments, ASourceTreesCommittedResultsNeedUpdateResults) {
  // A folder laid out as a source tree: experiments/experiment.cpp beside experiments/results.
  const fs::path tree = fresh("tree");
  fs::create_directories(tree / "experiments" / "results" / "holds");
  std::ofstream(tree / "experiments" / "experiment.cpp") << "// stands in for the source\n";
  std::ofstream(tree / "experiments" / "results" / "holds" / "summary.md") << "committed\n";
  EXPECT_THROW(ex::run_experiments(kList, {"holds"}, options(tree / "experiments" / "results")), std::invalid_argument);
  EXPECT_THROW(ex::run_experiments(kList, {"holds"}, options(tree / "experiments" / "results" / ".")),
               std::invalid_argument);
  EXPECT_EQ(read(tree / "experiments" / "results" / "holds" / "summary.md"), "committed\n");
  ex::RunOptions o = options(tree / "experiments" / "results");
  o.update_results = true;
  EXPECT_EQ(ex::run_experiments(kList, {"holds"}, o), 0);
  EXPECT_NE(read(tree / "experiments" / "results" / "holds" / "summary.md"), "committed\n");
}

TEST(Experiments, StudentsTQuantiles) {
  EXPECT_DOUBLE_EQ(ex::student_t975(1), 12.706);
  EXPECT_DOUBLE_EQ(ex::student_t975(23), 2.069);
  // Beyond the table: the Cornish–Fisher series, within 0.001 of the exact 2.021 (40) and 1.984 (100).
  EXPECT_NEAR(ex::student_t975(40), 2.021, 1e-3);
  EXPECT_NEAR(ex::student_t975(100), 1.984, 1e-3);
}
