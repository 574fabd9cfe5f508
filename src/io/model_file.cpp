#include "gipdyn/io/model_file.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"
#include "gipdyn/io/atomic_file.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the model file stores little-endian doubles; add byte swapping for this platform"
#endif

namespace gipdyn {
namespace {

constexpr char kMagic[8] = {'G', 'I', 'P', 'D', 'Y', 'N', 'M', 'F'};
constexpr size_t kPrefix = 8 + 4 + 4 + 8;

std::uint64_t fnv1a(const char* data, size_t size) {
  std::uint64_t h = 1469598103934665603ULL;
  for (size_t k = 0; k < size; ++k) {
    h ^= static_cast<unsigned char>(data[k]);
    h *= 1099511628211ULL;
  }
  return h;
}

template <class T>
void put(std::string& buf, const T& v) {
  buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

template <class T>
T get(const std::string& buf, size_t at) {
  T v;
  std::memcpy(&v, buf.data() + at, sizeof(T));
  return v;
}

std::vector<double> to_vector(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }

}  // namespace

std::string serialize_model(const InverseDynamicsModel& model) {
  using nlohmann::json;
  const int n = model.num_joints();
  const Eigen::Index N = model.num_training_samples();
  json h;
  h["format"] = "gipdyn-model";
  h["format_version"] = kModelFormatVersion;
  h["joints"] = model.joints().str();
  h["kernel"] = model.kernel_name();
  h["num_training_samples"] = N;
  h["output_scaling"] = to_string(model.output_scaling());
  json joints = json::array();
  json arrays = json::array({{{"name", "X"}, {"rows", N}, {"cols", 3 * n}}});
  for (int j = 0; j < n; ++j) {
    const GpRegressor& gp = model.joint_gp(j);
    joints.push_back({{"joint", j + 1},
                      {"output_offset", model.output_offset()(j)},
                      {"output_scale", model.output_scale()(j)},
                      {"param_names", gp.kernel().param_names()},
                      {"log_params", to_vector(gp.kernel().log_params())},
                      {"log_noise_variance", gp.log_noise_variance()},
                      {"jitter", gp.jitter()},
                      {"nll", gp.nll()}});
    arrays.push_back({{"name", "alpha" + std::to_string(j + 1)}, {"rows", N}, {"cols", 1}});
  }
  h["joint_models"] = joints;
  h["arrays"] = arrays;
  const std::string header = h.dump(1);

  std::string buf(kMagic, sizeof(kMagic));
  put<std::uint32_t>(buf, kModelFormatVersion);
  put<std::uint32_t>(buf, 0);
  put<std::uint64_t>(buf, header.size());
  buf += header;
  const Eigen::MatrixXd& X = model.training_inputs();
  buf.append(reinterpret_cast<const char*>(X.data()), sizeof(double) * static_cast<size_t>(X.size()));
  for (int j = 0; j < n; ++j) {
    const Eigen::VectorXd& a = model.joint_gp(j).alpha();
    buf.append(reinterpret_cast<const char*>(a.data()), sizeof(double) * static_cast<size_t>(a.size()));
  }
  put<std::uint64_t>(buf, fnv1a(buf.data(), buf.size()));
  return buf;
}

void save_model(const InverseDynamicsModel& model, const std::string& path) {
  const std::string buf = serialize_model(model);
  write_file_atomically(path, [&](std::ostream& out) { out.write(buf.data(), static_cast<std::streamsize>(buf.size())); },
                        true);
}

InverseDynamicsModel load_model(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open model file '" + path + "': " + std::strerror(errno));
  const std::string buf((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return deserialize_model(buf, "model file '" + path + "'");
}

InverseDynamicsModel deserialize_model(const std::string& buf, const std::string& what) {
  using nlohmann::json;
  if (buf.size() < kPrefix || std::memcmp(buf.data(), kMagic, sizeof(kMagic)) != 0)
    throw Error(what + " is not a gipdyn model (bad magic or truncated header); train one with `gipdyn train`");
  const auto version = get<std::uint32_t>(buf, 8);
  if (version > kModelFormatVersion)
    throw Error(what + " has format version " + std::to_string(version) + ", newer than this gipdyn reads (" +
                std::to_string(kModelFormatVersion) + "); upgrade gipdyn");
  const auto header_size = get<std::uint64_t>(buf, 16);
  if (header_size > buf.size() - kPrefix) throw Error(what + " is truncated (header cut off); re-save the model");
  json h;
  try {
    h = json::parse(buf.substr(kPrefix, header_size));
  } catch (const std::exception&) {
    throw Error(what + " is corrupted (unreadable header); re-save the model");
  }
  try {
    const JointTypes joints = JointTypes::parse(h.at("joints").get<std::string>());
    const int n = joints.size();
    const Eigen::Index N = h.at("num_training_samples").get<Eigen::Index>();
    const size_t payload = sizeof(double) * static_cast<size_t>(N) * static_cast<size_t>(3 * n + n);
    const size_t expected = kPrefix + header_size + payload + 8;
    if (buf.size() < expected)
      throw Error(what + " is truncated (" + std::to_string(buf.size()) + " of " + std::to_string(expected) +
                  " bytes); re-save the model");
    if (buf.size() != expected) throw Error(what + " is corrupted (unexpected size); re-save the model");
    if (get<std::uint64_t>(buf, expected - 8) != fnv1a(buf.data(), expected - 8))
      throw Error(what + " is corrupted (checksum mismatch); re-save the model");

    size_t at = kPrefix + header_size;
    Eigen::MatrixXd X(N, 3 * n);
    std::memcpy(X.data(), buf.data() + at, sizeof(double) * static_cast<size_t>(X.size()));
    at += sizeof(double) * static_cast<size_t>(X.size());
    const std::string kernel_name = h.at("kernel").get<std::string>();
    const FeatureMap features(joints);
    std::vector<GpRegressor> gps;
    Eigen::VectorXd offset(n), scale(n);
    const json& jm = h.at("joint_models");
    if (static_cast<int>(jm.size()) != n) throw Error(what + " is corrupted (wrong number of joint models)");
    for (int j = 0; j < n; ++j) {
      const json& e = jm.at(static_cast<size_t>(j));
      std::unique_ptr<Kernel> k = make_kernel(kernel_name, features, j);
      const auto p = e.at("log_params").get<std::vector<double>>();
      if (static_cast<int>(p.size()) != k->num_params()) throw Error(what + " is corrupted (parameter count)");
      k->set_log_params(Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<Eigen::Index>(p.size())));
      GpRegressor gp(std::move(k), e.at("log_noise_variance").get<double>());
      Eigen::VectorXd alpha(N);
      std::memcpy(alpha.data(), buf.data() + at, sizeof(double) * static_cast<size_t>(N));
      at += sizeof(double) * static_cast<size_t>(N);
      gp.set_state(alpha, e.at("jitter").get<double>(), e.at("nll").get<double>());
      gps.push_back(std::move(gp));
      offset(j) = e.at("output_offset").get<double>();
      scale(j) = e.at("output_scale").get<double>();
    }
    return InverseDynamicsModel(joints, kernel_name, std::move(X), std::move(gps),
                                parse_output_scaling(h.at("output_scaling").get<std::string>()), offset, scale);
  } catch (const json::exception& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
}

}  // namespace gipdyn
