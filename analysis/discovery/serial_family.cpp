#include "analysis/discovery/serial_family.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <utility>

#include <Eigen/Cholesky>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/discovery/serial_family_util.h"

namespace km::discovery {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using serial_effects::EffectId;
using util::Format;
using util::IsCyclic;
using util::IsSpike;

constexpr double kBlockDeg = 2.0;       // angle of one block of an interleaved sub-trace
constexpr double kConfoundRatio = 0.1;  // as the engine's and the diagnosis's

// Solves the symmetric system g x = b scaled by its diagonal (a tiny ridge keeps a parameter
// the data do not see at 0).
VectorXd SolveScaled(const MatrixXd& g, const VectorXd& b) {
  if (g.rows() == 0) return VectorXd();
  const VectorXd d = g.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  MatrixXd gs = d.asDiagonal() * g * d.asDiagonal();
  gs.diagonal().array() += 1e-12;
  return d.asDiagonal() * gs.ldlt().solve(d.asDiagonal() * b);
}

MatrixXd InverseScaled(const MatrixXd& g) {
  const int k = static_cast<int>(g.rows());
  MatrixXd inv(k, k);
  for (int j = 0; j < k; ++j) inv.col(j) = SolveScaled(g, VectorXd::Unit(k, j));
  return inv;
}

// Removes from v its components along the orthonormal vectors q (twice, for orthogonality).
void Reduce(const std::vector<VectorXd>& q, VectorXd& v) {
  for (int pass = 0; pass < 2; ++pass)
    for (const auto& qi : q) v -= qi.dot(v) * qi;
}

// Whether every vector of the orthonormal set a keeps less than ratio² of its norm outside the
// span of the orthonormal set b.
bool Within(const std::vector<VectorXd>& a, const std::vector<VectorXd>& b, double ratio) {
  if (a.empty() || b.empty()) return false;
  for (const auto& q : a) {
    VectorXd v = q;
    Reduce(b, v);
    if (v.squaredNorm() >= ratio * ratio) return false;
  }
  return true;
}

}  // namespace

void SerialFamilyOptions::Check() const {
  internal::CheckOption(!spike_widths_deg.empty(), "spike_widths_deg", "must not be empty");
  for (double w : spike_widths_deg)
    internal::CheckOption(w > 0.0, "spike_widths_deg", "must be > 0");
  KM_OPTION_GT(cyclic_min_period_mm, 0.0);
  KM_OPTION_GT(cyclic_max_period_fraction, 0.0);
  KM_OPTION_GE(sample_folds, 2);
  KM_OPTION_GE(resolution_um, 0.0);
}

