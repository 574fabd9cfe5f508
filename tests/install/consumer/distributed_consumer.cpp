// Links gipdyn::distributed from the installed package and evaluates one NLL on one process.
#include <gipdyn/distributed/distributed_nll.hpp>
#include <gipdyn/gipdyn.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  gipdyn::MpiSession mpi(&argc, &argv);
  const gipdyn::JointTypes joints = gipdyn::JointTypes::parse("RR");
  const gipdyn::FeatureMap features(joints);
  const Eigen::MatrixXd Z = features.compute(Eigen::MatrixXd::Random(50, 6));
  auto kernel = gipdyn::make_kernel("gip", features, 0);
  kernel->initialize(Z, 1.0);
  gipdyn::DistributedNll backend;
  const gipdyn::NllEvaluation e =
      backend.evaluate(*kernel, -2.0, Z, Eigen::VectorXd::Random(50), true, nullptr, gipdyn::JitterPolicy{});
  if (!e.ok()) return 1;
  std::printf("distributed NLL %.6g on %s\n", e.nll, backend.describe().c_str());
  return 0;
}
