#include "topo_gaussian/physics/mass_properties.h"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "topo_gaussian/common/block_sum.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian {
namespace {

using Vec10 = Eigen::Matrix<double, 10, 1>;

// Index of the packed symmetric entries (xx, yy, zz, xy, xz, yz).
constexpr int kSymRow[6] = {0, 1, 2, 0, 0, 1};
constexpr int kSymCol[6] = {0, 1, 2, 1, 2, 2};

// The ten numbers (scalar, 3-vector, symmetric 3×3) are packed alike for moments and properties.
Vec10 pack(double s, const Eigen::Vector3d& v, const Eigen::Matrix3d& M) {
  Vec10 out;
  out[0] = s;
  out.segment<3>(1) = v;
  for (int k = 0; k < 6; ++k) out[4 + k] = M(kSymRow[k], kSymCol[k]);
  return out;
}

void unpack(const Vec10& in, double* s, Eigen::Vector3d* v, Eigen::Matrix3d* M) {
  *s = in[0];
  *v = in.segment<3>(1);
  for (int k = 0; k < 6; ++k) {
    (*M)(kSymRow[k], kSymCol[k]) = in[4 + k];
    (*M)(kSymCol[k], kSymRow[k]) = in[4 + k];
  }
}

}  // namespace

Vec10 MassMoments::toVector() const { return pack(m0, m1, m2); }

MassMoments MassMoments::fromVector(const Vec10& v) {
  MassMoments m;
  unpack(v, &m.m0, &m.m1, &m.m2);
  return m;
}

Vec10 MassProperties::toVector() const { return pack(mass, com, inertia); }

MassProperties MassProperties::fromVector(const Vec10& v) {
  MassProperties p;
  unpack(v, &p.mass, &p.com, &p.inertia);
  return p;
}

void MassProperties::principal(Eigen::Vector3d* moments, Eigen::Matrix3d* axes) const {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(inertia);
  if (moments) *moments = es.eigenvalues();
  if (axes) *axes = es.eigenvectors();
}

MassMoments computeMassMoments(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& masses,
                               double cell_variance_m2) {
  if (X.size() != masses.size()) {
    throw TopoError(
        "particle masses",
        "size " + std::to_string(masses.size()) + " differs from " + std::to_string(X.size()) + " positions",
        "give one mass per particle");
  }
  // Summed in fixed blocks, added in block order: the same bits on any number of threads (block_sum.h).
  const Vec10 acc =
      blockSum<Vec10>(static_cast<std::ptrdiff_t>(X.size()), Vec10::Zero(), [&](Vec10* a, std::ptrdiff_t i) {
        const double mi = masses[i];
        const Eigen::Vector3d& x = X[i];
        (*a)[0] += mi;
        for (int k = 0; k < 3; ++k) (*a)[1 + k] += mi * x[k];
        for (int k = 0; k < 6; ++k) (*a)[4 + k] += mi * x[kSymRow[k]] * x[kSymCol[k]];
      });
  const double m0 = acc[0];
  double j[6];
  for (int k = 0; k < 6; ++k) j[k] = acc[4 + k];
  MassMoments m;
  m.m0 = m0;
  m.m1 = Eigen::Vector3d(acc[1], acc[2], acc[3]);
  for (int k = 0; k < 3; ++k) j[k] += m0 * cell_variance_m2;  // Σ m_i Σ_cell (diagonal)
  for (int k = 0; k < 6; ++k) {
    m.m2(kSymRow[k], kSymCol[k]) = j[k];
    m.m2(kSymCol[k], kSymRow[k]) = j[k];
  }
  return m;
}

MassProperties massPropertiesFromMoments(const MassMoments& moments) {
  if (!(moments.m0 > 0.0) || !std::isfinite(moments.m0) || !moments.m1.allFinite() || !moments.m2.allFinite()) {
    throw TopoError("mass moments", "total mass " + std::to_string(moments.m0) + " kg is not positive and finite",
                    "check the particle densities (a density floor above zero) and volumes");
  }
  MassProperties p;
  p.mass = moments.m0;
  p.com = moments.m1 / moments.m0;
  const Eigen::Matrix3d C = moments.m2 - moments.m1 * moments.m1.transpose() / moments.m0;
  p.inertia = C.trace() * Eigen::Matrix3d::Identity() - C;
  p.inertia = 0.5 * (p.inertia + p.inertia.transpose()).eval();
  return p;
}

MassProperties computeMassProperties(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& masses,
                                     double cell_variance_m2) {
  return massPropertiesFromMoments(computeMassMoments(X, masses, cell_variance_m2));
}

Eigen::Matrix<double, 10, 10> massPropertiesJacobian(const MassMoments& moments) {
  // props = f(M0, M1, M2):  m = M0,  c = M1/M0,  C = M2 − M1 M1ᵀ/M0,  I = tr(C) 1 − C.
  Eigen::Matrix<double, 10, 10> J = Eigen::Matrix<double, 10, 10>::Zero();
  const double M0 = moments.m0;
  const Eigen::Vector3d& M1 = moments.m1;
  J(0, 0) = 1.0;
  for (int a = 0; a < 3; ++a) {
    J(1 + a, 0) = -M1[a] / (M0 * M0);
    J(1 + a, 1 + a) = 1.0 / M0;
  }
  // dC_ab: w.r.t. M0: +M1a M1b / M0²; w.r.t. M1c: −(δac M1b + δbc M1a)/M0; w.r.t. packed M2 entry k: 1 at (a,b).
  auto dC = [&](int a, int b, int var) -> double {
    if (var == 0) return M1[a] * M1[b] / (M0 * M0);
    if (var <= 3) {
      const int c = var - 1;
      return -(((a == c) ? M1[b] : 0.0) + ((b == c) ? M1[a] : 0.0)) / M0;
    }
    const int k = var - 4;
    return ((kSymRow[k] == a && kSymCol[k] == b) || (kSymRow[k] == b && kSymCol[k] == a)) ? 1.0 : 0.0;
  };
  for (int var = 0; var < 10; ++var) {
    const double dtr = dC(0, 0, var) + dC(1, 1, var) + dC(2, 2, var);
    for (int k = 0; k < 6; ++k) {
      const int a = kSymRow[k], b = kSymCol[k];
      J(4 + k, var) = (a == b ? dtr : 0.0) - dC(a, b, var);
    }
  }
  return J;
}

void momentsGradientToParticles(const std::vector<Eigen::Vector3d>& X, const Vec10& g, std::vector<double>* dL_dm,
                                double cell_variance_m2) {
  const long n = static_cast<long>(X.size());
  const double cell = cell_variance_m2 * (g[4] + g[5] + g[6]);  // ∂M2/∂m_i ∋ Σ_cell on the diagonal
  dL_dm->resize(X.size());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    const Eigen::Vector3d& x = X[i];
    double d = g[0] + g[1] * x[0] + g[2] * x[1] + g[3] * x[2] + cell;
    for (int k = 0; k < 6; ++k) d += g[4 + k] * x[kSymRow[k]] * x[kSymCol[k]];
    (*dL_dm)[i] = d;
  }
}

void massPropertiesGradientToParticles(const std::vector<Eigen::Vector3d>& X, const MassMoments& moments,
                                       const Vec10& dL_dprops, std::vector<double>* dL_dm, double cell_variance_m2) {
  const Vec10 g = massPropertiesJacobian(moments).transpose() * dL_dprops;
  momentsGradientToParticles(X, g, dL_dm, cell_variance_m2);
}

}  // namespace topo_gaussian
