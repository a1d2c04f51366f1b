#include "model/dop853.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "model/cvode.h"

namespace rocklab::model::detail {
namespace {

// Dormand and Prince's 8(5,3) pair and its order-7 dense output, the
// published coefficients (Hairer, Norsett & Wanner, Solving ODEs I, 2nd
// ed., II.10; the values of Hairer's DOP853 code) rounded to doubles.
// Stage 12 is f at the step's end (first same as last); stages 13-15 serve
// the dense output only.
constexpr double kDopC[16] = {0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726, 0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0, 1.0, 0.1, 0.2, 0.7777777777777778};
// Row i: the weights of stages 0 .. i-1 for stage i (row 12: the step's solution).
constexpr double kDopA[16][15] = {
    {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.05260015195876773, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.0197250569845379, 0.0591751709536137, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.02958758547680685, 0.0, 0.08876275643042054, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402, 0.008273789163814023, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671, 20.154067550477894, -43.48988418106996, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193, 15.279233632882423, -33.28821096898486, -0.020331201708508627, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927, -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196, 0.0, 0.0, 0.0, 0.0, 0.0},
    {2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996, -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636, 0.0, 0.0, 0.0, 0.0},
    {0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259, 0.0, 0.0, 0.0},
    {0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637, 0.15329179827876568, 0.00820105229563469, 0.007567897660545699, -0.008298, 0.0, 0.0},
    {0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566, -0.05492374857139099, 0.0, 0.0, -0.00010834732869724932, 0.0003825710908356584, -0.00034046500868740456, 0.1413124436746325, 0.0},
    {-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599, 4.06898981839711, 0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145, 2.9475147891527724, -9.15095847217987},
};
// The error estimators of order 5 and 3 (weights of stages 0 .. 11).
constexpr double kDopE5[12] = {0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502, 1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294};
constexpr double kDopE3[12] = {-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082};
// The dense output's four higher coefficients (weights of stages 0 .. 15).
constexpr double kDopD[4][16] = {
    {-8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917, 2.38466765651207, 2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688, -0.08899033645133331, 18.148505520854727, -9.194632392478356, -4.436036387594894},
    {10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028, -374.5467547226902, -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229, 15.697238121770845, -31.139403219565178, -9.35292435884448, 35.81684148639408},
    {19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758, 527.8081592054236, -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443, -2.778205752353508, -60.19669523126412, 84.32040550667716, 11.99229113618279},
    {-25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455, 357.6391179106141, 93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605, -43.53345659001114, 96.32455395918828, -39.17726167561544, -149.72683625798564},
};

// Dormand and Prince's 5(4) pair (the published fractions, ibid. II.5,
// Table 5.2): stages 0-5, stage 6 f at the step's end (c = 1, first same as
// last), the error weights b - b^ of stages 0-6, and Shampine's dense
// output of order 4 (the values of Hairer's DOPRI5 code), its fifth
// coefficient's weights of stages 0-6.
constexpr double kDp5C[7] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0, 1.0};
constexpr double kDp5A[7][6] = {
    {0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {1.0 / 5, 0.0, 0.0, 0.0, 0.0, 0.0},
    {3.0 / 40, 9.0 / 40, 0.0, 0.0, 0.0, 0.0},
    {44.0 / 45, -56.0 / 15, 32.0 / 9, 0.0, 0.0, 0.0},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0.0, 0.0},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656, 0.0},
    {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84},
};
constexpr double kDp5E[7] = {71.0 / 57600, 0.0, -71.0 / 16695, 71.0 / 1920, -17253.0 / 339200, 22.0 / 525, -1.0 / 40};
constexpr double kDp5D[7] = {-12715105075.0 / 11282082432, 0.0, 87487479700.0 / 32700410799,
                             -10690763975.0 / 1880347072, 701980252875.0 / 199316789632,
                             -1453857185.0 / 822651844, 69997945.0 / 29380423};

// The step-size control both pairs share (Hairer's codes' constants).
constexpr double kErkSafety = 0.9;
constexpr double kErkMinFactor = 0.2;  // smallest step ratio after a rejection
constexpr double kErkEps = std::numeric_limits<double>::epsilon();

}  // namespace

EmbeddedRungeKutta::EmbeddedRungeKutta(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s,
                                       int roots, Pair pair)
    : n_(n), rtol_(rtol), roots_(roots), system_(system), pair_(pair), max_step_s_(max_step_s) {
  if (n < 1 || n > kMaxN) throw std::invalid_argument("EmbeddedRungeKutta: n must be 1.." + std::to_string(kMaxN));
  if (roots < 1 || roots > kMaxRoots) {
    throw std::invalid_argument("EmbeddedRungeKutta: roots must be 1.." + std::to_string(kMaxRoots));
  }
  SetTolerances(rtol, atol);
  Vec zero{};
  ReInit(0.0, zero.data());
}

