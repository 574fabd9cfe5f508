// Log preprocessing: the zero-phase Butterworth filter (phase and gain on
// sinusoids), numerical derivatives of analytic trajectories, resampling of an
// irregular time grid, and the whole `preprocess` pipeline with its report.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>
#include <random>

#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/preprocess/log_preprocessing.hpp"
#include "gipdyn/preprocess/signal.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

namespace fs = std::filesystem;
const double kPi = std::acos(-1.0);

// Least-squares amplitude and phase of the f-Hz component of y(t).
std::pair<double, double> amplitude_and_phase(const Eigen::VectorXd& t, const Eigen::VectorXd& y, double f) {
  Eigen::MatrixXd B(t.size(), 2);
  B.col(0) = (2 * kPi * f * t.array()).sin();
  B.col(1) = (2 * kPi * f * t.array()).cos();
  const Eigen::Vector2d c = B.colPivHouseholderQr().solve(y);
  return {std::hypot(c(0), c(1)), std::atan2(c(1), c(0))};
}

// Filtered forward and backward, the gain is |H(f)|^2, which for the bilinear
// Butterworth is 1 / (1 + (tan(pi f / fs) / tan(pi fc / fs))^(2N)); the phase is 0.
TEST(ZeroPhaseButterworth, GainAndZeroPhaseOnSinusoids) {
  const double fs = 100.0, fc = 5.0;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(4000, 0.0, 3999.0 / fs);
  for (int order : {1, 2, 3, 4}) {
    const auto sections = butterworth_lowpass(order, fc, fs);
    for (double f : {0.5, 2.0, 5.0, 8.0, 20.0}) {
      const Eigen::VectorXd x = (2 * kPi * f * t.array() + 0.3).sin();
      const Eigen::VectorXd y = filtfilt(sections, x);
      // Away from the ends, where the edge handling still matters.
      const Eigen::Index a = 500, m = 3000;
      const auto [amp, phase] = amplitude_and_phase(t.segment(a, m), y.segment(a, m), f);
      const double ratio = std::tan(kPi * f / fs) / std::tan(kPi * fc / fs);
      const double expected = 1.0 / (1.0 + std::pow(ratio, 2 * order));
      EXPECT_NEAR(amp, expected, 1e-6 + 1e-4 * expected) << "order " << order << " f " << f;
      if (expected > 1e-3) {
        EXPECT_NEAR(phase, 0.3, 1e-6) << "order " << order << " f " << f;
      }
    }
    // One pass of the designed sections is the -3 dB point at the cutoff:
    // |H(exp(i w))| = 1/sqrt(2) at w = 2 pi fc / fs, evaluated from the coefficients.
    const std::complex<double> z = std::polar(1.0, -2 * kPi * fc / fs);  // z^-1
    std::complex<double> H = 1.0;
    for (const Biquad& s : sections) H *= (s.b0 + s.b1 * z + s.b2 * z * z) / (1.0 + s.a1 * z + s.a2 * z * z);
    EXPECT_NEAR(std::abs(H), 1.0 / std::sqrt(2.0), 1e-12) << "order " << order;
  }
}

