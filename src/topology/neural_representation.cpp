#include "topo_gaussian/topology/neural_representation.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

namespace {

/// Σ_c A(j, c) B(j, c) for every row j, walking the column-major storage in order (a row at a time
/// strides by the row count: with 512 × 512 layers that made the host's weight-norm backward most
/// of a GPU gradient's time).
Eigen::VectorXd rowDots(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& B) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(A.rows());
  for (Eigen::Index c = 0; c < A.cols(); ++c) d.array() += A.col(c).array() * B.col(c).array();
  return d;
}

// Particles are processed in column blocks: big enough for efficient GEMM, small enough that the
// stored activations of a block (depth × width × block doubles) stay modest per thread.
constexpr Eigen::Index kMaxBlock = 2048;
// Output layer gain at initialisation: s deviates from initial_field by ~0.01 (v̂·h is O(1)).
constexpr double kOutputGain = 0.01;

int maxThreads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

int threadId() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

// Column blocks of [0, n): at least one per thread (when n allows), at most kMaxBlock wide.
struct Blocks {
  Eigen::Index size = 0, count = 0;
};

Blocks makeBlocks(Eigen::Index n, int threads) {
  Blocks b;
  if (n == 0) return b;
  Eigen::Index count = std::max<Eigen::Index>((n + kMaxBlock - 1) / kMaxBlock, threads);
  count = ((count + threads - 1) / threads) * threads;  // whole rounds of the thread team
  count = std::min(count, n);
  b.size = (n + count - 1) / count;
  b.count = (n + b.size - 1) / b.size;
  return b;
}

Eigen::Matrix3Xd normalise(const NormalisedFrame& f, const std::vector<Eigen::Vector3d>& X) {
  Eigen::Matrix3Xd U(3, static_cast<Eigen::Index>(X.size()));
  const double inv = 1.0 / f.scale;
  for (std::size_t i = 0; i < X.size(); ++i) U.col(static_cast<Eigen::Index>(i)) = (X[i] - f.centre) * inv;
  return U;
}

}  // namespace

int NeuralRepresentation::parameterCount(int depth, int width) {
  if (depth < 2 || width < 1)
    throw TopoError("neural representation",
                    "depth " + std::to_string(depth) + " / width " + std::to_string(width) + " is not a network",
                    "use depth ≥ 2 (linear layers) and width ≥ 1, e.g. 8 × 512 as in the paper");
  const std::int64_t w = width;
  const std::int64_t count = (3 * w + 2 * w) + (depth - 2) * (w * w + 2 * w) + (w * 1 + 2);
  if (count > INT_MAX)
    throw TopoError(
        "neural representation",
        std::to_string(depth) + " × " + std::to_string(width) + " has " + std::to_string(count) + " parameters",
        "use a smaller width or depth");
  return static_cast<int>(count);
}

NeuralRepresentation::NeuralRepresentation(const NeuralOptions& options, const std::vector<Eigen::Vector3d>& X)
    : options_(options), frame_(NormalisedFrame::fromPoints(X)) {
  num_parameters_ = parameterCount(options.depth, options.width);  // validates depth and width
  if (!std::isfinite(options.initial_field))
    throw TopoError("neural representation initial_field", "is not finite", "use e.g. 0.3");
  n_ = X.size();
  U_ = normalise(frame_, X);
  int offset = 0;
  for (int l = 0; l < options.depth; ++l) {
    Layer L;
    L.in = l == 0 ? 3 : options.width;
    L.out = l == options.depth - 1 ? 1 : options.width;
    L.v = offset;
    L.g = L.v + L.in * L.out;
    L.b = L.g + L.out;
    offset = L.b + L.out;
    layers_.push_back(L);
  }
}

