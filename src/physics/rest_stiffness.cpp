// Rest stiffness assembly and its Cholesky preconditioner; see rest_stiffness.h.
#include "topo_gaussian/physics/rest_stiffness.h"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <limits>
#include <mutex>
#include <string>
#include <utility>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

#ifdef TOPO_HAVE_CHOLMOD
#include <Eigen/CholmodSupport>
#ifdef _OPENMP
#include <omp.h>
#endif
// OpenBLAS's own threads compete with the OpenMP particle loops: its threads spin in the kernel
// between calls, so a Newton solve measured much slower with 2 BLAS threads than with 1 on 2 cores.
// BLAS gets every core for the factorisation and one thread for the triangular solves. Weak: absent with other BLAS implementations.
extern "C" void openblas_set_num_threads(int) __attribute__((weak));
#else
#include <Eigen/SparseCholesky>
#endif

namespace topo_gaussian {
namespace {

using Block = std::pair<int, Eigen::Matrix3d>;

/// Column blocks of rows k (particles) of K0 + diag(shift); fixed particles get identity rows and
/// no couplings. lower: only the blocks l ≥ k (what a Cholesky factorisation of the lower triangle
/// reads; half the work).
std::vector<std::vector<Block>> assembleRows(const CorotatedSph& sph, const Eigen::VectorXd* shift,
                                             const std::vector<std::uint8_t>* fixed, bool lower = false) {
  const std::size_t n = sph.size();
  const NeighborList& nb = sph.neighbors();
  const auto& X = sph.restPositions();
  const auto& V = sph.volumes();
  const auto& W = sph.kernelValues();
  const auto& g = sph.kernelGradients();
  const auto& mu = sph.shearModuli();
  const auto& lambda = sph.lameLambdas();
  const double h = sph.smoothingLength();
  const double alpha = sph.options().hourglass_alpha;
  auto isFixed = [&](std::size_t i) { return fixed && !fixed->empty() && (*fixed)[i]; };

  // Per particle i: c_i (self coefficient), and the hourglass moments D_i = Σ_j w_ij X_ji X_jiᵀ,
  // m_i = Σ_j w_ij X_ji, Σ_j w_ij.
  std::vector<Eigen::Vector3d> cself(n), mom(n);
  std::vector<Eigen::Matrix3d> D(n);
  std::vector<double> wsum(n);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    Eigen::Vector3d c = Eigen::Vector3d::Zero(), m = Eigen::Vector3d::Zero();
    Eigen::Matrix3d d = Eigen::Matrix3d::Zero();
    double ws = 0.0;
    for (int e = nb.offsets[i]; e < nb.offsets[i + 1]; ++e) {
      const int j = nb.indices[e];
      c -= V[j] * g[e];
      const Eigen::Vector3d Xji = X[j] - X[i];
      const double w = V[j] * W[e];
      m += w * Xji;
      d += w * Xji * Xji.transpose();
      ws += w;
    }
    cself[i] = c;
    mom[i] = m;
    D[i] = d;
    wsum[i] = ws;
  }