TEST(ZeroPhaseButterworth, KeepsConstantsAndLinesAndRejectsBadSettings) {
  const auto sections = butterworth_lowpass(2, 2.0, 50.0);
  Eigen::MatrixXd x(200, 2);
  x.col(0).setConstant(3.5);
  x.col(1) = Eigen::VectorXd::LinSpaced(200, -1.0, 4.0);
  const Eigen::MatrixXd y = filtfilt(sections, x);
  // Unit DC gain and steady-state starts: a constant passes unchanged. A line
  // passes unchanged once the start-up transient (which assumed a constant) has died out.
  EXPECT_LT((y.col(0) - x.col(0)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((y.col(1) - x.col(1)).segment(60, 80).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_THROW(butterworth_lowpass(2, 30.0, 50.0), Error);  // above Nyquist
  EXPECT_THROW(butterworth_lowpass(0, 1.0, 50.0), Error);
  try {
    filtfilt(sections, Eigen::MatrixXd::Ones(5, 1));  // shorter than the padding
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("has 5; filter a longer stretch, or leave this one unfiltered"),
              std::string::npos)
        << e.what();
  }
}

// Second-order differences: error O(dt^2) inside and at the ends.
TEST(TimeDerivative, AccurateOnAnalyticTrajectories) {
  const double dt = 1e-3;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(5001, 0.0, 5.0);
  const Eigen::ArrayXd w1 = Eigen::ArrayXd::Constant(t.size(), 2 * kPi * 0.5), w2 = Eigen::ArrayXd::Constant(t.size(), 2 * kPi * 1.3);
  const Eigen::ArrayXd q = (w1 * t.array()).sin() + 0.3 * (w2 * t.array()).cos();
  const Eigen::ArrayXd qd = w1 * (w1 * t.array()).cos() - 0.3 * w2 * (w2 * t.array()).sin();
  const Eigen::ArrayXd qdd = -w1.square() * (w1 * t.array()).sin() - 0.3 * w2.square() * (w2 * t.array()).cos();
  const Eigen::MatrixXd d1 = time_derivative(q.matrix(), dt);
  const Eigen::MatrixXd d2 = time_derivative(d1, dt);
  // Truncation bounds: central differences dt^2/6 max|q'''| inside, one-sided dt^2/3 max|q'''|
  // at the ends; differencing twice is a central difference over 2 dt: (2 dt)^2/6 max|q''''|.
  const double d3 = std::pow(w1(0), 3) + 0.3 * std::pow(w2(0), 3), d4 = std::pow(w1(0), 4) + 0.3 * std::pow(w2(0), 4);
  const Eigen::Index n = t.size();
  EXPECT_LT((d1.col(0).array() - qd).abs().segment(1, n - 2).maxCoeff(), dt * dt / 6 * d3);
  EXPECT_LT((d1.col(0).array() - qd).abs().maxCoeff(), dt * dt / 3 * d3);
  EXPECT_LT((d2.col(0).array() - qdd).abs().segment(2, n - 4).maxCoeff(), 4 * dt * dt / 6 * d4 * 1.05);
  // The two end rows combine two one-sided stencils: first order in dt there.
  EXPECT_LT((d2.col(0).array() - qdd).abs().maxCoeff(), 0.05);
  EXPECT_THROW(time_derivative(Eigen::MatrixXd::Ones(2, 1), dt), Error);
}

TEST(Resampling, IrregularGridOntoUniformGrid) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.4e-3, 0.4e-3);
  Eigen::VectorXd t(2001);
  for (Eigen::Index i = 0; i < t.size(); ++i) t(i) = 1e-3 * static_cast<double>(i) + (i > 0 && i < 2000 ? jitter(rng) : 0.0);
  Eigen::MatrixXd x(t.size(), 2);
  x.col(0) = (3.0 - 2.0 * t.array()).matrix();       // linear: interpolation is exact
  x.col(1) = (2 * kPi * t.array()).sin().matrix();   // smooth: error <= h^2 / 8 max|x''|
  const Eigen::VectorXd grid = Eigen::VectorXd::LinSpaced(401, 0.0, 2.0);
  const Eigen::MatrixXd y = resample_linear(t, x, grid);
  EXPECT_LT((y.col(0).array() - (3.0 - 2.0 * grid.array())).abs().maxCoeff(), 1e-12);
  // Linear interpolation: error <= h^2 / 8 max|x''| with h the longest input step.
  const double h = (t.tail(t.size() - 1) - t.head(t.size() - 1)).maxCoeff();
  EXPECT_LT((y.col(1).array() - (2 * kPi * grid.array()).sin()).abs().maxCoeff(), h * h / 8 * 4 * kPi * kPi);
  EXPECT_THROW(resample_linear(t, x, Eigen::VectorXd::Constant(1, 5.0)), Error);
}

