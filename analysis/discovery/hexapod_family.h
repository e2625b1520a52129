// The hexapod model family of the discovery engine: base model = the 24 kinematic parameters
// (analysis/hexapod/calibration.h), candidates = the hexapod effects of
// analysis/hexapod/effects/effect_list.h, each step refitted jointly with the kinematics
// (analysis/hexapod/effect_fit.h).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "analysis/discovery/engine.h"
#include "analysis/discovery/hexapod_gap.h"
#include "analysis/hexapod/effect_fit.h"

namespace km::discovery {

// The engine options of a hexapod discovery: test-level inference on (the samples of a DBB test
// are correlated).
EngineOptions HexapodEngineOptions();

class HexapodFamily final : public ModelFamily {
 public:
  // `known`: effects the machine's stored model already has (kept in every fit, fitted again).
  HexapodFamily(const hexapod::EffectFitData& data, std::vector<hexapod::ActiveEffect> known);

  FitState FitBase() override;
  std::vector<Candidate> Candidates(const FitState& fit) override;
  bool Physical(const Candidate& c, const Eigen::VectorXd& x, std::string* why) override;
  FitState Accept(const Candidate& c, const Eigen::VectorXd& x) override;
  Evidence Describe(const FitState& before, const Candidate& c,
                    const Eigen::VectorXd& contribution) override;
  std::vector<int> FoldKeys() const override;
  double RepeatabilityFloor(const FitState& fit) const override;
  Evidence DescribeGap(const FitState& fit) const override;

  // The fitted model after the base fit (index 0) and after every accepted step.
  const std::vector<hexapod::EffectFitResult>& History() const { return history_; }
  const hexapod::EffectFitData& Data() const { return data_; }

 private:
  // A candidate at its starting values p0 (the engine's estimate is p − p0).
  struct Pending {
    std::string key;
    hexapod::ActiveEffect effect;
    std::vector<int> free;  // indices into effect.params that are columns
  };
  const Pending* Find(const Candidate& c) const;
  FitState StateOf(const hexapod::EffectFitResult& r) const;
  void AddToolFigures(const Eigen::VectorXd& gap, std::map<std::string, double>& figures) const;

  const hexapod::EffectFitData& data_;
  PairedRows pairs_;
  std::vector<hexapod::ActiveEffect> known_;
  std::vector<hexapod::EffectFitResult> history_;
  std::vector<Pending> pending_;
};

}  // namespace km::discovery