  std::vector<std::vector<Block>> rows(n);
#pragma omp parallel
  {
    std::vector<int> slot(n, -1);  // column particle → position in the row being built
#pragma omp for schedule(dynamic, 64)
    for (long long kk = 0; kk < static_cast<long long>(n); ++kk) {
      const std::size_t k = static_cast<std::size_t>(kk);
      std::vector<Block>& row = rows[k];
      // A row holds the particles within two neighbourhoods (the finger: ~16 × (neighbours + 1), half of
      // them in the lower triangle): reserved about once instead of grown by doubling (each growth
      // copied the row's 80-byte blocks; with many threads, malloc's arenas contended).
      if (isFixed(k)) {
        row.emplace_back(static_cast<int>(k), Eigen::Matrix3d::Identity());
        continue;
      }
      const std::size_t ring = static_cast<std::size_t>(nb.offsets[k + 1] - nb.offsets[k] + 1);
      row.reserve(std::min<std::size_t>(n, (lower ? 10 : 18) * ring));
      auto add = [&](int l, const Eigen::Matrix3d& B) {
        if (slot[l] < 0) {
          slot[l] = static_cast<int>(row.size());
          row.emplace_back(l, B);
        } else {
          row[slot[l]].second += B;
        }
      };
      // Particles i whose energy involves x_k: k itself and its neighbours (lists are symmetric).
      for (int ei = nb.offsets[k] - 1; ei < nb.offsets[k + 1]; ++ei) {
        const std::size_t i = ei < nb.offsets[k] ? k : static_cast<std::size_t>(nb.indices[ei]);
        // q_k, w_k, X_k relative to particle i.
        Eigen::Vector3d qk = cself[i], Xk = Eigen::Vector3d::Zero();
        double wk = 0.0;
        const bool k_is_i = i == k;
        if (!k_is_i) {
          const int* b = nb.begin(i);
          const int* p = std::lower_bound(b, nb.end(i), static_cast<int>(k));
          const int e = nb.offsets[i] + static_cast<int>(p - b);
          qk = V[k] * g[e];
          Xk = X[k] - X[i];
          wk = V[k] * W[e];
        }
        const double Vi = V[i], mui = mu[i], lai = lambda[i];
        const double chg = 2.0 * alpha * mui * Vi / (h * h);
        const Eigen::Vector3d Dqk = D[i] * qk;
        const double qk_m = qk.dot(mom[i]);
        for (int el = nb.offsets[i] - 1; el < nb.offsets[i + 1]; ++el) {
          const bool l_is_i = el < nb.offsets[i];
          const int l = l_is_i ? static_cast<int>(i) : nb.indices[el];
          if (isFixed(static_cast<std::size_t>(l)) || (lower && l < static_cast<int>(k))) continue;
          Eigen::Vector3d ql = cself[i], Xl = Eigen::Vector3d::Zero();
          double wl = 0.0;
          if (!l_is_i) {
            ql = V[l] * g[el];
            Xl = X[l] - X[i];
            wl = V[l] * W[el];
          }
          Eigen::Matrix3d B = Vi * (mui * ql * qk.transpose() + lai * qk * ql.transpose());
          double a = Dqk.dot(ql) - wl * qk.dot(Xl) - wk * ql.dot(Xk);
          if (l_is_i) a += qk_m;
          if (k_is_i) a += ql.dot(mom[i]) - wl;
          if (l_is_i) a -= wk;
          if (k_is_i && l_is_i) a += wsum[i];
          if (!k_is_i && l == static_cast<int>(k)) a += wk;
          B.diagonal().array() += Vi * mui * qk.dot(ql) + chg * a;
          add(l, B);
        }
      }
      if (shift && shift->size() > 0) {
        Eigen::Matrix3d S = shift->segment<3>(3 * k).asDiagonal();
        add(static_cast<int>(k), S);
      }
      for (const Block& b : row) slot[b.first] = -1;
      std::sort(row.begin(), row.end(), [](const Block& a, const Block& b) { return a.first < b.first; });
    }
  }
  return rows;
}

/// lower: rows holds the blocks l ≥ k only (assembleRows(..., true)); the matrix is then K's lower
/// triangle (row ≥ column).
Eigen::SparseMatrix<double> toSparse(const std::vector<std::vector<Block>>& rows, bool lower = false) {
  const std::size_t n = rows.size();
  // Column 3k+a holds K(3l+b, 3k+a) = block(k,l)(a,b) (K is symmetric): its entries are the row's blocks'
  // columns c ≥ c0 (c0 = a on the diagonal block of the lower triangle, else 0). The columns' sizes and
  // offsets first, then every particle's three columns filled in parallel into the compressed arrays.
  std::vector<Eigen::Index> start(3 * n + 1, 0);
  for (std::size_t k = 0; k < n; ++k) {
    const bool diag = lower && !rows[k].empty();
    for (int a = 0; a < 3; ++a) {
      Eigen::Index count = 3 * static_cast<Eigen::Index>(rows[k].size());
      if (diag)
        for (const Block& b : rows[k])
          if (b.first == static_cast<int>(k)) count -= a;
      start[3 * k + a + 1] = start[3 * k + a] + count;
    }
  }
  if (start[3 * n] > std::numeric_limits<int>::max())
    throw TopoError("rest stiffness", std::to_string(start[3 * n]) + " entries exceed the sparse matrix's 32-bit index",
                    "use a coarser spacing (fewer particles or neighbours)");
  Eigen::SparseMatrix<double> K(3 * n, 3 * n);
  K.resizeNonZeros(start[3 * n]);
  auto* outer = K.outerIndexPtr();
  for (std::size_t c = 0; c <= 3 * n; ++c) outer[c] = static_cast<int>(start[c]);
  auto* inner = K.innerIndexPtr();
  double* values = K.valuePtr();
#pragma omp parallel for schedule(dynamic, 256)
  for (long long kk = 0; kk < static_cast<long long>(n); ++kk) {
    const std::size_t k = static_cast<std::size_t>(kk);
    for (int a = 0; a < 3; ++a) {
      Eigen::Index e = start[3 * k + a];
      for (const Block& b : rows[k]) {
        const int c0 = lower && b.first == static_cast<int>(k) ? a : 0;
        for (int c = c0; c < 3; ++c) {
          inner[e] = 3 * b.first + c;
          values[e++] = b.second(a, c);
        }
      }
    }
  }
  return K;
}

}  // namespace