fs::path temp_file(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("gipdyn_pre_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d / name;
}

// A 2-joint log at an irregular ~500 Hz with positions only, torque noise at
// 100 Hz and a second at rest: the pipeline recovers qd and qdd of the
// analytic motion, removes the noise, and drops exactly the rest.
TEST(PreprocessLog, RecoversDerivativesFiltersNoiseAndDropsRest) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> jitter(-0.5e-3, 0.5e-3);
  const int rows = 3001;
  Eigen::MatrixXd log(rows, 5);  // time, q1, q2, tau1, tau2
  auto motion = [](double t, int j) { return t < 1.0 ? 0.0 : std::sin((j + 1) * (t - 1.0)) * (t - 1.0); };
  for (int i = 0; i < rows; ++i) {
    const double t = 2e-3 * i + (i > 0 && i < rows - 1 ? jitter(rng) : 0.0);
    log(i, 0) = t;
    for (int j = 0; j < 2; ++j) {
      log(i, 1 + j) = motion(t, j);
      log(i, 3 + j) = 2.0 * motion(t, j) + 0.5 * std::sin(2 * kPi * 100.0 * t);  // 100 Hz "noise"
    }
  }
  const fs::path in = temp_file("log.csv");
  write_csv(in.string(), {"t", "q1", "q2", "tau1", "tau2"}, log);
  PreprocessOptions o;
  o.dt = 2e-3;
  o.cutoff_hz = 10.0;
  o.filter_torque = true;
  o.drop_rest = true;
  const PreprocessedLog p = preprocess_log(in.string(), o);
  ASSERT_EQ(p.joints(), 2);
  EXPECT_EQ(p.column_names().front(), "t");
  EXPECT_EQ(p.column_names().back(), "tau2");
  // The first second (t < 1, at rest) is dropped, up to the few samples before
  // t = 1 into which the (non-causal) zero-phase filter spreads the start of motion.
  EXPECT_GT(p.t(0), 0.98);
  EXPECT_LT(p.t(0), 1.02);
  const auto& report = p.report;
  EXPECT_EQ(report["steps"].size(), 4u);
  EXPECT_EQ(report["steps"][3]["dropped_rows"].get<long>(), report["steps"][0]["rows"].get<long>() - p.t.size());
  EXPECT_GE(report["steps"][3]["dropped_rows"].get<long>(), 490);  // most of the 500 samples of the first second
  EXPECT_EQ(report["output_rows"].get<long>(), p.t.size());
  // Away from the ends and from the kink at t = 1 s, derivatives match the analytic ones.
  for (Eigen::Index i = 0; i < p.t.size(); ++i) {
    const double t = p.t(i);
    if (t < 1.5 || t > 5.5) continue;
    for (int j = 0; j < 2; ++j) {
      const double w = j + 1, s = t - 1.0;
      const double qd = w * std::cos(w * s) * s + std::sin(w * s);
      const double qdd = -w * w * std::sin(w * s) * s + 2 * w * std::cos(w * s);
      EXPECT_NEAR(p.qd(i, j), qd, 2e-3) << t;
      EXPECT_NEAR(p.qdd(i, j), qdd, 2e-2) << t;
      // The 0.5-amplitude 100 Hz component is gone, up to what linear interpolation
      // on the jittered grid turned into broadband error.
      EXPECT_NEAR(p.tau(i, j), 2.0 * motion(t, j), 2e-2) << t;
    }
  }
}

