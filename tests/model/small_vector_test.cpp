// model/small_vector.h: the fixed-length vector operations the integrators
// use instead of the serial N_Vector's.
//
// ORACLE: SUNDIALS' own serial vector (N_VNew_Serial, its operations
// untouched) on the same inputs. TOLERANCE: bit equality: every operation
// computes the same expressions in the same order (sums in index order).
#include <gtest/gtest.h>

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>

#include <cstring>
#include <random>
#include <vector>

#include "model/small_vector.h"

namespace rocklab::model::detail {
namespace {

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

class SmallVectorTest : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    ASSERT_EQ(SUNContext_Create(nullptr, &ctx_), 0);
    n_ = GetParam();
    ref_ = N_VNew_Serial(n_, ctx_);
    N_VEnableFusedOps_Serial(ref_, SUNTRUE);
    small_ = N_VNew_Serial(n_, ctx_);
    ASSERT_TRUE(UseSmallVectorOps(small_));
    for (int k = 0; k < kVecs; ++k) {
      r_[k] = N_VClone(ref_);
      s_[k] = N_VClone(small_);
    }
  }
  void TearDown() override {
    for (int k = 0; k < kVecs; ++k) {
      N_VDestroy(r_[k]);
      N_VDestroy(s_[k]);
    }
    N_VDestroy(ref_);
    N_VDestroy(small_);
    SUNContext_Free(&ctx_);
  }
  // The same random values (a few zeros and negatives among them) in both sets.
  void Fill(std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    for (int k = 0; k < kVecs; ++k) {
      for (int i = 0; i < n_; ++i) {
        const double v = (rng() % 7 == 0) ? 0.0 : u(rng);
        NV_Ith_S(r_[k], i) = v;
        NV_Ith_S(s_[k], i) = v;
      }
    }
  }
  void ExpectSame(int k, const char* op) {
    for (int i = 0; i < n_; ++i) {
      EXPECT_TRUE(SameBits(NV_Ith_S(r_[k], i), NV_Ith_S(s_[k], i)))
          << op << " n " << n_ << " element " << i << ": " << NV_Ith_S(r_[k], i) << " vs " << NV_Ith_S(s_[k], i);
    }
  }
  static constexpr int kVecs = 6;
  SUNContext ctx_{nullptr};
  int n_{};
  N_Vector ref_{nullptr}, small_{nullptr};
  N_Vector r_[kVecs]{}, s_[kVecs]{};
};