/// The sparsity pattern of a compressed matrix (its symbolic factorisation's key).
struct RestStiffnessPreconditioner::Pattern {
  Eigen::Index rows = 0;
  std::vector<int> outer, inner;
  static Pattern of(const Eigen::SparseMatrix<double>& K) {
    Pattern p;
    p.rows = K.rows();
    p.outer.assign(K.outerIndexPtr(), K.outerIndexPtr() + K.outerSize() + 1);
    p.inner.assign(K.innerIndexPtr(), K.innerIndexPtr() + K.nonZeros());
    return p;
  }
  bool operator==(const Pattern& o) const { return rows == o.rows && outer == o.outer && inner == o.inner; }
};

#ifdef TOPO_HAVE_CHOLMOD
struct RestStiffnessPreconditioner::Factor {
  /// Eigen's CHOLMOD wrapper, plus freeing the numerical values while keeping the analysis.
  struct SupernodalLLT : Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> {
    void dropNumeric() {
      if (m_cholmodFactor) cholmod_change_factor(CHOLMOD_PATTERN, 1, 1, 1, 1, m_cholmodFactor, &this->cholmod());
      m_factorizationIsOk = false;
    }
    double entries() const { return m_cholmodFactor ? static_cast<double>(m_cholmodFactor->xsize) : 0.0; }
  };
  SupernodalLLT llt;
  /// Keeps the symbolic analysis only (the numerical factor is freed); true: worth keeping.
  bool release() {
    llt.dropNumeric();
    return true;
  }
  static void blasThreads(int n) {
    if (openblas_set_num_threads) openblas_set_num_threads(n);
  }
  void analyze(const Eigen::SparseMatrix<double>& K) { llt.analyzePattern(K); }
  /// Entries of the numerical factor the analysis laid out (supernodal: L->xsize).
  double entries() const { return llt.entries(); }
  bool factorize(const Eigen::SparseMatrix<double>& K) {
#ifdef _OPENMP
    blasThreads(omp_get_max_threads());
#endif
    llt.factorize(K);
    blasThreads(1);
    return llt.info() == Eigen::Success;
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& r) const { return llt.solve(r); }
};
std::string RestStiffnessPreconditioner::backend() { return "cholmod-supernodal"; }
#else
struct RestStiffnessPreconditioner::Factor {
  /// Eigen's LDLT, plus the column counts its analysis computed.
  struct Ldlt : Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> {
    double entries() const { return m_nonZerosPerCol.size() ? static_cast<double>(m_nonZerosPerCol.sum()) : 0.0; }
  };
  Ldlt ldlt;
  /// Eigen's SimplicialLDLT cannot free its values alone: not kept (its AMD analysis is cheap).
  bool release() { return false; }
  void analyze(const Eigen::SparseMatrix<double>& K) { ldlt.analyzePattern(K); }
  double entries() const { return ldlt.entries(); }
  bool factorize(const Eigen::SparseMatrix<double>& K) {
    ldlt.factorize(K);
    return ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 0.0;
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& r) const { return ldlt.solve(r); }
};
std::string RestStiffnessPreconditioner::backend() { return "eigen-simplicial-ldlt"; }
#endif

namespace {
// One spare symbolic factor (CHOLMOD: the ordering and supernodal structure, its numerical values
// freed), with the pattern it was analysed for: a preconditioner of the same pattern (same body,
// neighbourhoods and clamps; another material, as in every evaluation of an inference) takes it
// and only refactorises numerically, skipping the fill-reducing ordering and the symbolic analysis
// (1.5 s of 7 s for the 9212-particle finger). A preconditioner gives its factor back when it is
// destroyed; what stays between inferences is the analysis (integers), not the factor.
std::mutex g_spare_mutex;
std::unique_ptr<RestStiffnessPreconditioner::Factor> g_spare;
RestStiffnessPreconditioner::Pattern g_spare_pattern;
}  // namespace

RestStiffnessPreconditioner::~RestStiffnessPreconditioner() {
  if (!factor_ || !pattern_ || !factor_->release()) return;
  std::lock_guard<std::mutex> lock(g_spare_mutex);
  g_spare = std::move(factor_);
  g_spare_pattern = std::move(*pattern_);
}

Eigen::SparseMatrix<double> restStiffness(const CorotatedSph& sph) {
  return toSparse(assembleRows(sph, nullptr, nullptr));
}

namespace {
double meanNeighbours(const CorotatedSph& sph) {
  const std::size_t n = sph.size();
  return n > 0 ? static_cast<double>(sph.neighbors().offsets[n]) / static_cast<double>(n) : 0.0;
}
}  // namespace