SerialFamily::SerialFamily(const std::vector<dbb::DiagnosisTrace>& traces,
                           const std::vector<std::string>& test_ids, dbb::Plane plane,
                           SerialFamilyOptions options)
    : plane_(plane), opt_(std::move(options)), traces_(traces), test_ids_(test_ids) {
  opt_.Check();
  if (traces.empty()) throw InvalidInput("", 0, "tests", "no trace to discover from");
  if (test_ids.size() != traces.size())
    throw InvalidInput("", 0, "test_id", "one test id per trace is needed");
  rmin_mm_ = std::numeric_limits<double>::infinity();
  for (const auto& tr : traces) {
    rmin_mm_ = std::min(rmin_mm_, tr.radius_mm);
    for (std::size_t i = 1; i < tr.angle_rad.size(); ++i)
      max_step_rad_ = std::max(max_step_rad_, std::abs(tr.angle_rad[i] - tr.angle_rad[i - 1]));
  }
  // Fold keys: the test id. When no test id holds both directions although both are present
  // (one id per file), cw and ccw of equal radius and feed are taken as one test.
  std::vector<std::string> key_names = test_ids;
  {
    std::map<std::string, int> dirs;  // bit 1 ccw, bit 2 cw
    int all = 0;
    for (std::size_t t = 0; t < traces.size(); ++t) {
      const int bit = traces[t].direction == dbb::Direction::kCcw ? 1 : 2;
      dirs[test_ids[t]] |= bit;
      all |= bit;
    }
    const bool paired =
        std::any_of(dirs.begin(), dirs.end(), [](const auto& d) { return d.second == 3; });
    if (all == 3 && !paired) {
      for (std::size_t t = 0; t < traces.size(); ++t)
        key_names[t] = Format("%.6g", traces[t].radius_mm) + " mm, " +
                       Format("%.6g", traces[t].feed_mm_min) + " mm/min";
    }
  }
  test_ids_ = key_names;
  std::map<std::string, int> ids;
  for (const auto& id : key_names) ids.emplace(id, static_cast<int>(ids.size()));
  // One test id: interleaved sub-traces (blocks of kBlockDeg dealt to sample_folds groups), if
  // every sub-trace keeps enough samples around the circle.
  const int k = opt_.sample_folds;
  std::vector<dbb::DiagnosisTrace> groups;
  if (ids.size() < 2) {
    split_ = true;
    for (const auto& tr : traces) {
      const double step = tr.angle_rad.size() > 1
                              ? std::abs(tr.angle_rad.back() - tr.angle_rad.front()) /
                                    static_cast<double>(tr.angle_rad.size() - 1)
                              : 1.0;
      const auto block = static_cast<std::size_t>(
          std::max(1.0, std::round(kBlockDeg * kDeg / std::max(step, 1e-12))));
      if (tr.angle_rad.size() < block * static_cast<std::size_t>(k) * 8 ||
          tr.angle_rad.size() < static_cast<std::size_t>(16 * k)) {
        split_ = false;
        break;
      }
    }
  }
  if (split_) {
    for (std::size_t t = 0; t < traces.size(); ++t) {
      const auto& tr = traces[t];
      const double step = std::abs(tr.angle_rad.back() - tr.angle_rad.front()) /
                          static_cast<double>(tr.angle_rad.size() - 1);
      const auto block = static_cast<std::size_t>(
          std::max(1.0, std::round(kBlockDeg * kDeg / std::max(step, 1e-12))));
      for (int j = 0; j < k; ++j) {
        dbb::DiagnosisTrace g = tr;
        g.angle_rad.clear();
        g.dev_um.clear();
        for (std::size_t i = 0; i < tr.angle_rad.size(); ++i) {
          if (static_cast<int>((i / block) % static_cast<std::size_t>(k)) != j) continue;
          g.angle_rad.push_back(tr.angle_rad[i]);
          g.dev_um.push_back(tr.dev_um[i]);
        }
        groups.push_back(std::move(g));
        trace_of_group_.push_back(static_cast<int>(t));
        fold_key_.push_back(j);
      }
    }
  } else {
    groups = traces;
    for (std::size_t t = 0; t < traces.size(); ++t) {
      trace_of_group_.push_back(static_cast<int>(t));
      fold_key_.push_back(ids.at(key_names[t]));
    }
  }
  groups_ = OffReversals(std::move(groups));
  p_ = dbb::StackTraces(groups_);
  e0_ = p_.y;
  p_.RemoveSetup(e0_, &setup_y_);
  // The signatures are first order in e/R: below the second-order term of the bar length
  // |e_t|²/(2R) a "gap" is geometry, not an effect. |e| ≤ the largest set-up-free deviation
  // plus the largest centre offset of a trace.
  double centre = 0.0;
  for (const auto& c : setup_y_) centre = std::max(centre, std::hypot(c[0], c[1]));
  const double e = (e0_.size() ? e0_.cwiseAbs().maxCoeff() : 0.0) + centre;
  resolution_um_ = std::max(opt_.resolution_um, e * e / (2.0 * rmin_mm_ * 1000.0));
}

std::string SerialFamily::Name(EffectId id) const {
  const auto [a, b] = dbb::AxisLetters(plane_);
  return serial_effects::EffectName(id, a, b);
}

