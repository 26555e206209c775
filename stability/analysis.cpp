// Stability of a derivative table: which analyses run, which are skipped, and why.
#include "stability/analysis.hpp"

namespace flapstab {

StabilityReport analyse_stability(const DerivativeTable& t, const StabilityRequest& req) {
  StabilityReport r;
  r.source = t.source;
  r.reference = t.reference;
  r.nondimensional = nondimensional_parameters(t);
  r.six_dof_requested = req.six_dof;

  if (t.has_longitudinal)
    r.longitudinal = analyse_modes(longitudinal_system(t), t.reference, req.modes);
  else
    r.notices.push_back("longitudinal analysis skipped: the table has no [derivatives.longitudinal] section");
  if (t.has_lateral)
    r.lateral = analyse_modes(lateral_system(t), t.reference, req.modes);
  else
    r.notices.push_back("lateral analysis skipped: the table has no [derivatives.lateral] section");

  if (req.six_dof) {
    if (t.has_longitudinal && t.has_lateral)
      r.coupled = analyse_modes(coupled_system(t), t.reference, req.modes);
    else
      r.notices.push_back("6DoF analysis skipped: it needs both [derivatives.longitudinal] and "
                          "[derivatives.lateral]");
  } else if (t.has_coupling) {
    r.notices.push_back("the table has [derivatives.coupling] entries, which only the 6DoF analysis "
                        "uses; request it to include them");
  }
  return r;
}

}  // namespace flapstab