Dop853::Dop853(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, int roots)
    : EmbeddedRungeKutta(n, system, rtol, atol, max_step_s, roots, Pair{8, 6.0, 12, false}) {}

Dopri5::Dopri5(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, int roots)
    : EmbeddedRungeKutta(n, system, rtol, atol, max_step_s, roots, Pair{5, 10.0, 6, true}) {}

void EmbeddedRungeKutta::SetTolerances(double rtol, const double* atol) {
  if (!(rtol >= 0.0)) throw std::invalid_argument("EmbeddedRungeKutta: rtol must be >= 0");
  rtol_ = rtol;
  for (int i = 0; i < n_; ++i) {
    if (!(atol[i] > 0.0) && rtol <= 0.0) throw std::invalid_argument("EmbeddedRungeKutta: a tolerance must be > 0");
    atol_[i] = atol[i];
  }
}

void EmbeddedRungeKutta::SetMaxStep(double max_step_s) { max_step_s_ = max_step_s > 0.0 ? max_step_s : 0.0; }

void EmbeddedRungeKutta::SetRootDirection(const int* direction) {
  for (int r = 0; r < roots_; ++r) direction_[r] = direction[r];
}

void EmbeddedRungeKutta::Rhs(double t_s, const double* y, double* ydot) {
  ++rhs_evals_;
  const int flag = system_.Rhs(t_s, y, ydot);
  if (flag != 0) {
    char text[128];
    std::snprintf(text, sizeof text, "EmbeddedRungeKutta: the right-hand side failed (flag %d) at t = %.17g s", flag,
                  t_s);
    throw IntegratorError(text);
  }
}

void EmbeddedRungeKutta::Roots(double t_s, const double* y, double* g) {
  if (system_.Roots(t_s, y, g) != 0) throw IntegratorError("EmbeddedRungeKutta: the root functions failed");
}

double EmbeddedRungeKutta::SmallestStep(double t_s) { return 2 * kErkEps * std::max(std::abs(t_s), 1.0); }

double EmbeddedRungeKutta::Weight(int i, double y_old, double y_new) const {
  return atol_[i] + rtol_ * std::max(std::abs(y_old), std::abs(y_new));
}

void EmbeddedRungeKutta::ReInit(double t0_s, const double* y0, bool keep_step) {
  // The last step size proposed, as the first guess from here: a restart
  // (an impact) keeps the motion's time scale, while the starting-step
  // estimate from y0 (theta = 0 at an impact, its tolerance atol) ramps up
  // from ~1e-5 s over four or five steps of a flight of ~7 (figure 8).
  h_hint_ = keep_step && started_ ? h_ : 0.0;
  t_old_ = t_new_ = t_ = t0_s;
  for (int i = 0; i < n_; ++i) y_old_[i] = y_new_[i] = y_out_[i] = y0[i];
  started_ = false;
  last_rejected_ = false;
  dense_ready_ = false;
  steps_ = rhs_evals_ = fails_ = 0;
  // The root functions' values at the start are taken when stepping starts
  // (the caller sets the directions after ReInit, and may change the model's
  // regime too).
  t_lo_ = t0_s;
  found_.fill(0);
}

// Hairer's starting step: h0 from |y| / |f| (scaled by the tolerances), one
// Euler step to estimate the second derivative, and h such that h^order
// times the larger of the two is 0.01.
double EmbeddedRungeKutta::InitialStep() {
  const Vec& f0 = k_[0];
  double dy = 0.0, df = 0.0;
  for (int i = 0; i < n_; ++i) {
    const double sk = atol_[i] + rtol_ * std::abs(y_new_[i]);
    dy += (y_new_[i] / sk) * (y_new_[i] / sk);
    df += (f0[i] / sk) * (f0[i] / sk);
  }
  dy = std::sqrt(dy / n_);
  df = std::sqrt(df / n_);
  double h = dy < 1e-5 || df < 1e-5 ? 1e-6 : 0.01 * dy / df;
  if (max_step_s_ > 0.0) h = std::min(h, max_step_s_);
  Vec y1{}, f1{};
  for (int i = 0; i < n_; ++i) y1[i] = y_new_[i] + h * f0[i];
  Rhs(t_new_ + h, y1.data(), f1.data());
  double d2 = 0.0;
  for (int i = 0; i < n_; ++i) {
    const double sk = atol_[i] + rtol_ * std::abs(y_new_[i]);
    d2 += ((f1[i] - f0[i]) / sk) * ((f1[i] - f0[i]) / sk);
  }
  d2 = std::sqrt(d2 / n_) / h;
  const double d = std::max(d2, df);
  const double h1 = d <= 1e-15 ? std::max(1e-6, h * 1e-3) : std::pow(0.01 / d, 1.0 / pair_.order);
  h = std::min(100.0 * h, h1);
  if (max_step_s_ > 0.0) h = std::min(h, max_step_s_);
  return h;
}