// Least squares of e0 on the terms' columns with the physical lower bounds (active set: a
// bounded value below its bound is held at the bound; held values whose gradient points back
// inside are released).
SerialFamily::Bounded SerialFamily::FitTo(const VectorXd& e0,
                                          const std::vector<const Term*>& terms) const {
  std::vector<const VectorXd*> cols;
  std::vector<double> lower;
  for (const Term* t : terms) {
    for (std::size_t j = 0; j < t->sig.cols.size(); ++j) {
      cols.push_back(&t->sig.cols[j]);
      lower.push_back(LowerBound(t->sig.id, static_cast<int>(j)));
    }
  }
  const int k = static_cast<int>(cols.size());
  MatrixXd g(k, k);
  VectorXd b(k);
  for (int i = 0; i < k; ++i) {
    b[i] = cols[static_cast<std::size_t>(i)]->dot(e0);
    for (int j = 0; j <= i; ++j)
      g(i, j) = g(j, i) =
          cols[static_cast<std::size_t>(i)]->dot(*cols[static_cast<std::size_t>(j)]);
  }
  Bounded out;
  out.x = VectorXd::Zero(k);
  out.at_bound.assign(static_cast<std::size_t>(k), false);
  for (int iter = 0; iter < 4 * k + 4; ++iter) {
    std::vector<int> free;
    for (int j = 0; j < k; ++j)
      if (!out.at_bound[static_cast<std::size_t>(j)]) free.push_back(j);
    const int f = static_cast<int>(free.size());
    MatrixXd gf(f, f);
    VectorXd bf(f);
    for (int i = 0; i < f; ++i) {
      bf[i] = b[free[i]];
      for (int j = 0; j < f; ++j) gf(i, j) = g(free[i], free[j]);
    }
    const VectorXd xf = SolveScaled(gf, bf);
    out.x.setZero();
    for (int j = 0; j < k; ++j)
      if (out.at_bound[static_cast<std::size_t>(j)]) out.x[j] = lower[static_cast<std::size_t>(j)];
    for (int i = 0; i < f; ++i) out.x[free[i]] = xf[i];
    // The worst violation (in units of the column's norm) is held at its bound.
    int worst = -1;
    double wv = 0.0;
    for (int j : free) {
      const double v = (lower[static_cast<std::size_t>(j)] - out.x[j]) * std::sqrt(g(j, j));
      if (v > wv) {
        wv = v;
        worst = j;
      }
    }
    if (worst >= 0) {
      out.at_bound[static_cast<std::size_t>(worst)] = true;
      continue;
    }
    // Release a held value whose gradient points inside the bound.
    const VectorXd grad = b - g * out.x;  // = Aᵀ(e0 − A x)
    int release = -1;
    double rv = 0.0;
    for (int j = 0; j < k; ++j) {
      if (!out.at_bound[static_cast<std::size_t>(j)]) continue;
      const double v = grad[j] / std::sqrt(std::max(g(j, j), 1e-300));
      if (v > rv * (1.0 + 1e-9) && v > 1e-9 * e0.norm()) {
        rv = v;
        release = j;
      }
    }
    if (release < 0) break;
    out.at_bound[static_cast<std::size_t>(release)] = false;
  }
  out.residual = e0;
  for (int j = 0; j < k; ++j) out.residual -= out.x[j] * *cols[static_cast<std::size_t>(j)];
  out.rss = out.residual.squaredNorm();
  return out;
}

