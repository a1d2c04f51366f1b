// Housner's piecewise model (physical time):
//   theta'' = -p_s^2 [ sin(alpha_s s - theta) + (u_g''/g) cos(alpha_s s - theta) ],
// s = +1 while the block pivots on its +x corner (theta > 0), -1 otherwise;
// alpha_s, p_s those of that pivot (BlockParams::Side; the same for a
// symmetric block). Impact at theta = 0: theta_dot <- mu_new theta_dot with
// mu_new the restitution of the pivot it lands on (the pair old -> new),
// s flips, CVODE restarts.

#include <cmath>

#include "model/numbers.h"

#include "model/rocking_impl.h"

namespace rocklab::model::detail {
namespace {

class HousnerModel final : public CvodeRockingModel {
 public:
  HousnerModel(const BlockParams& params, const ModelOptions& options)
      : CvodeRockingModel(params, options) {
    const double atol[2] = {options.atol, options.atol};
    Init(2, atol);
  }
  ModelKind kind() const override { return ModelKind::kHousner; }

 protected:
  void RockingRhs(double t_s, const double* y, double* ydot) override {
    const double ug = table_accel(t_s);
    const double phi = sp_.alpha * side_ - y[0];
    ydot[0] = y[1];
    ydot[1] = -sp_.p * sp_.p * (std::sin(phi) + ug / kGravity * std::cos(phi));
  }
  void RockingRoots(const double* y, double* g) const override {
    // The impact root is theta shifted by kHousnerImpactSlackRad towards the
    // side the block rocks on, so it is never zero where rocking starts (theta =
    // 0 at an uplift from rest or after an impact). A root that is zero at
    // the initial point takes its sign from CVODE's first step: when the
    // table acceleration only touches g tan(alpha), the block moves off
    // towards the other side at once, that sign is already the wrong one, and
    // the crossing back through 0 is never seen (the block then drifted past
    // pi/2 with no impact and no overturn). Shifted, that motion crosses the
    // root and lands the block. The impact is found 1e-14 rad past theta = 0:
    // 1e-14 / |theta_dot| s late, below the root finder's own resolution
    // for any rocking worth the name.
    g[0] = y[0] + side_ * kHousnerImpactSlackRad;
    g[1] = side_ * y[0] - kPi / 2;
    g[2] = 1.0;  // no switch
  }
  int ImpactRootDirection() const override { return side_ > 0 ? -1 : +1; }
  void InitialState(double theta0, double theta_dot0, int side, double* y) override {
    side_ = side;
    sp_ = params_.Side(side_);
    y[0] = theta0;
    y[1] = theta_dot0;
  }
  bool ApplyImpact(double* y) override {
    y[0] = 0.0;
    side_ = -side_;
    sp_ = params_.Side(side_);
    y[1] *= sp_.mu;
    return true;
  }
  void FillState(const double* y) override {
    state_.theta = y[0];
    state_.theta_dot = y[1];
    state_.chi = std::abs(y[0]) / sp_.alpha;
    state_.psi = side_ > 0 ? 0.0 : kPi;
    state_.equations = Equations::kHousner;
  }
  Equations RestEquations() const override { return Equations::kHousner; }

 private:
  int side_{+1};
  SideParams sp_{params_.Side(+1)};  // of the pivot it rocks on
};

}  // namespace

std::unique_ptr<RockingModel> MakeHousner(const BlockParams& params, const ModelOptions& options) {
  return std::make_unique<HousnerModel>(params, options);
}

}  // namespace rocklab::model::detail
