// JSON forms of flapstab's results (trim, derivatives) and the metadata every output file carries.
#pragma once
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include "cfd/derivatives.hpp"
#include "trim/trim.hpp"

namespace flapstab {

// Version, conventions, units and the input's hash: the header of every JSON flapstab writes.
nlohmann::json metadata_json(const Case& c, const std::string& command);
nlohmann::json trim_json(const TrimResult& r);
nlohmann::json derivatives_json(const DerivativeResult& d);
nlohmann::json kinematics_json(const Kinematics& k);
// A matrix as a JSON array of rows.
nlohmann::json matrix_json(const Eigen::MatrixXd& m);
// Wall time since t0 (s).
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
// FNV-1a 64-bit hash of a file's bytes, as 16 hex digits.
std::string file_hash(const std::string& path);

}  // namespace flapstab