Eigen::VectorXd NeuralRepresentation::initialParameters() const {
  Eigen::VectorXd theta(num_parameters_);
  std::mt19937 rng(options_.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    const Layer& L = layers_[l];
    const bool last = l + 1 == layers_.size();
    // He scale for ReLU layers, 1/fan-in for the linear output.
    const double stddev = std::sqrt((last ? 1.0 : 2.0) / L.in);
    Eigen::Map<Eigen::MatrixXd> v(theta.data() + L.v, L.out, L.in);
    for (Eigen::Index k = 0; k < v.size(); ++k) v.data()[k] = stddev * normal(rng);
    const Eigen::VectorXd norms = rowDots(v, v).cwiseSqrt();
    std::uniform_real_distribution<double> bias(-1.0 / std::sqrt(L.in), 1.0 / std::sqrt(L.in));
    for (int j = 0; j < L.out; ++j) {
      // Hidden: g = ‖v_j‖ so W = v (He-scaled, activations O(1)). Output: small gain, bias = s₀.
      theta[L.g + j] = last ? kOutputGain : norms[j];
      theta[L.b + j] = last ? options_.initial_field : bias(rng);
    }
  }
  return theta;
}

std::vector<Eigen::MatrixXd> NeuralRepresentation::weights(const Eigen::VectorXd& theta) const {
  const int depth = static_cast<int>(layers_.size());
  std::vector<Eigen::MatrixXd> W(depth);
  std::vector<int> zero_row(depth, -1);  // a row with ‖v_j‖ = 0, per layer (thrown after the loop)
  // One layer a thread (O(parameters) work: a few ms for the paper's net, beside a GPU's GEMMs).
#pragma omp parallel for schedule(dynamic) num_threads(std::min(depth, maxThreads()))
  for (int l = 0; l < depth; ++l) {
    const Layer& L = layers_[l];
    const Eigen::Map<const Eigen::MatrixXd> v(theta.data() + L.v, L.out, L.in);
    const Eigen::Map<const Eigen::VectorXd> g(theta.data() + L.g, L.out);
    const Eigen::VectorXd norms = rowDots(v, v).cwiseSqrt();
    for (int j = 0; j < L.out && zero_row[l] < 0; ++j)
      if (!(norms[j] > 0.0)) zero_row[l] = j;
    if (zero_row[l] < 0) W[l] = (g.array() / norms.array()).matrix().asDiagonal() * v;
  }
  for (int l = 0; l < depth; ++l)
    if (zero_row[l] >= 0)
      throw TopoError("neural representation parameters θ",
                      "row " + std::to_string(zero_row[l]) + " of layer " + std::to_string(l) +
                          " has a zero weight vector v (weight normalisation divides by ‖v‖)",
                      "restart from initialParameters()");
  return W;
}

void NeuralRepresentation::forward(const Eigen::VectorXd& theta, const Eigen::Matrix3Xd& U, std::vector<double>* s,
                                   std::vector<double>* margin) const {
  checkParameters(theta);
  const std::vector<Eigen::MatrixXd> W = weights(theta);
  const Eigen::Index n = U.cols();
  if (s) s->resize(static_cast<std::size_t>(n));
  if (margin) margin->assign(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  const int threads = maxThreads();
  const Blocks blocks = makeBlocks(n, threads);
  const int depth = static_cast<int>(layers_.size());

  // Parallel over blocks; Eigen's own GEMM threading stays off inside the parallel region.
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Eigen::Index blk = 0; blk < blocks.count; ++blk) {
    const Eigen::Index c0 = blk * blocks.size;
    const Eigen::Index bs = std::min(blocks.size, n - c0);
    Eigen::MatrixXd H = U.middleCols(c0, bs), Z;
    for (int l = 0; l < depth; ++l) {
      const Layer& L = layers_[l];
      Z.noalias() = W[l] * H;
      Z.colwise() += Eigen::Map<const Eigen::VectorXd>(theta.data() + L.b, L.out);
      if (l + 1 == depth) break;
      if (margin) {
        const Eigen::RowVectorXd m = Z.cwiseAbs().colwise().minCoeff();
        for (Eigen::Index c = 0; c < bs; ++c) (*margin)[c0 + c] = std::min((*margin)[c0 + c], m[c]);
      }
      H = Z.cwiseMax(0.0);
    }
    if (s)
      for (Eigen::Index c = 0; c < bs; ++c) (*s)[c0 + c] = Z(0, c);
  }
}