SerialModel SerialFamily::MakeModel(const std::vector<Term>& terms, const Bounded& fit) const {
  SerialModel m;
  int k = 0;
  for (const auto& t : terms) k += static_cast<int>(t.sig.cols.size());
  int nfree = 0;
  for (bool a : fit.at_bound) nfree += a ? 0 : 1;
  m.dof = std::max(1, p_.n - 3 * p_.traces - nfree - (delay_ms_ > 0.0 ? 1 : 0));
  m.rss_um2 = fit.rss;
  m.residual = -fit.residual;
  const double sigma2 = fit.rss / m.dof;
  // Covariance of the free values; a held value gets the σ it would have if freed.
  std::vector<const VectorXd*> cols;
  for (const auto& t : terms)
    for (const auto& c : t.sig.cols) cols.push_back(&c);
  MatrixXd g(k, k);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j <= i; ++j)
      g(i, j) = g(j, i) =
          cols[static_cast<std::size_t>(i)]->dot(*cols[static_cast<std::size_t>(j)]);
  std::vector<int> free;
  for (int j = 0; j < k; ++j)
    if (!fit.at_bound[static_cast<std::size_t>(j)]) free.push_back(j);
  MatrixXd gf(free.size(), free.size());
  for (std::size_t i = 0; i < free.size(); ++i)
    for (std::size_t j = 0; j < free.size(); ++j) gf(i, j) = g(free[i], free[j]);
  const MatrixXd gf_inv = InverseScaled(gf);
  MatrixXd cov = MatrixXd::Zero(k, k);
  for (std::size_t i = 0; i < free.size(); ++i)
    for (std::size_t j = 0; j < free.size(); ++j)
      cov(free[i], free[j]) = sigma2 * gf_inv(static_cast<int>(i), static_cast<int>(j));
  for (int j = 0; j < k; ++j) {
    if (!fit.at_bound[static_cast<std::size_t>(j)]) continue;
    VectorXd gj(free.size());
    for (std::size_t i = 0; i < free.size(); ++i) gj[static_cast<int>(i)] = g(free[i], j);
    const double left = g(j, j) - (free.empty() ? 0.0 : gj.dot(gf_inv * gj));
    cov(j, j) = left > 0.0 ? sigma2 / left : 0.0;
  }
  // Effects: values, uncertainties by propagation through the registry's value jacobian.
  int off = 0;
  const auto& ctx = p_.ctx[0];
  for (const auto& t : terms) {
    const auto& info = serial_effects::Info(t.sig.id);
    const int nl = info.num_linear;
    SerialEffectFit e;
    e.id = t.sig.id;
    e.name = Name(t.sig.id);
    e.shape = t.sig.shape;
    e.unit = info.unit;
    std::vector<double> params(static_cast<std::size_t>(info.num_params), 0.0);
    for (int j = 0; j < nl; ++j) {
      params[static_cast<std::size_t>(j)] = fit.x[off + j];
      e.linear.push_back(fit.x[off + j]);
      e.linear_sigma.push_back(std::sqrt(std::max(0.0, cov(off + j, off + j))));
      e.at_bound = e.at_bound || fit.at_bound[static_cast<std::size_t>(off + j)];
    }
    for (std::size_t s = 0; s < t.sig.shape.size(); ++s) {
      params[static_cast<std::size_t>(nl) + s] = t.sig.shape[s];
      e.shape_map[info.param_names[static_cast<std::size_t>(nl) + s]] = t.sig.shape[s];
    }
    for (int j = 0; j < info.num_params; ++j)
      e.parameters[info.param_names[static_cast<std::size_t>(j)]] =
          params[static_cast<std::size_t>(j)];
    e.value = serial_effects::Value(t.sig.id, ctx, params.data());
    const MatrixXd jac = serial_effects::ValueJacobian(t.sig.id, ctx, params.data()).leftCols(nl);
    const MatrixXd cv = jac * cov.block(off, off, nl, nl) * jac.transpose();
    double vnorm = 0.0, snorm = 0.0;
    for (std::size_t v = 0; v < e.value.size(); ++v) {
      const auto vi = static_cast<Eigen::Index>(v);
      const double s = std::sqrt(std::max(0.0, cv(vi, vi)));
      e.sigma.push_back(s);
      vnorm += e.value[v] * e.value[v];
      snorm += s * s;
    }
    e.z_score = snorm > 0.0 ? std::sqrt(vnorm / (snorm / static_cast<double>(e.value.size())))
                            : (vnorm > 0.0 ? 1e9 : 0.0);
    e.z_score = std::min(e.z_score, 1e9);
    m.effects.push_back(std::move(e));
    off += nl;
  }
  if (delay_ms_ > 0.0) AddDelayEffect(m, sigma2);
  // Set-up terms net of the effects' own centre and radius parts, averaged over the groups.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), var = Eigen::Vector3d::Zero();
  for (int gi = 0; gi < p_.traces; ++gi) {
    Eigen::Vector3d s = setup_y_[static_cast<std::size_t>(gi)];
    int c = 0;
    for (const auto& t : terms)
      for (std::size_t j = 0; j < t.sig.cols.size(); ++j, ++c)
        s -= fit.x[c] * t.sig.setup_part[j][static_cast<std::size_t>(gi)];
    mean += s;
    var += sigma2 * p_.setup_inv[static_cast<std::size_t>(gi)].diagonal();
  }
  const double tt = p_.traces;
  mean /= tt;
  var /= tt * tt;
  m.centre_um[0] = mean[0];
  m.centre_um[1] = mean[1];
  m.radius_um = mean[2];
  m.centre_sigma_um[0] = std::sqrt(var[0]);
  m.centre_sigma_um[1] = std::sqrt(var[1]);
  m.radius_sigma_um = std::sqrt(var[2]);
  return m;
}

