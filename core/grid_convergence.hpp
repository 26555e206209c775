// Discretisation error of a computed quantity from its values on two or three grids: Richardson extrapolation and
// the grid-convergence index (GCI).
//
// Three grids (h1 < h2 < h3, values f1 f2 f3): the procedure of Celik, Ghia, Roache, Freitas, Coleman & Raad 2008,
// "Procedure for estimation and reporting of uncertainty due to discretization in CFD applications", J Fluids Eng
// 130:078001. With r21 = h2/h1, r32 = h3/h2, e21 = f2 - f1, e32 = f3 - f2 and s = sign(e32/e21), the apparent
// order p solves
//     p = | ln|e32/e21| + ln((r21^p - s) / (r32^p - s)) | / ln r21
// (fixed-point iteration from the r21 = r32 solution); the extrapolated value is f_ext = (r21^p f1 - f2) /
// (r21^p - 1), the relative errors e_a = |(f1 - f2)/f1| and e_ext = |(f_ext - f1)/f_ext|, and the fine-grid index
// GCI = 1.25 e_a / (r21^p - 1). s < 0 (the differences change sign) is oscillatory convergence and an order
// p <= 0 (the differences grow as the grid is refined) divergence: both are reported as such, with the two-grid
// index of the finest pair below as the estimate.
//
// Two grids: the order cannot be measured; the index uses an assumed order p and Roache's safety factor 3
// (Roache 1994, J Fluids Eng 116:405): GCI = 3 |e21 / f1| / (r21^p - 1), and the extrapolated value uses the
// same p.
#pragma once
#include <string>
#include <vector>

namespace flapstab {

struct GridValue {
  double h = 0;      // representative spacing (any unit, the same for all grids)
  double value = 0;
};

struct GridConvergence {
  enum class Kind { monotone, oscillatory, diverging, two_grids, unchanged };
  Kind kind = Kind::unchanged;
  double order = 0;            // the apparent order (three grids), or the assumed one (two grids)
  bool order_assumed = false;
  double extrapolated = 0;     // Richardson extrapolation to h = 0 (the finest value where it is not defined)
  double relative_error = 0;   // e_a: |f1 - f2| / |f1|
  double extrapolated_error = 0;  // e_ext: |f_ext - f1| / |f_ext|
  double gci_fine = 0;         // relative (a fraction of |f1|)
  double finest = 0;           // f1
  double safety_factor = 1.25;
  std::string note;            // why the estimate is not a plain monotone Richardson one
};

// The grids in any order (sorted by h here); two or three of them with distinct h. assumed_order is used with
// two grids and as the fallback where three grids give no order.
GridConvergence grid_convergence(std::vector<GridValue> grids, double assumed_order = 1.0);

const char* to_string(GridConvergence::Kind k);

}  // namespace flapstab