MlpCuda* NeuralRepresentation::gpu() const {
  if (!gpu_resolved_) {
    gpu_resolved_ = true;
    if (resolveBackend(options_.backend, "neural representation backend") == ComputeBackend::Cuda) {
      gpu_ = std::make_shared<MlpCuda>(layerSizes(), U_, CudaPrecision::Float64);
    }
  }
  return gpu_.get();
}

std::vector<int> NeuralRepresentation::layerSizes() const {
  std::vector<int> sizes{layers_.front().in};
  for (const Layer& L : layers_) sizes.push_back(L.out);
  return sizes;
}

std::vector<Eigen::VectorXd> NeuralRepresentation::biases(const Eigen::VectorXd& theta) const {
  std::vector<Eigen::VectorXd> b;
  for (const Layer& L : layers_) b.push_back(theta.segment(L.b, L.out));
  return b;
}

void NeuralRepresentation::field(const Eigen::VectorXd& theta, std::vector<double>* s) const {
  if (MlpCuda* g = gpu()) {
    checkParameters(theta);
    g->forward(weights(theta), biases(theta), s);
    gpu_theta_ = theta;  // a fieldBackward at this θ reuses the forward's activations
    return;
  }
  forward(theta, U_, s, nullptr);
}

void NeuralRepresentation::fieldAt(const Eigen::VectorXd& theta, const std::vector<Eigen::Vector3d>& points,
                                   std::vector<double>* s) const {
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw TopoError("neural fieldAt points", "point " + std::to_string(i) + " is not finite",
                      "pass finite positions");
  forward(theta, normalise(frame_, points), s, nullptr);
}

void NeuralRepresentation::kinkMargin(const Eigen::VectorXd& theta, std::vector<double>* margin) const {
  forward(theta, U_, nullptr, margin);
}