FitState SerialFamily::StateOf(const std::vector<Term>& terms, const SerialModel& m) const {
  FitState s;
  s.residual = m.residual;
  int k = 0;
  for (const auto& t : terms) k += static_cast<int>(t.sig.cols.size());
  s.jacobian = MatrixXd::Zero(p_.n, 3 * p_.traces + k);
  for (int g = 0; g < p_.traces; ++g) {
    for (std::size_t i = p_.begin[static_cast<std::size_t>(g)];
         i < p_.begin[static_cast<std::size_t>(g) + 1]; ++i) {
      const auto& a = p_.samples[i].a;
      const auto r = static_cast<Eigen::Index>(i);
      s.jacobian(r, 3 * g) = a.c;
      s.jacobian(r, 3 * g + 1) = a.s;
      s.jacobian(r, 3 * g + 2) = 1.0;
    }
    for (int c = 0; c < 3; ++c) s.column_group.push_back(g);
  }
  int c = 3 * p_.traces;
  for (const auto& t : terms) {
    for (const auto& col : t.sig.cols) {
      s.jacobian.col(c++) = col;
      s.column_group.push_back(-1);
    }
    s.in_model.push_back(Name(t.sig.id));
  }
  if (delay_ms_ > 0.0 && delay_col_.size() == p_.n) {
    s.jacobian.conservativeResize(Eigen::NoChange, s.jacobian.cols() + 1);
    s.jacobian.col(s.jacobian.cols() - 1) = delay_col_;
    s.column_group.push_back(-1);
    s.in_model.push_back(Name(EffectId::kServoLag));
  }
  for (std::size_t b : p_.begin) s.row_begin.push_back(static_cast<int>(b));
  return s;
}

FitState SerialFamily::FitBase() {
  model_.clear();
  history_.clear();
  notes_.clear();
  if (delay_ms_ != 0.0) Restack(0.0);
  delay_col_.resize(0);
  history_.push_back(MakeModel(model_, Fit({})));
  return StateOf(model_, history_.back());
}

