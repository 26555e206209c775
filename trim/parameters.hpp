// Trim parameters: named, bounded changes to the kinematics (amplitudes, means, angles, frequency).
#pragma once
#include <string>
#include <vector>
#include "core/case_file.hpp"

namespace flapstab {

// Applies a vector of parameter values to a copy of the base kinematics. Values are in the
// parameters' units (deg or Hz). Amplitudes scale the base oscillation; means shift it.
class TrimParameterization {
 public:
  TrimParameterization(const Kinematics& base, std::vector<TrimParameterSpec> specs, const std::string& file);
  std::size_t size() const { return specs_.size(); }
  const std::vector<TrimParameterSpec>& specs() const { return specs_; }
  // The parameters' values in the base kinematics.
  const std::vector<double>& initial() const { return initial_; }
  Kinematics apply(const std::vector<double>& values) const;
  // Whether any parameter acts on one wing only.
  bool one_sided() const;
  static std::string unit(const std::string& name);

 private:
  double base_value(const TrimParameterSpec& s) const;
  Kinematics base_;
  std::vector<TrimParameterSpec> specs_;
  std::vector<double> initial_;
};

// Exact peak-to-peak of a periodic series: dense sampling refined by Newton on f'.
double exact_peak_to_peak(const AngleSeries& s);

}  // namespace flapstab
