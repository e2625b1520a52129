// The location errors a pose set cannot determine, named in words (docs/methods.md §17.4): from
// the null space of the column-scaled first-order Jacobian (rotary_identify.h). Errors that share
// a null direction form a group; the errors linked to no other are named together
// ("YOA, ZOA, BOA and COA are not determined by these poses"), a group of
// two with one null direction names the one combination that is determined, e.g.
// "XOC and BOC cannot be separated by these poses: only XOC + 150 mm × BOC is determined" (the
// coefficient of a µrad error beside a µm one is a lever arm: µm per µrad = m). No value is ever
// given for an undetermined error or combination.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/rotary/rotary_types.h"

namespace km::rotary {

struct NullSpaceGroup {
  std::vector<std::size_t> errors;  // indices into LocationErrors
  std::string determined;           // the combination determined; empty when none is
  std::string sentence;
};

// null_basis: 8 × k orthonormal columns in scaled coordinates q = scale ∘ p (p in µm, µrad).
// An error belongs to the null space when its squared share exceeds share_tolerance.
std::vector<NullSpaceGroup> DescribeNullSpace(Kinematics kinematics,
                                              const Eigen::MatrixXd& null_basis,
                                              const Eigen::VectorXd& scale, double share_tolerance);

// "A", "A and B", "A, B and C".
std::string JoinNames(const std::vector<std::string>& names);

}  // namespace km::rotary
