#include "gipdyn/io/detail/model_container.hpp"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/version.hpp"

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

// JSON has no NaN or Inf: nlohmann writes them as null, and the reader's get<double>() then
// fails, so a model with one in its header would be saved and never load again. Returns where
// the first one is ("joint_models/2/log_params/0"), or "" when there is none.
std::string non_finite_header_number(const nlohmann::json& j, const std::string& at) {
  if (j.is_number_float()) return std::isfinite(j.get<double>()) ? "" : at;
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      if (auto where = non_finite_header_number(it.value(), at.empty() ? it.key() : at + "/" + it.key());
          !where.empty())
        return where;
  } else if (j.is_array()) {
    for (size_t k = 0; k < j.size(); ++k)
      if (auto where = non_finite_header_number(j[k], at + "/" + std::to_string(k)); !where.empty()) return where;
  }
  return "";
}

// Names the first non-finite number of the container ("its array 'alpha2'", "its header field
// 'joint_models/0/nll'"), or "" when every number is finite.
std::string non_finite_number(const ModelContainer& c) {
  for (const auto& [name, a] : c.arrays)
    if (!a.allFinite()) return "its array '" + name + "'";
  if (auto where = non_finite_header_number(c.header, ""); !where.empty()) return "its header field '" + where + "'";
  return "";
}

// The bytes of a container whose numbers are all finite (the callers check, each with its own message).
std::string pack_finite_container(const ModelContainer& c) {
  nlohmann::json h = c.header;
  // The container owns the format: nobody else writes these two keys.
  h["format"] = "gipdyn-model";
  h["format_version"] = kModelFormatVersion;
  h["written_by"] = std::string("gipdyn ") + version();
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, a] : c.arrays) list.push_back({{"name", name}, {"rows", a.rows()}, {"cols", a.cols()}});
  h["arrays"] = list;
  const std::string header = h.dump(1);
  std::string buf(kMagic, sizeof(kMagic));
  put<std::uint32_t>(buf, kModelFormatVersion);
  put<std::uint32_t>(buf, 0);
  put<std::uint64_t>(buf, header.size());
  buf += header;
  for (const auto& [name, a] : c.arrays)
    buf.append(reinterpret_cast<const char*>(a.data()), sizeof(double) * static_cast<size_t>(a.size()));
  put<std::uint64_t>(buf, fnv1a(buf.data(), buf.size()));
  return buf;
}

}  // namespace

const Eigen::MatrixXd& ModelContainer::array(const std::string& name, const std::string& what) const {
  for (const auto& [n, a] : arrays)
    if (n == name) return a;
  throw Error(what + " is corrupted (no array '" + name + "'); re-save the model");
}

std::string pack_container(const ModelContainer& c) {
  if (auto where = non_finite_number(c); !where.empty())
    throw Error("the model holds a non-finite number (NaN or Inf) in " + where + "; it cannot be saved: train it again");
  return pack_finite_container(c);
}

ModelContainer unpack_container(const std::string& buf, const std::string& what) {
  using nlohmann::json;
  if (buf.size() < kPrefix || std::memcmp(buf.data(), kMagic, sizeof(kMagic)) != 0)
    throw Error(what + " is not a gipdyn model file (bad magic or truncated header)");
  const auto format_version = get<std::uint32_t>(buf, 8);
  if (format_version < 1)
    throw Error(what + " has format version 0, which no gipdyn writes: the file is corrupted; re-save the model");
  const auto header_size = get<std::uint64_t>(buf, 16);
  if (format_version > kModelFormatVersion) {
    std::string writer;  // best effort: a newer header may still say who wrote it
    if (header_size <= buf.size() - kPrefix) {
      const json h = json::parse(buf.substr(kPrefix, header_size), nullptr, false);
      if (h.is_object() && h.contains("written_by") && h.at("written_by").is_string())
        writer = ", written by " + h.at("written_by").get<std::string>();
    }
    throw Error(what + " has format version " + std::to_string(format_version) + writer + ", newer than this gipdyn (" +
                std::string(version()) + ") reads (" + std::to_string(kModelFormatVersion) + "); upgrade gipdyn");
  }
  if (header_size > buf.size() - kPrefix) throw Error(what + " is truncated (header cut off); re-save the model");
  ModelContainer c;
  try {
    c.header = json::parse(buf.substr(kPrefix, header_size));
  } catch (const std::exception&) {
    throw Error(what + " is corrupted (unreadable header); re-save the model");
  }
  try {
    std::vector<std::pair<std::string, std::pair<Eigen::Index, Eigen::Index>>> shapes;
    size_t payload = 0;
    for (const json& a : c.header.at("arrays")) {
      const auto rows = a.at("rows").get<Eigen::Index>(), cols = a.at("cols").get<Eigen::Index>();
      if (rows < 0 || cols < 0) throw Error(what + " is corrupted (negative array size); re-save the model");
      shapes.push_back({a.at("name").get<std::string>(), {rows, cols}});
      payload += sizeof(double) * static_cast<size_t>(rows) * static_cast<size_t>(cols);
    }
    const size_t expected = kPrefix + header_size + payload + 8;
    if (buf.size() < expected)
      throw Error(what + " is truncated (" + std::to_string(buf.size()) + " of " + std::to_string(expected) +
                  " bytes); re-save the model");
    if (buf.size() != expected) throw Error(what + " is corrupted (unexpected size); re-save the model");
    if (get<std::uint64_t>(buf, expected - 8) != fnv1a(buf.data(), expected - 8))
      throw Error(what + " is corrupted (checksum mismatch); re-save the model");
    size_t at = kPrefix + header_size;
    for (const auto& [name, shape] : shapes) {
      Eigen::MatrixXd a(shape.first, shape.second);
      std::memcpy(a.data(), buf.data() + at, sizeof(double) * static_cast<size_t>(a.size()));
      at += sizeof(double) * static_cast<size_t>(a.size());
      // A valid checksum over NaN says only that the NaN was written: no model of ours holds one.
      if (!a.allFinite())
        throw Error(what + " holds a non-finite number (NaN or Inf) in its array '" + name +
                    "'; the model is unusable: train it again");
      c.arrays.emplace_back(name, std::move(a));
    }
  } catch (const json::exception& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
  c.header.erase("arrays");
  return c;
}

void write_container(const ModelContainer& container, const std::string& path) {
  if (auto where = non_finite_number(container); !where.empty())
    throw Error("the model to write to '" + path + "' holds a non-finite number (NaN or Inf) in " + where +
                "; nothing was written: train it again");
  const std::string buf = pack_finite_container(container);
  write_file_atomically(path, [&](std::ostream& out) { out.write(buf.data(), static_cast<std::streamsize>(buf.size())); },
                        true);
}

std::string read_model_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open model file '" + path + "': " + std::strerror(errno));
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace gipdyn