TEST_P(SmallVectorTest, EveryOperationGivesTheSerialVectorsBits) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    Fill(rng);
    const double a = std::uniform_real_distribution<double>(-3, 3)(rng);
    // The serial vector's special cases too: b = 1, a = b, a = -b.
    const double b = trial % 4 == 0 ? 1.0 : trial % 4 == 1 ? a : trial % 4 == 2 ? -a : -0.7;
    N_VLinearSum(a, r_[0], b, r_[1], r_[5]);
    N_VLinearSum(a, s_[0], b, s_[1], s_[5]);
    ExpectSame(5, "LinearSum");
    N_VLinearSum(1.0, r_[0], -1.0, r_[1], r_[5]);
    N_VLinearSum(1.0, s_[0], -1.0, s_[1], s_[5]);
    ExpectSame(5, "LinearSum(1, -1)");
    N_VLinearSum(a, r_[0], 1.0, r_[1], r_[1]);  // axpy in place
    N_VLinearSum(a, s_[0], 1.0, s_[1], s_[1]);
    ExpectSame(1, "LinearSum in place");
    N_VScale(a, r_[2], r_[5]);
    N_VScale(a, s_[2], s_[5]);
    ExpectSame(5, "Scale");
    N_VProd(r_[0], r_[2], r_[5]);
    N_VProd(s_[0], s_[2], s_[5]);
    ExpectSame(5, "Prod");
    N_VAbs(r_[0], r_[5]);
    N_VAbs(s_[0], s_[5]);
    ExpectSame(5, "Abs");
    N_VAddConst(r_[0], a, r_[5]);
    N_VAddConst(s_[0], a, s_[5]);
    ExpectSame(5, "AddConst");
    N_VCompare(0.5, r_[0], r_[5]);
    N_VCompare(0.5, s_[0], s_[5]);
    ExpectSame(5, "Compare");
    EXPECT_EQ(N_VInvTest(r_[0], r_[5]), N_VInvTest(s_[0], s_[5]));
    ExpectSame(5, "InvTest");
    EXPECT_EQ(N_VConstrMask(r_[0], r_[1], r_[5]), N_VConstrMask(s_[0], s_[1], s_[5]));
    ExpectSame(5, "ConstrMask");
    EXPECT_TRUE(SameBits(N_VDotProd(r_[0], r_[1]), N_VDotProd(s_[0], s_[1]))) << "DotProd";
    EXPECT_TRUE(SameBits(N_VMaxNorm(r_[0]), N_VMaxNorm(s_[0]))) << "MaxNorm";
    EXPECT_TRUE(SameBits(N_VWrmsNorm(r_[0], r_[1]), N_VWrmsNorm(s_[0], s_[1]))) << "WrmsNorm";
    EXPECT_TRUE(SameBits(N_VWrmsNormMask(r_[0], r_[1], r_[2]), N_VWrmsNormMask(s_[0], s_[1], s_[2])))
        << "WrmsNormMask";
    EXPECT_TRUE(SameBits(N_VMin(r_[0]), N_VMin(s_[0]))) << "Min";
    EXPECT_TRUE(SameBits(N_VWL2Norm(r_[0], r_[1]), N_VWL2Norm(s_[0], s_[1]))) << "WL2Norm";
    EXPECT_TRUE(SameBits(N_VL1Norm(r_[0]), N_VL1Norm(s_[0]))) << "L1Norm";
    EXPECT_TRUE(SameBits(N_VMinQuotient(r_[0], r_[1]), N_VMinQuotient(s_[0], s_[1]))) << "MinQuotient";
    EXPECT_TRUE(SameBits(N_VWSqrSumLocal(r_[0], r_[1]), N_VWSqrSumLocal(s_[0], s_[1]))) << "WSqrSumLocal";

    // Fused: 1 to 5 vectors, into a separate vector and in place (z = X[0]).
    double c[5];
    for (double& v : c) v = std::uniform_real_distribution<double>(-2, 2)(rng);
    if (trial % 2 == 0) c[1] = -c[0];
    for (int nvec = 1; nvec <= 4; ++nvec) {
      ASSERT_EQ(N_VLinearCombination(nvec, c, r_, r_[5]), N_VLinearCombination(nvec, c, s_, s_[5]));
      ExpectSame(5, "LinearCombination");
    }
    c[0] = 1.0;
    ASSERT_EQ(N_VLinearCombination(4, c, r_, r_[0]), N_VLinearCombination(4, c, s_, s_[0]));
    ExpectSame(0, "LinearCombination in place");
    N_Vector ry[2] = {r_[1], r_[2]}, rz[2] = {r_[3], r_[4]};
    N_Vector sy[2] = {s_[1], s_[2]}, sz[2] = {s_[3], s_[4]};
    ASSERT_EQ(N_VScaleAddMulti(2, c + 1, r_[0], ry, rz), N_VScaleAddMulti(2, c + 1, s_[0], sy, sz));
    ExpectSame(3, "ScaleAddMulti");
    ExpectSame(4, "ScaleAddMulti");
    ASSERT_EQ(N_VScaleAddMulti(2, c + 1, r_[0], ry, ry), N_VScaleAddMulti(2, c + 1, s_[0], sy, sy));
    ExpectSame(1, "ScaleAddMulti in place");
    ExpectSame(2, "ScaleAddMulti in place");
    double rn[2], sn[2];
    ASSERT_EQ(N_VWrmsNormVectorArray(2, ry, rz, rn), N_VWrmsNormVectorArray(2, sy, sz, sn));
    EXPECT_TRUE(SameBits(rn[0], sn[0]) && SameBits(rn[1], sn[1])) << "WrmsNormVectorArray";
    ASSERT_EQ(N_VScaleVectorArray(2, c, ry, rz), N_VScaleVectorArray(2, c, sy, sz));
    ExpectSame(3, "ScaleVectorArray");
    ExpectSame(4, "ScaleVectorArray");
    ASSERT_EQ(N_VLinearSumVectorArray(2, a, ry, b, rz, rz), N_VLinearSumVectorArray(2, a, sy, b, sz, sz));
    ExpectSame(3, "LinearSumVectorArray");
    ExpectSame(4, "LinearSumVectorArray");
  }
}

TEST_P(SmallVectorTest, ClonesCarryTheOperations) {
  N_Vector clone = N_VClone(small_);
  EXPECT_EQ(clone->ops->nvlinearsum, small_->ops->nvlinearsum);
  EXPECT_NE(clone->ops->nvlinearsum, ref_->ops->nvlinearsum);
  EXPECT_EQ(N_VGetLength(clone), n_);
  N_VDestroy(clone);
}

INSTANTIATE_TEST_SUITE_P(Lengths, SmallVectorTest, ::testing::Values(1, 2, 3, 4));

TEST(SmallVector, OtherLengthsAreRefused) {
  SUNContext ctx{nullptr};
  ASSERT_EQ(SUNContext_Create(nullptr, &ctx), 0);
  N_Vector v = N_VNew_Serial(5, ctx);
  const auto before = v->ops->nvlinearsum;
  EXPECT_FALSE(UseSmallVectorOps(v));
  EXPECT_EQ(v->ops->nvlinearsum, before);
  N_VDestroy(v);
  SUNContext_Free(&ctx);
}

}  // namespace
}  // namespace rocklab::model::detail