// A continuous joint logged within (-pi, pi] (ROS joint_states, many wrists)
// jumps by 2 pi when it wraps; differentiated as it is, each wrap is a velocity
// spike of 2 pi / dt. The log is unwrapped first: the same qd and qdd as the
// log of the unwrapped angle, q equal up to its multiple of 2 pi, and the
// report counts the jumps.
TEST(PreprocessLog, UnwrapsAnglesThatWrapAround) {
  const int rows = 2001;
  Eigen::MatrixXd log(rows, 5);  // t, q1, q2, tau1, tau2
  for (int i = 0; i < rows; ++i) {
    const double t = 2e-3 * i;
    log.row(i) << t, 3.0 * t + 0.5 * std::sin(2.0 * t), 0.3 * std::sin(t), std::cos(t), 0.1;  // q1 turns 2 rad/s
  }
  Eigen::MatrixXd wrapped = log;
  for (int i = 0; i < rows; ++i) wrapped(i, 1) = std::remainder(log(i, 1), 2.0 * kPi);
  const fs::path plain = temp_file("plain.csv"), wrap = temp_file("wrapped.csv");
  write_csv(plain.string(), {"t", "q1", "q2", "tau1", "tau2"}, log);
  write_csv(wrap.string(), {"t", "q1", "q2", "tau1", "tau2"}, wrapped);
  PreprocessOptions o;
  o.cutoff_hz = 20.0;
  const PreprocessedLog a = preprocess_log(plain.string(), o), b = preprocess_log(wrap.string(), o);
  ASSERT_EQ(a.t.size(), b.t.size());
  EXPECT_LT((a.qd - b.qd).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((a.qdd - b.qdd).cwiseAbs().maxCoeff(), 1e-6);
  const Eigen::ArrayXd turns = (a.q.col(0) - b.q.col(0)).array() / (2.0 * kPi);
  EXPECT_LT((turns - turns.round()).abs().maxCoeff(), 1e-9);
  // q1 runs from 0 to about 12.5 rad: past pi at 1 s, then every 2 pi.
  ASSERT_EQ(b.report["steps"][0]["step"], "unwrap");
  EXPECT_EQ(b.report["steps"][0]["jumps"]["q1"].get<int>(), 2);
  EXPECT_FALSE(b.report["steps"][0]["jumps"].contains("q2"));
  EXPECT_EQ(a.report["steps"][0]["step"], "resample");  // nothing to unwrap
  EXPECT_EQ(b.report["dt_s"].get<double>(), 2e-3);
}

TEST(PreprocessLog, NamesEachProblem) {
  const fs::path in = temp_file("bad.csv");
  auto message = [&](const std::vector<std::string>& header, const Eigen::MatrixXd& data, PreprocessOptions o = {}) {
    write_csv(in.string(), header, data);
    return test::error_of([&] { preprocess_log(in.string(), o); });
  };
  Eigen::MatrixXd d(50, 3);
  d.col(0) = Eigen::VectorXd::LinSpaced(50, 0.0, 0.49);
  d.col(1).setRandom();
  d.col(2).setRandom();
  EXPECT_EQ(message({"t", "q1", "tau1"}, d), "");  // a valid log
  EXPECT_NE(message({"time", "q1", "torque"}, d).find("no column tau1"), std::string::npos);
  EXPECT_NE(message({"clock", "q1", "tau1"}, d).find("PreprocessOptions::time_column"), std::string::npos);
  Eigen::MatrixXd back = d;
  back(10, 0) = back(9, 0);
  EXPECT_NE(message({"t", "q1", "tau1"}, back).find("time does not increase at data row 11"), std::string::npos);
  // A time column in milliseconds, as many loggers write it, read as seconds.
  Eigen::MatrixXd ms = d;
  ms.col(0) *= 1000.0;
  EXPECT_NE(message({"t", "q1", "tau1"}, ms)
                .find("its time column 't' advances by 10 per row (median), read as seconds; if it counts milli-"),
            std::string::npos);
  PreprocessOptions high;
  high.cutoff_hz = 60.0;
  EXPECT_NE(message({"t", "q1", "tau1"}, d, high).find("Nyquist"), std::string::npos);
  Eigen::MatrixXd two(50, 5);
  two << d, d.col(1), d.col(2);
  EXPECT_NE(message({"t", "q1", "tau1", "q2", "qd1"}, two).find("no column tau2"), std::string::npos);
  Eigen::MatrixXd partial(50, 6);
  partial << two, d.col(1);
  EXPECT_NE(message({"t", "q1", "tau1", "q2", "tau2", "qd1"}, partial).find("1 of the 2 velocity columns"),
            std::string::npos);
}

}  // namespace
}  // namespace gipdyn
