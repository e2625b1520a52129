#include "analysis/rotary/rotary_separability.h"

#include <cmath>
#include <cstdio>
#include <numeric>

namespace km::rotary {
namespace {

std::string ErrorName(Kinematics k, std::size_t i) {
  return std::string(LocationErrorNames(k)[i]);
}

// Groups of the errors in the null space: i and j together when the projector links them.
std::vector<std::vector<std::size_t>> NullGroups(const Eigen::MatrixXd& projector, double tol) {
  const std::size_t n = kLocationErrorCount;
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  auto root = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i];
    return i;
  };
  auto in_null = [&](std::size_t i) { return projector(i, i) > tol; };
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const bool linked =
          in_null(i) && in_null(j) && std::abs(projector(Eigen::Index(i), Eigen::Index(j))) > tol;
      if (linked) parent[root(j)] = root(i);
    }
  }
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < n; ++i) {
    if (!in_null(i) || root(i) != i) continue;
    std::vector<std::size_t> g;
    for (std::size_t j = 0; j < n; ++j) {
      if (in_null(j) && root(j) == i) g.push_back(j);
    }
    groups.push_back(g);
  }
  return groups;
}

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// first + c × second, the one combination orthogonal to the null direction (physical units).
std::string PairCombination(Kinematics k, std::size_t first, std::size_t second, double c) {
  const std::string sign = c < 0.0 ? " − " : " + ";
  const double m = std::abs(c);
  std::string term;
  if (IsAngularError(first) == IsAngularError(second)) {
    term = std::abs(m - 1.0) < 0.01 ? "" : Number(m) + " × ";
  } else {
    term = Number(m * 1e3) + " mm × ";  // µm per µrad is m
  }
  return ErrorName(k, first) + sign + term + ErrorName(k, second);
}

NullSpaceGroup DescribePair(Kinematics k, std::size_t i, std::size_t j,
                            const Eigen::MatrixXd& projector, const Eigen::VectorXd& scale) {
  // A position error first, so that a mixed coefficient reads as a lever arm in mm.
  if (IsAngularError(i) && !IsAngularError(j)) std::swap(i, j);
  // The null direction within the pair, in physical units: p = q / scale.
  const Eigen::Index col =
      projector(Eigen::Index(i), Eigen::Index(i)) >= projector(Eigen::Index(j), Eigen::Index(j))
          ? Eigen::Index(i)
          : Eigen::Index(j);
  const double ni = projector(Eigen::Index(i), col) / scale(Eigen::Index(i));
  const double nj = projector(Eigen::Index(j), col) / scale(Eigen::Index(j));
  NullSpaceGroup g;
  g.errors = {i, j};
  g.determined = PairCombination(k, i, j, -ni / nj);
  g.sentence = ErrorName(k, i) + " and " + ErrorName(k, j) +
               " cannot be separated by these poses: only " + g.determined + " is determined";
  return g;
}

}  // namespace

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " and " : ", ";
    out += names[i];
  }
  return out;
}

std::vector<NullSpaceGroup> DescribeNullSpace(Kinematics k, const Eigen::MatrixXd& null_basis,
                                              const Eigen::VectorXd& scale,
                                              double share_tolerance) {
  const Eigen::MatrixXd projector = null_basis * null_basis.transpose();
  std::vector<NullSpaceGroup> out;
  NullSpaceGroup alone;  // the errors no pose is moved by, in one sentence
  for (const auto& members : NullGroups(projector, share_tolerance)) {
    if (members.size() == 1) {
      alone.errors.push_back(members[0]);
      continue;
    }
    double dims = 0.0;
    std::vector<std::string> names;
    for (std::size_t i : members) {
      dims += projector(Eigen::Index(i), Eigen::Index(i));
      names.push_back(ErrorName(k, i));
    }
    const auto null_dims = static_cast<std::size_t>(std::lround(dims));
    if (members.size() == 2 && null_dims == 1) {
      out.push_back(DescribePair(k, members[0], members[1], projector, scale));
      continue;
    }
    NullSpaceGroup g;
    g.errors = members;
    if (null_dims >= members.size()) {
      g.sentence = JoinNames(names) + " are not determined by these poses";
    } else {
      const std::size_t known = members.size() - null_dims;
      g.sentence = JoinNames(names) + " cannot be separated by these poses: only " +
                   std::to_string(known) + (known == 1 ? " combination" : " combinations") +
                   " of them " + (known == 1 ? "is" : "are") + " determined";
    }
    out.push_back(g);
  }
  if (!alone.errors.empty()) {
    std::vector<std::string> names;
    for (std::size_t i : alone.errors) names.push_back(ErrorName(k, i));
    alone.sentence = JoinNames(names) + (names.size() == 1 ? " is" : " are") +
                     " not determined by these poses: no pose is moved by " +
                     (names.size() == 1 ? "it" : "them");
    out.insert(out.begin(), alone);
  }
  return out;
}

}  // namespace km::rotary
