#include "model/small_vector.h"

#include <nvector/nvector_serial.h>

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace rocklab::model::detail {
namespace {

// Every operation of the SUNDIALS 6.4 vector interface that CVODE (Adams,
// fixed point) and ARKODE's ERKStep call, for length N. Sums run in index
// order, as the serial vector's do.
template <int N>
struct Ops {
  static double* D(N_Vector v) { return NV_DATA_S(v); }

  static void LinearSum(double a, N_Vector x, double b, N_Vector y, N_Vector z) {
    const double *xd = D(x), *yd = D(y);
    double* zd = D(z);
    // a = +-b rounds as a (x +- y), as the serial vector computes it.
    if (a == b) {
      for (int i = 0; i < N; ++i) zd[i] = a * (xd[i] + yd[i]);
    } else if (a == -b) {
      for (int i = 0; i < N; ++i) zd[i] = a * (xd[i] - yd[i]);
    } else {
      for (int i = 0; i < N; ++i) zd[i] = a * xd[i] + b * yd[i];
    }
  }
  static void Const(double c, N_Vector z) {
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = c;
  }
  static void Prod(N_Vector x, N_Vector y, N_Vector z) {
    const double *xd = D(x), *yd = D(y);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = xd[i] * yd[i];
  }
  static void Div(N_Vector x, N_Vector y, N_Vector z) {
    const double *xd = D(x), *yd = D(y);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = xd[i] / yd[i];
  }
  static void Scale(double c, N_Vector x, N_Vector z) {
    const double* xd = D(x);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = c * xd[i];
  }
  static void Abs(N_Vector x, N_Vector z) {
    const double* xd = D(x);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = std::abs(xd[i]);
  }
  static void Inv(N_Vector x, N_Vector z) {
    const double* xd = D(x);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = 1.0 / xd[i];
  }
  static void AddConst(N_Vector x, double b, N_Vector z) {
    const double* xd = D(x);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = xd[i] + b;
  }
  static double DotProd(N_Vector x, N_Vector y) {
    const double *xd = D(x), *yd = D(y);
    double sum = 0.0;
    for (int i = 0; i < N; ++i) sum += xd[i] * yd[i];
    return sum;
  }
  static double MaxNorm(N_Vector x) {
    const double* xd = D(x);
    double m = 0.0;
    for (int i = 0; i < N; ++i) m = std::max(m, std::abs(xd[i]));
    return m;
  }
  static double WSqrSum(N_Vector x, N_Vector w) {
    const double *xd = D(x), *wd = D(w);
    double sum = 0.0;
    for (int i = 0; i < N; ++i) {
      const double p = xd[i] * wd[i];
      sum += p * p;
    }
    return sum;
  }
  static double WSqrSumMask(N_Vector x, N_Vector w, N_Vector id) {
    const double *xd = D(x), *wd = D(w), *idd = D(id);
    double sum = 0.0;
    for (int i = 0; i < N; ++i) {
      if (idd[i] > 0.0) {
        const double p = xd[i] * wd[i];
        sum += p * p;
      }
    }
    return sum;
  }
  static double WrmsNorm(N_Vector x, N_Vector w) { return std::sqrt(WSqrSum(x, w) / N); }
  static double WrmsNormMask(N_Vector x, N_Vector w, N_Vector id) { return std::sqrt(WSqrSumMask(x, w, id) / N); }
  static double Min(N_Vector x) {
    const double* xd = D(x);
    double m = xd[0];
    for (int i = 1; i < N; ++i) m = std::min(m, xd[i]);
    return m;
  }
  static double WL2Norm(N_Vector x, N_Vector w) { return std::sqrt(WSqrSum(x, w)); }
  static double L1Norm(N_Vector x) {
    const double* xd = D(x);
    double sum = 0.0;
    for (int i = 0; i < N; ++i) sum += std::abs(xd[i]);
    return sum;
  }
  static void Compare(double c, N_Vector x, N_Vector z) {
    const double* xd = D(x);
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = std::abs(xd[i]) >= c ? 1.0 : 0.0;
  }
  static sunbooleantype InvTest(N_Vector x, N_Vector z) {
    const double* xd = D(x);
    double* zd = D(z);
    bool no_zero = true;
    for (int i = 0; i < N; ++i) {
      if (xd[i] == 0.0) {
        no_zero = false;
      } else {
        zd[i] = 1.0 / xd[i];
      }
    }
    return no_zero ? SUNTRUE : SUNFALSE;
  }
  static sunbooleantype ConstrMask(N_Vector c, N_Vector x, N_Vector m) {
    const double *cd = D(c), *xd = D(x);
    double* md = D(m);
    bool ok = true;
    for (int i = 0; i < N; ++i) {
      md[i] = 0.0;
      if (cd[i] == 0.0) continue;
      const double xc = xd[i] * cd[i];
      if ((std::abs(cd[i]) > 1.5 && xc <= 0.0) || (std::abs(cd[i]) > 0.5 && xc < 0.0)) {
        md[i] = 1.0;
        ok = false;
      }
    }
    return ok ? SUNTRUE : SUNFALSE;
  }
  static double MinQuotient(N_Vector num, N_Vector denom) {
    const double *nd = D(num), *dd = D(denom);
    bool none = true;
    double m = BIG_REAL;
    for (int i = 0; i < N; ++i) {
      if (dd[i] == 0.0) continue;
      const double q = nd[i] / dd[i];
      m = !none && m < q ? m : q;  // on a tie of -0 and 0, q: the serial vector's SUNMIN
      none = false;
    }
    return m;
  }

  // Fused operations.
  static int LinearCombination(int nvec, double* c, N_Vector* x, N_Vector z) {
    if (nvec < 1) return -1;
    if (nvec == 2) {  // the serial vector's LinearSum, with its rounding
      LinearSum(c[0], x[0], c[1], x[1], z);
      return 0;
    }
    double acc[N];
    const double* x0 = D(x[0]);
    for (int i = 0; i < N; ++i) acc[i] = c[0] * x0[i];
    for (int k = 1; k < nvec; ++k) {
      const double* xk = D(x[k]);
      for (int i = 0; i < N; ++i) acc[i] += c[k] * xk[i];
    }
    double* zd = D(z);
    for (int i = 0; i < N; ++i) zd[i] = acc[i];
    return 0;
  }
  static int ScaleAddMulti(int nvec, double* a, N_Vector x, N_Vector* y, N_Vector* z) {
    if (nvec < 1) return -1;
    double xv[N];
    const double* xd = D(x);
    for (int i = 0; i < N; ++i) xv[i] = xd[i];
    for (int k = 0; k < nvec; ++k) {
      const double* yd = D(y[k]);
      double* zd = D(z[k]);
      for (int i = 0; i < N; ++i) zd[i] = a[k] * xv[i] + yd[i];
    }
    return 0;
  }
  static int DotProdMulti(int nvec, N_Vector x, N_Vector* y, double* dots) {
    if (nvec < 1) return -1;
    for (int k = 0; k < nvec; ++k) dots[k] = DotProd(x, y[k]);
    return 0;
  }
  // Vector array operations.
  static int LinearSumVectorArray(int nvec, double a, N_Vector* x, double b, N_Vector* y, N_Vector* z) {
    if (nvec < 1) return -1;
    for (int k = 0; k < nvec; ++k) LinearSum(a, x[k], b, y[k], z[k]);
    return 0;
  }
  static int ScaleVectorArray(int nvec, double* c, N_Vector* x, N_Vector* z) {
    if (nvec < 1) return -1;
    for (int k = 0; k < nvec; ++k) Scale(c[k], x[k], z[k]);
    return 0;
  }
  static int ConstVectorArray(int nvec, double c, N_Vector* z) {
    if (nvec < 1) return -1;
    for (int k = 0; k < nvec; ++k) Const(c, z[k]);
    return 0;
  }
  static int WrmsNormVectorArray(int nvec, N_Vector* x, N_Vector* w, double* norms) {
    if (nvec < 1) return -1;
    for (int k = 0; k < nvec; ++k) norms[k] = WrmsNorm(x[k], w[k]);
    return 0;
  }
  static int WrmsNormMaskVectorArray(int nvec, N_Vector* x, N_Vector* w, N_Vector id, double* norms) {
    if (nvec < 1) return -1;
    for (int k = 0; k < nvec; ++k) norms[k] = WrmsNormMask(x[k], w[k], id);
    return 0;
  }

  static void Install(N_Vector v) {
    N_Vector_Ops o = v->ops;
    o->nvlinearsum = LinearSum;
    o->nvconst = Const;
    o->nvprod = Prod;
    o->nvdiv = Div;
    o->nvscale = Scale;
    o->nvabs = Abs;
    o->nvinv = Inv;
    o->nvaddconst = AddConst;
    o->nvdotprod = DotProd;
    o->nvmaxnorm = MaxNorm;
    o->nvwrmsnorm = WrmsNorm;
    o->nvwrmsnormmask = WrmsNormMask;
    o->nvmin = Min;
    o->nvwl2norm = WL2Norm;
    o->nvl1norm = L1Norm;
    o->nvcompare = Compare;
    o->nvinvtest = InvTest;
    o->nvconstrmask = ConstrMask;
    o->nvminquotient = MinQuotient;
    o->nvlinearcombination = LinearCombination;
    o->nvscaleaddmulti = ScaleAddMulti;
    o->nvdotprodmulti = DotProdMulti;
    o->nvlinearsumvectorarray = LinearSumVectorArray;
    o->nvscalevectorarray = ScaleVectorArray;
    o->nvconstvectorarray = ConstVectorArray;
    o->nvwrmsnormvectorarray = WrmsNormVectorArray;
    o->nvwrmsnormmaskvectorarray = WrmsNormMaskVectorArray;
    // Left to SUNDIALS' generic loops over the operations above (unused by
    // the integrators here).
    o->nvscaleaddmultivectorarray = nullptr;
    o->nvlinearcombinationvectorarray = nullptr;
    o->nvdotprodlocal = DotProd;
    o->nvmaxnormlocal = MaxNorm;
    o->nvminlocal = Min;
    o->nvl1normlocal = L1Norm;
    o->nvinvtestlocal = InvTest;
    o->nvconstrmasklocal = ConstrMask;
    o->nvminquotientlocal = MinQuotient;
    o->nvwsqrsumlocal = WSqrSum;
    o->nvwsqrsummasklocal = WSqrSumMask;
    o->nvdotprodmultilocal = DotProdMulti;
  }
};

}  // namespace

bool UseSmallVectorOps(N_Vector serial) {
  if (serial == nullptr || N_VGetVectorID(serial) != SUNDIALS_NVEC_SERIAL) return false;
  switch (NV_LENGTH_S(serial)) {
    case 1: Ops<1>::Install(serial); return true;
    case 2: Ops<2>::Install(serial); return true;
    case 3: Ops<3>::Install(serial); return true;
    case 4: Ops<4>::Install(serial); return true;
    default: return false;
  }
}

}  // namespace rocklab::model::detail