std::vector<Candidate> SerialFamily::Candidates(const FitState& fit) {
  pending_.clear();
  const VectorXd gap = -fit.residual;
  auto in_model = [&](EffectId id) {
    return std::any_of(model_.begin(), model_.end(), [&](const Term& t) { return t.sig.id == id; });
  };
  const double pmin =
      std::max(opt_.cyclic_min_period_mm, 4.0 * rmin_mm_ * std::max(max_step_rad_, 1e-9));
  const double pmax = opt_.cyclic_max_period_fraction * rmin_mm_;
  const int step = static_cast<int>(model_.size()) + 1;
  auto withheld = [&](EffectId id) {
    return std::any_of(opt_.withheld.begin(), opt_.withheld.end(),
                       [&](const auto& w) { return w.first == step && w.second == Name(id); });
  };
  int order = 0;
  for (const auto& info : serial_effects::AllEffects()) {
    ++order;
    if (!info.in_form || !info.linear_fit || in_model(info.id) || withheld(info.id)) continue;
    if (IsSpike(info.id)) {
      for (double w : opt_.spike_widths_deg)
        pending_.push_back(Term{dbb::SetupFreeSignature(p_, info.id, {w}), order});
    } else if (IsCyclic(info.id)) {
      if (!opt_.search_cyclic || !(pmax > pmin)) continue;
      const int axis = info.id == EffectId::kCyclicErrorU ? 0 : 1;
      double period = dbb::CyclicPeriodPeak(p_, gap, axis, pmin, pmax);
      if (!(period > 0.0)) continue;
      const double bin_rel = period * dbb::kCyclicBins / (dbb::kCyclicFft * rmin_mm_);
      period = dbb::RefinePeriod(p_, gap, axis, period, std::min(0.2, bin_rel),
                                 rmin_mm_ * std::max(max_step_rad_, 1e-9));
      pending_.push_back(Term{dbb::SetupFreeSignature(p_, info.id, {period}), order});
    } else {
      pending_.push_back(Term{dbb::SetupFreeSignature(p_, info.id, {}), order});
    }
  }
  // Of two candidates the data cannot tell apart given the model (each one's projected
  // signature lies within the other's span up to the confound ratio, e.g. servo_mismatch and
  // squareness on traces of one direction), the earlier in the registry list is offered; the
  // other is named in the evidence, never claimed.
  {
    std::vector<VectorXd> basis;
    for (const auto& m : model_) {
      for (const auto& col : m.sig.cols) {
        VectorXd v = col;
        Reduce(basis, v);
        if (v.norm() > 1e-9 * col.norm() && v.norm() > 0.0) basis.push_back(v / v.norm());
      }
    }
    std::vector<std::vector<VectorXd>> q(pending_.size());
    for (std::size_t k = 0; k < pending_.size(); ++k) {
      for (const auto& col : pending_[k].sig.cols) {
        VectorXd v = col;
        Reduce(basis, v);
        Reduce(q[k], v);
        if (v.norm() > 1e-9 * col.norm() && v.norm() > 0.0) q[k].push_back(v / v.norm());
      }
    }
    confused_.clear();
    std::vector<Term> kept;
    for (std::size_t k = 0; k < pending_.size(); ++k) {
      bool drop = false;
      for (std::size_t i = 0; i < k && !drop; ++i) {
        if (pending_[i].sig.id == pending_[k].sig.id || pending_[i].order >= pending_[k].order)
          continue;
        if (Within(q[k], q[i], kConfoundRatio) && Within(q[i], q[k], kConfoundRatio)) {
          auto& names = confused_[Name(pending_[i].sig.id)];
          const std::string n = Name(pending_[k].sig.id);
          if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
          drop = true;
        }
      }
      if (!drop) kept.push_back(std::move(pending_[k]));
    }
    pending_ = std::move(kept);
  }
  std::vector<Candidate> out;
  for (const auto& t : pending_) {
    const auto& info = serial_effects::Info(t.sig.id);
    Candidate c;
    c.effect = Name(t.sig.id);
    c.variant = VariantOf(t.sig);
    c.priority = t.order;
    c.columns.resize(p_.n, static_cast<Eigen::Index>(t.sig.cols.size()));
    for (std::size_t j = 0; j < t.sig.cols.size(); ++j) {
      c.columns.col(static_cast<Eigen::Index>(j)) = t.sig.cols[j];
      c.parameter_names.push_back(info.param_names[j]);
    }
    out.push_back(std::move(c));
  }
  for (auto& c : DelayCandidate(step)) out.push_back(std::move(c));
  return out;
}