void EmbeddedRungeKutta::Step(double tstop_s) {
  const int end = pair_.end_stage;
  if (!started_) {
    Rhs(t_new_, y_new_.data(), k_[end].data());
    Roots(t_new_, y_new_.data(), g_new_.data());
    for (int r = 0; r < roots_; ++r) g_lo_[r] = g_new_[r];
    k_[0] = k_[end];
    h_ = h_hint_ > 0.0 ? h_hint_ : InitialStep();
    started_ = true;
  } else {
    k_[0] = k_[end];  // first same as last
  }
  t_old_ = t_new_;
  y_old_ = y_new_;
  dense_ready_ = false;
  for (int r = 0; r < roots_; ++r) g_lo_[r] = g_new_[r];
  t_lo_ = t_old_;
  const double exponent = -1.0 / pair_.order;
  Vec ys{};
  while (true) {
    double h = h_;
    if (max_step_s_ > 0.0) h = std::min(h, max_step_s_);
    bool to_stop = false;
    if (t_old_ + h >= tstop_s || t_old_ + 1.01 * h >= tstop_s) {
      h = tstop_s - t_old_;
      to_stop = true;
    }
    if (!(h > SmallestStep(t_old_))) {
      char text[160];
      std::snprintf(text, sizeof text, "EmbeddedRungeKutta: step size %.3g s too small at t = %.17g s (stop at %.17g s)",
                    h, t_old_, tstop_s);
      throw StepFailure(text);
    }
    const double err = TryStep(h, to_stop ? tstop_s : t_old_ + h, ys);
    if (!std::isfinite(err)) {
      ++fails_;
      h_ = h * kErkMinFactor;
      last_rejected_ = true;
      continue;
    }
    if (err > 1.0) {
      ++fails_;
      h_ = h * std::max(kErkMinFactor, kErkSafety * std::pow(err, exponent));
      last_rejected_ = true;
      continue;
    }
    double factor =
        err == 0.0 ? pair_.max_factor : std::min(pair_.max_factor, kErkSafety * std::pow(err, exponent));
    if (last_rejected_) factor = std::min(factor, 1.0);
    factor = std::max(factor, kErkMinFactor);
    last_rejected_ = false;
    t_new_ = to_stop ? tstop_s : t_old_ + h;
    y_new_ = ys;
    if (!pair_.end_in_try) Rhs(t_new_, y_new_.data(), k_[end].data());
    ++steps_;
    h_ = h * factor;
    break;
  }
  Roots(t_new_, y_new_.data(), g_new_.data());
}

double Dop853::TryStep(double h, double, Vec& ys) {
  const int n = n_;
  for (int s = 1; s < 12; ++s) {
    for (int i = 0; i < n; ++i) {
      double acc = 0.0;
      for (int j = 0; j < s; ++j) acc += kDopA[s][j] * k_[j][i];
      ys[i] = y_old_[i] + h * acc;
    }
    Rhs(t_old_ + kDopC[s] * h, ys.data(), k_[s].data());
  }
  double err5 = 0.0, err3 = 0.0;
  for (int i = 0; i < n; ++i) {
    double acc = 0.0, e5 = 0.0, e3 = 0.0;
    for (int j = 0; j < 12; ++j) {
      acc += kDopA[12][j] * k_[j][i];
      e5 += kDopE5[j] * k_[j][i];
      e3 += kDopE3[j] * k_[j][i];
    }
    ys[i] = y_old_[i] + h * acc;
    const double sk = Weight(i, y_old_[i], ys[i]);
    err5 += (e5 / sk) * (e5 / sk);
    err3 += (e3 / sk) * (e3 / sk);
  }
  // The 5th-order estimate, damped by the 3rd where the two differ (the
  // method's estimate of order 8 in h).
  double denom = err5 + 0.01 * err3;
  if (denom <= 0.0) denom = 1.0;
  return std::abs(h) * err5 / std::sqrt(denom * n);
}

