// The C++ leg of the test that every front end gives the same model for the same log and options
// (python/tests/test_python.py): the library's default estimator fitted as train and Python fit it,
// through EstimatorOptions and choose_teacher alone (with "auto": the choice by evidence,
// fit_selected_estimator, as train --model auto and Python's InverseDynamics(model="auto") run it), then
// its predictions of another log.
//   front_end_fit TRAIN.csv JOINTS MAX_ITERATIONS SEED TEST.csv OUT.csv [auto]
#include <cstdio>
#include <string>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/model_selection.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/joint_types.hpp"

int main(int argc, char** argv) {
  using namespace gipdyn;
  const bool choose = argc == 8 && std::string(argv[7]) == kAutomaticEstimator;
  if (argc != 7 && !choose) {
    std::fprintf(stderr, "usage: front_end_fit TRAIN.csv JOINTS MAX_ITERATIONS SEED TEST.csv OUT.csv [auto]\n");
    return 2;
  }
  try {
    const JointTypes joints = JointTypes::parse(argv[2]);
    const Dataset train = read_dataset(argv[1], joints, true);
    EstimatorOptions o;  // the library's defaults: the default estimator and search
    o.search.optimizer.max_iterations = std::stoi(argv[3]);
    o.set_seed(std::stoul(argv[4]));
    TeacherOptions settings;
    settings.seed = o.search.seed;
    FitResult r;
    if (choose) {
      r = fit_selected_estimator(o, SelectionOptions{}, train.X, train.tau, joints, settings).fit;
    } else {
      o.teacher = choose_teacher(kAutomaticTeacher, o, settings);  // every front end's default teacher
      r = fit_estimator(o, train.X, train.tau, joints);
    }
    if (!r.report.ok()) throw Error(r.report.message);
    const Dataset test = read_dataset(argv[5], joints, false);
    write_csv(argv[6], joint_column_names("tau", joints.size()), r.estimator->predict(test.X));
    std::printf("%s\n", choose ? r.estimator->name().c_str() : to_string(r.teaching).c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "front_end_fit: %s\n", e.what());
    return 1;
  }
  return 0;
}
