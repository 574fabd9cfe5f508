#pragma once
// The paper's experiments (docs/results/paper-experiments.md), each writing CSV, a Markdown
// summary and PNG plots into one output folder. Every experiment records each
// finished unit of work (a run of an estimator, a training size, a split) as
// soon as it is done; restarted with the same settings and folder, it skips
// those units. config.json in the folder holds the settings; a restart with
// other settings is refused rather than mixed in (except the number of runs,
// so an experiment can be extended).
#include "experiments/accuracy_experiment.hpp"
#include "experiments/contact_experiment.hpp"
#include "experiments/control_experiment.hpp"
#include "experiments/data_efficiency_experiment.hpp"
#include "experiments/real_robot_experiment.hpp"