void Dop853::PrepareDense() {
  const double h = t_new_ - t_old_;
  const int n = n_;
  Vec ys{};
  for (int s = 13; s < 16; ++s) {
    for (int i = 0; i < n; ++i) {
      double acc = 0.0;
      for (int j = 0; j < s; ++j) acc += kDopA[s][j] * k_[j][i];
      ys[i] = y_old_[i] + h * acc;
    }
    Rhs(t_old_ + kDopC[s] * h, ys.data(), k_[s].data());
  }
  for (int i = 0; i < n; ++i) {
    const double dy = y_new_[i] - y_old_[i];
    dense_[0][i] = dy;
    dense_[1][i] = h * k_[0][i] - dy;
    dense_[2][i] = 2.0 * dy - h * (k_[12][i] + k_[0][i]);
    for (int d = 0; d < 4; ++d) {
      double acc = 0.0;
      for (int j = 0; j < 16; ++j) acc += kDopD[d][j] * k_[j][i];
      dense_[3 + d][i] = h * acc;
    }
  }
}

// y(t_old + x h) = y_old + x (c0 + (1-x) (c1 + x (c2 + (1-x) (c3 + x (c4 + (1-x) (c5 + x c6)))))).
void Dop853::Dense(double x, double* y) const {
  for (int i = 0; i < n_; ++i) {
    double v = 0.0;
    for (int d = 6; d >= 0; --d) {
      v += dense_[d][i];
      v *= (d % 2 == 0) ? x : 1.0 - x;
    }
    y[i] = y_old_[i] + v;
  }
}

// Stages 1-5, the solution, f there (stage 6, c = 1: at the step's end as
// the caller places it) and the error of the embedded order 4.
double Dopri5::TryStep(double h, double t_end, Vec& ys) {
  const int n = n_;
  for (int s = 1; s < 7; ++s) {
    for (int i = 0; i < n; ++i) {
      double acc = 0.0;
      for (int j = 0; j < s; ++j) acc += kDp5A[s][j] * k_[j][i];
      ys[i] = y_old_[i] + h * acc;
    }
    if (s < 6) Rhs(kDp5C[s] == 1.0 ? t_end : t_old_ + kDp5C[s] * h, ys.data(), k_[s].data());
  }
  Rhs(t_end, ys.data(), k_[6].data());
  double err = 0.0;
  for (int i = 0; i < n; ++i) {
    double e = 0.0;
    for (int j = 0; j < 7; ++j) e += kDp5E[j] * k_[j][i];
    const double scaled = h * e / Weight(i, y_old_[i], ys[i]);
    err += scaled * scaled;
  }
  return std::sqrt(err / n);
}

void Dopri5::PrepareDense() {
  const double h = t_new_ - t_old_;
  for (int i = 0; i < n_; ++i) {
    const double dy = y_new_[i] - y_old_[i];
    const double c2 = h * k_[0][i] - dy;
    double d = 0.0;
    for (int j = 0; j < 7; ++j) d += kDp5D[j] * k_[j][i];
    dense_[0][i] = dy;
    dense_[1][i] = c2;
    dense_[2][i] = dy - h * k_[6][i] - c2;
    dense_[3][i] = h * d;
  }
}

// y(t_old + x h) = y_old + x (c0 + (1-x) (c1 + x (c2 + (1-x) c3))).
void Dopri5::Dense(double x, double* y) const {
  for (int i = 0; i < n_; ++i) {
    y[i] = y_old_[i] + x * (dense_[0][i] + (1.0 - x) * (dense_[1][i] + x * (dense_[2][i] + (1.0 - x) * dense_[3][i])));
  }
}

void EmbeddedRungeKutta::Interpolate(double t_s, double* y) {
  if (t_s == t_new_) {
    for (int i = 0; i < n_; ++i) y[i] = y_new_[i];
    return;
  }
  if (!dense_ready_) {
    PrepareDense();
    dense_ready_ = true;
  }
  Dense((t_s - t_old_) / (t_new_ - t_old_), y);
}

void EmbeddedRungeKutta::RootsAt(double t_s, double* y, double* g) {
  Interpolate(t_s, y);
  Roots(t_s, y, g);
}

namespace {
// Whether root r moved from g_lo to g in its direction (+1 rising, -1 falling, 0 either).
bool DopCrossed(double g_lo, double g, int direction) {
  if (g_lo == 0.0) return false;
  const bool sign_changed = g_lo > 0.0 ? g <= 0.0 : g >= 0.0;
  if (!sign_changed) return false;
  return direction == 0 || (direction > 0) == (g_lo < 0.0);
}
}  // namespace