void NeuralRepresentation::fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                                         Eigen::VectorXd* dL_dtheta) const {
  checkParameters(theta);
  checkFieldGradient(dL_ds);
  if (MlpCuda* gpu_mlp = gpu()) {
    std::vector<Eigen::MatrixXd> G;
    std::vector<Eigen::VectorXd> gb;
    const bool same = gpu_theta_.size() == theta.size() && gpu_theta_ == theta;
    if (!same || !gpu_mlp->backwardAfterForward(dL_ds, &G, &gb))
      gpu_mlp->backward(weights(theta), biases(theta), dL_ds, &G, &gb);
    gpu_theta_.resize(0);  // backward() uploads the same weights; the kept activations stay valid only after field()
    weightNormBackward(theta, G, gb, dL_dtheta);
    return;
  }
  const std::vector<Eigen::MatrixXd> W = weights(theta);
  const Eigen::Index n = U_.cols();
  const int threads = maxThreads();
  const Blocks blocks = makeBlocks(n, threads);
  const int depth = static_cast<int>(layers_.size());

  // dL/dW_l and dL/db_l per thread, summed in thread order afterwards (deterministic).
  struct Partial {
    std::vector<Eigen::MatrixXd> dW;
    std::vector<Eigen::VectorXd> db;
  };
  std::vector<Partial> partial(threads);

#pragma omp parallel num_threads(threads)
  {
    Partial& P = partial[threadId()];
    P.dW.resize(depth);
    P.db.resize(depth);
    for (int l = 0; l < depth; ++l) {
      P.dW[l].setZero(layers_[l].out, layers_[l].in);
      P.db[l].setZero(layers_[l].out);
    }
    std::vector<Eigen::MatrixXd> H(depth);  // inputs of each layer (H[0] = u, then ReLU outputs)
    Eigen::MatrixXd Z, delta, back;
#pragma omp for schedule(static)
    for (Eigen::Index blk = 0; blk < blocks.count; ++blk) {
      const Eigen::Index c0 = blk * blocks.size;
      const Eigen::Index bs = std::min(blocks.size, n - c0);
      H[0] = U_.middleCols(c0, bs);
      for (int l = 0; l + 1 < depth; ++l) {
        Z.noalias() = W[l] * H[l];
        Z.colwise() += Eigen::Map<const Eigen::VectorXd>(theta.data() + layers_[l].b, layers_[l].out);
        H[l + 1] = Z.cwiseMax(0.0);
      }
      // The output is linear: dL/dz_out = dL/ds.
      delta = Eigen::Map<const Eigen::RowVectorXd>(dL_ds.data() + c0, bs);
      for (int l = depth - 1; l >= 0; --l) {
        P.dW[l].noalias() += delta * H[l].transpose();
        P.db[l].noalias() += delta.rowwise().sum();
        if (l == 0) break;
        back.noalias() = W[l].transpose() * delta;
        delta = (H[l].array() > 0.0).select(back.array(), 0.0).matrix();  // ReLU′ of layer l − 1
      }
    }
  }

  std::vector<Eigen::MatrixXd> Gs(depth);
  std::vector<Eigen::VectorXd> gbs(depth);
  for (int l = 0; l < depth; ++l) {
    const Layer& L = layers_[l];
    Gs[l] = Eigen::MatrixXd::Zero(L.out, L.in);
    gbs[l] = Eigen::VectorXd::Zero(L.out);
    for (const Partial& P : partial) {
      if (P.dW.empty()) continue;  // a thread that never ran
      Gs[l] += P.dW[l];
      gbs[l] += P.db[l];
    }
  }
  weightNormBackward(theta, Gs, gbs, dL_dtheta);
}

void NeuralRepresentation::weightNormBackward(const Eigen::VectorXd& theta, const std::vector<Eigen::MatrixXd>& Gs,
                                              const std::vector<Eigen::VectorXd>& gbs,
                                              Eigen::VectorXd* dL_dtheta) const {
  dL_dtheta->setZero(num_parameters_);
  const int depth = static_cast<int>(layers_.size());
  // One layer a thread; each writes its own segments of dL/dθ.
#pragma omp parallel for schedule(dynamic) num_threads(std::min(depth, maxThreads()))
  for (int l = 0; l < depth; ++l) {
    const Layer& L = layers_[l];
    const Eigen::MatrixXd& G = Gs[l];
    const Eigen::VectorXd& gb = gbs[l];
    // Weight normalisation: W_j = g_j v_j/‖v_j‖ ⇒ dL/dg_j = G_j·v̂_j,
    // dL/dv_j = (g_j/‖v_j‖)(G_j − (G_j·v̂_j) v̂_j).
    const Eigen::Map<const Eigen::MatrixXd> v(theta.data() + L.v, L.out, L.in);
    Eigen::Map<Eigen::MatrixXd> dv(dL_dtheta->data() + L.v, L.out, L.in);
    const Eigen::ArrayXd norm = rowDots(v, v).cwiseSqrt().array();
    const Eigen::ArrayXd gdotvhat = rowDots(G, v).array() / norm;
    const Eigen::Map<const Eigen::ArrayXd> g(theta.data() + L.g, L.out);
    dL_dtheta->segment(L.g, L.out) = gdotvhat.matrix();
    // column by column (storage order): dv = diag(g/‖v‖) (G − diag(G·v̂/‖v‖) v)
    const Eigen::ArrayXd a = g / norm, c = gdotvhat / norm;
    for (Eigen::Index k = 0; k < L.in; ++k) dv.col(k) = (a * (G.col(k).array() - c * v.col(k).array())).matrix();
    dL_dtheta->segment(L.b, L.out) = gb;
  }
}

}  // namespace topo_gaussian