double RestStiffnessPreconditioner::assemblyBytesEstimate(const CorotatedSph& sph) {
  const double n = static_cast<double>(sph.size());
  return 21.0 * 4.5 * n * std::min(n, 8.0 * (meanNeighbours(sph) + 1.0));
}

RestStiffnessPreconditioner::RestStiffnessPreconditioner(const CorotatedSph& sph, const Eigen::VectorXd& shift,
                                                         const std::vector<std::uint8_t>& fixed,
                                                         double max_factor_bytes, const CholeskySolverFactory& external,
                                                         bool external_required) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = sph.size();
  if (shift.size() != 0 && static_cast<std::size_t>(shift.size()) != 3 * n)
    throw TopoError("rest-stiffness preconditioner",
                    "shift has " + std::to_string(shift.size()) + " entries for " + std::to_string(n) + " particles",
                    "pass 3N entries or none");
  if (!fixed.empty() && fixed.size() != n)
    throw TopoError("rest-stiffness preconditioner", "fixed flags have the wrong size", "pass one flag per particle");
  // Before assembling: K0 couples two neighbourhoods, about 8 × one neighbourhood's particles (twice its
  // radius); its lower triangle holds half of 9 entries a coupled pair, ~21 bytes each while assembled
  // (12 in K, 80 per 3 × 3 block in the rows).
  const double assembly_bytes = assemblyBytesEstimate(sph);
  const auto refuse = [&](const std::string& what, double bytes) {
    throw TopoError("rest-stiffness preconditioner",
                    what + " for " + std::to_string(n) + " particles would take " + numberText(bytes / 1e9, 3) +
                        " GB, above the limit of " + numberText(max_factor_bytes / 1e9, 3) + " GB",
                    "raise SoftBodyOptions::cholesky_max_factor_bytes where the memory is free, or use a coarser "
                    "spacing (the factor grows about as the particle count to the power 1.5: measured on the finger)");
  };
  if (max_factor_bytes > 0.0 && assembly_bytes > max_factor_bytes)
    refuse("assembling its rest stiffness (about " + numberText(meanNeighbours(sph), 3) + " neighbours a particle)",
           assembly_bytes);
  const Eigen::SparseMatrix<double> K = toSparse(assembleRows(sph, &shift, &fixed, true), true);
  nnz_ = static_cast<std::size_t>(K.nonZeros());
  matrix_bytes_ = 12.0 * static_cast<double>(nnz_);
  const auto notPositiveDefinite = [] {
    return TopoError("rest-stiffness preconditioner", "the rest stiffness is singular or not positive definite",
                     "clamp the body, add contact or inertia (an unsupported body has rigid modes)");
  };
  if (external) {
    std::unique_ptr<CholeskySolver> solver;
    bool positive_definite = true;
    try {
      solver = external();
      positive_definite = solver->factorize(K);
    } catch (const TopoError& e) {
      if (external_required) throw ExternalFactorRefused(e.what());
      external_note_ = e.what();
      solver.reset();
    }
    if (solver) {
      if (!positive_definite) throw notPositiveDefinite();
      external_ = std::move(solver);
      matrix_bytes_ = 0.0;  // K0 is freed when this returns: only the external factor remains
      seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return;
    }
  }
  auto pattern = std::make_unique<Pattern>(Pattern::of(K));
  {
    std::lock_guard<std::mutex> lock(g_spare_mutex);
    if (g_spare && g_spare_pattern == *pattern) {
      factor_ = std::move(g_spare);
      reused_analysis_ = true;
    }
  }
  if (!factor_) {
    factor_ = std::make_unique<Factor>();
    factor_->analyze(K);
  }
  pattern_ = std::move(pattern);
  factor_bytes_ = 8.0 * factor_->entries();
  if (max_factor_bytes > 0.0 && factor_bytes_ + matrix_bytes_ > max_factor_bytes) {
    factor_.reset();  // the analysis is not worth keeping either
    pattern_.reset();
    refuse("its Cholesky factor (with the rest stiffness)", factor_bytes_ + matrix_bytes_);
  }
  if (!factor_->factorize(K)) throw notPositiveDefinite();
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double availableMemoryBytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key, unit;
  double kb = 0.0;
  while (meminfo >> key >> kb >> unit)
    if (key == "MemAvailable:") return 1024.0 * kb;
  return 0.0;
}

void RestStiffnessPreconditioner::apply(const Eigen::VectorXd& r, Eigen::VectorXd* z) const {
  const auto t0 = std::chrono::steady_clock::now();
  try {
    if (external_)
      external_->solve(r, z);
    else
      *z = factor_->solve(r);
  } catch (...) {
    failed_ = true;
    throw;
  }
  ++applications_;
  apply_ns_ += std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
}

std::string RestStiffnessPreconditioner::where() const { return external_ ? external_->name() : "host: " + backend(); }

}  // namespace topo_gaussian