bool EmbeddedRungeKutta::FindRoot(double t_hi_s, const double* g_hi) {
  // Nearly every call (once a sample in the model node) has no crossing:
  // answered before the search's scratch is set up.
  bool crossed = false;
  for (int r = 0; r < roots_; ++r) crossed = crossed || DopCrossed(g_lo_[r], g_hi[r], direction_[r]);
  if (!crossed) return false;
  const double tol = 100 * kErkEps * std::max(std::abs(t_hi_s), std::abs(t_new_ - t_old_));
  double t_best = t_hi_s;
  bool any = false;
  Vec y{};
  std::array<double, kMaxRoots> g{};
  for (int r = 0; r < roots_; ++r) {
    if (!DopCrossed(g_lo_[r], g_hi[r], direction_[r])) continue;
    // Illinois' regula falsi on root r over (a, b], b always past the crossing.
    double a = t_lo_, b = std::min(t_hi_s, t_best);
    double ga = g_lo_[r];
    double gb = g_hi[r];
    if (any) {  // an earlier root bounds this one's search: is r crossed there?
      RootsAt(b, y.data(), g.data());
      if (!DopCrossed(ga, g[r], 0)) continue;
      gb = g[r];
    }
    int kept = 0;
    for (int it = 0; it < 200 && b - a > tol; ++it) {
      double m = gb != ga ? b - gb * (b - a) / (gb - ga) : 0.5 * (a + b);
      if (!(m > a && m < b)) m = 0.5 * (a + b);
      m = std::min(std::max(m, a + 0.5 * tol), b - 0.5 * tol);
      RootsAt(m, y.data(), g.data());
      if (DopCrossed(ga, g[r], 0)) {
        b = m;
        gb = g[r];
        if (kept == -1) ga *= 0.5;
        kept = -1;
      } else {
        a = m;
        ga = g[r];
        if (kept == +1) gb *= 0.5;
        kept = +1;
      }
    }
    t_best = b;
    any = true;
  }
  if (!any) return false;
  // Every root crossed at t_best (the earliest crossing, within its tolerance).
  RootsAt(t_best, y.data(), g.data());
  found_.fill(0);
  for (int r = 0; r < roots_; ++r) {
    if (DopCrossed(g_lo_[r], g[r], direction_[r])) found_[r] = g_lo_[r] < 0.0 ? +1 : -1;
  }
  bool reported = false;
  for (int r = 0; r < roots_; ++r) reported = reported || found_[r] != 0;
  if (!reported) {
    // The search's end differs from the root's own test by rounding: report
    // the one that was searched at its bracket's end.
    for (int r = 0; r < roots_; ++r) {
      if (DopCrossed(g_lo_[r], g_hi[r], direction_[r])) {
        found_[r] = g_lo_[r] < 0.0 ? +1 : -1;
        break;
      }
    }
  }
  t_ = t_best;
  for (int i = 0; i < n_; ++i) y_out_[i] = y[i];
  t_lo_ = t_best;
  for (int r = 0; r < roots_; ++r) g_lo_[r] = g[r];
  return true;
}

EmbeddedRungeKutta::Result EmbeddedRungeKutta::Advance(double tout_s, double tstop_s) {
  if (tstop_s < tout_s) tstop_s = tout_s;
  while (true) {
    if (started_ && t_lo_ < t_new_) {
      // Search the rest of the current step up to the output.
      const double t_end = std::min(t_new_, tout_s);
      if (t_end > t_lo_) {
        // The roots at t_end: the step's own at its end (the model node's
        // every sample), else from the dense output.
        std::array<double, kMaxRoots> g_between{};
        const double* g_end = g_new_.data();
        if (t_end != t_new_) {
          Vec y{};
          RootsAt(t_end, y.data(), g_between.data());
          g_end = g_between.data();
        }
        if (FindRoot(t_end, g_end)) return Result::kRoot;
        t_lo_ = t_end;
        for (int r = 0; r < roots_; ++r) {
          // A root function that was exactly zero becomes active once it is not.
          g_lo_[r] = g_end[r];
        }
      }
    }
    if (tout_s <= t_new_) {
      if (tout_s < t_old_) {
        throw std::invalid_argument("EmbeddedRungeKutta: output time before the current step");
      }
      t_ = tout_s;
      Interpolate(tout_s, y_out_.data());
      if (t_lo_ < tout_s) t_lo_ = tout_s;
      return Result::kReached;
    }
    Step(tstop_s);
  }
}

void EmbeddedRungeKutta::RootsFound(int* found) const {
  for (int r = 0; r < roots_; ++r) found[r] = found_[r];
}

}  // namespace rocklab::model::detail