const SerialFamily::Term* SerialFamily::Find(const Candidate& c) const {
  for (const auto& t : pending_)
    if (Name(t.sig.id) == c.effect && VariantOf(t.sig) == c.variant) return &t;
  return nullptr;
}

bool SerialFamily::Physical(const Candidate& c, const VectorXd& x, std::string* why) {
  if (IsDelay(c)) {
    if (x.size() == 1 && x[0] >= 0.0 && x[0] <= kMaxDelayMs) return true;
    *why = "delay_ms = " + Format("%.4g", x.size() ? x[0] : 0.0) +
           (x.size() && x[0] < 0.0 ? " < 0 (the axes would run ahead of their command)"
                                   : " > " + Format("%g", kMaxDelayMs));
    return false;
  }
  const Term* t = Find(c);
  if (!t) return false;
  const auto& info = serial_effects::Info(t->sig.id);
  for (int j = 0; j < static_cast<int>(x.size()); ++j) {
    if (x[j] < LowerBound(t->sig.id, j)) {
      *why = info.param_names[static_cast<std::size_t>(j)] + " = " + Format("%.4g", x[j]) + " < " +
             Format("%g", LowerBound(t->sig.id, j));
      return false;
    }
  }
  // The joint fit with the candidate must keep the model's bounded values inside their bounds
  // (an effect bought by pushing another beyond physics is not an explanation).
  std::vector<const Term*> terms;
  for (const auto& m : model_) terms.push_back(&m);
  terms.push_back(t);
  std::vector<const VectorXd*> cols;
  for (const Term* m : terms)
    for (const auto& col : m->sig.cols) cols.push_back(&col);
  const int k = static_cast<int>(cols.size());
  MatrixXd g(k, k);
  VectorXd b(k);
  for (int i = 0; i < k; ++i) {
    b[i] = cols[static_cast<std::size_t>(i)]->dot(e0_);
    for (int j = 0; j <= i; ++j)
      g(i, j) = g(j, i) =
          cols[static_cast<std::size_t>(i)]->dot(*cols[static_cast<std::size_t>(j)]);
  }
  const VectorXd xj = SolveScaled(g, b);
  const SerialModel& now = history_.back();
  int off = 0;
  for (std::size_t mi = 0; mi < model_.size(); ++mi) {
    const auto& m = model_[mi];
    for (int j = 0; j < static_cast<int>(m.sig.cols.size()); ++j) {
      const double lb = LowerBound(m.sig.id, j);
      if (!now.effects[mi].at_bound && xj[off + j] < lb) {
        *why = "it would make " + Name(m.sig.id) + " " +
               serial_effects::Info(m.sig.id).param_names[static_cast<std::size_t>(j)] + " = " +
               Format("%.4g", xj[off + j]) + " < " + Format("%g", lb);
        return false;
      }
    }
    off += static_cast<int>(m.sig.cols.size());
  }
  return true;
}

FitState SerialFamily::Accept(const Candidate& c, const VectorXd& x) {
  if (IsDelay(c)) {
    const double est = std::clamp(x.size() ? x[0] : delay_offered_ms_, 0.1, kMaxDelayMs);
    RefineDelay(est / 2.0, std::min(2.0 * est, kMaxDelayMs));
    RefineShapes(model_, 0);
  } else {
    const Term* t = Find(c);
    if (!t) throw DidNotConverge("discovery: unknown candidate " + c.effect);
    model_.push_back(*t);
    RefineShapes(model_, model_.size() - 1);
    if (delay_ms_ > 0.0) RefineDelay(delay_ms_ / 1.5, std::min(1.5 * delay_ms_, kMaxDelayMs));
  }
  FinishStep();
  return StateOf(model_, history_.back());
}

std::vector<int> SerialFamily::FoldKeys() const {
  return fold_key_;
}

}  // namespace km::discovery
