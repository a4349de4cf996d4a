// The MLP on the GPU; see include/topo_gaussian/cuda/mlp_cuda.h. cuBLAS is loaded at the first
// use (dlopen of libcublas.so.13): programs that never run the MLP on a GPU do not pay its ~60 ms
// of load time at every start.
#include "topo_gaussian/cuda/mlp_cuda.h"

#include <algorithm>
#include <sstream>
#include <string>
#include <type_traits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"

#if TOPO_HAVE_CUDA
#include <cublas_v2.h>
#include <cuda_runtime_api.h>
#include "cuda_library.h"
#include "mlp_kernels.h"
#include "soft_body_cuda_impl.h"  // check, DeviceBuffer
#endif

namespace topo_gaussian {

#if TOPO_HAVE_CUDA

namespace {

/// The cuBLAS functions the MLP calls, resolved once from libcublas.
struct Cublas {
  cublasStatus_t (*create)(cublasHandle_t*) = nullptr;
  cublasStatus_t (*destroy)(cublasHandle_t) = nullptr;
  cublasStatus_t (*setStream)(cublasHandle_t, cudaStream_t) = nullptr;
  cublasStatus_t (*setMathMode)(cublasHandle_t, cublasMath_t) = nullptr;
  cublasStatus_t (*dgemm)(cublasHandle_t, cublasOperation_t, cublasOperation_t, int, int, int, const double*,
                          const double*, int, const double*, int, const double*, double*, int) = nullptr;
  cublasStatus_t (*sgemm)(cublasHandle_t, cublasOperation_t, cublasOperation_t, int, int, int, const float*,
                          const float*, int, const float*, int, const float*, float*, int) = nullptr;
  cublasStatus_t (*dgemv)(cublasHandle_t, cublasOperation_t, int, int, const double*, const double*, int, const double*,
                          int, const double*, double*, int) = nullptr;
  cublasStatus_t (*sgemv)(cublasHandle_t, cublasOperation_t, int, int, const float*, const float*, int, const float*,
                          int, const float*, float*, int) = nullptr;
  std::string error;
};

template <class F>
bool resolve(void* lib, const char* name, F* f) {
  return cuda_detail::resolveSymbol(lib, name, f, true);
}

const Cublas& cublas() {
  static const Cublas c = [] {
    Cublas c;
    void* lib = cuda_detail::openCudaLibrary({"libcublas.so.13", "libcublas.so.12", "libcublas.so"}, &c.error);
    if (!lib) return c;
    const bool ok = resolve(lib, "cublasCreate", &c.create) && resolve(lib, "cublasDestroy", &c.destroy) &&
                    resolve(lib, "cublasSetStream", &c.setStream) && resolve(lib, "cublasDgemm", &c.dgemm) &&
                    resolve(lib, "cublasSgemm", &c.sgemm) && resolve(lib, "cublasDgemv", &c.dgemv) &&
                    resolve(lib, "cublasSgemv", &c.sgemv) && resolve(lib, "cublasSetMathMode", &c.setMathMode);
    if (!ok) c.error = "libcublas lacks a function the MLP needs (a cuBLAS older than CUDA 11?)";
    return c;
  }();
  return c;
}

void checkBlas(cublasStatus_t s, const char* what) {
  if (s != CUBLAS_STATUS_SUCCESS)
    throw TopoError("CUDA MLP", std::string(what) + " failed with cuBLAS status " + std::to_string(static_cast<int>(s)),
                    "check the GPU's free memory; backend cpu runs without it");
}

template <class T>
cublasStatus_t gemm(cublasHandle_t h, cublasOperation_t a, cublasOperation_t b, int m, int n, int k, T alpha,
                    const T* A, int lda, const T* B, int ldb, T beta, T* C, int ldc) {
  if constexpr (std::is_same_v<T, double>)
    return cublas().dgemm(h, a, b, m, n, k, &alpha, A, lda, B, ldb, &beta, C, ldc);
  else
    return cublas().sgemm(h, a, b, m, n, k, &alpha, A, lda, B, ldb, &beta, C, ldc);
}

template <class T>
cublasStatus_t gemv(cublasHandle_t h, int m, int n, T alpha, const T* A, int lda, const T* x, T beta, T* y) {
  if constexpr (std::is_same_v<T, double>)
    return cublas().dgemv(h, CUBLAS_OP_N, m, n, &alpha, A, lda, x, 1, &beta, y, 1);
  else
    return cublas().sgemv(h, CUBLAS_OP_N, m, n, &alpha, A, lda, x, 1, &beta, y, 1);
}

constexpr long long kBlockPoints = 65536;

}  // namespace

struct MlpCuda::Impl {
  std::vector<int> sizes;
  std::size_t n = 0;
  CudaPrecision precision = CudaPrecision::Float64;
  MlpMath math = MlpMath::Exact;
  cudaStream_t stream = nullptr;
  cublasHandle_t handle = nullptr;
  std::vector<std::unique_ptr<DeviceBuffer>> buffers;
  void* U = nullptr;                // 3 × n
  std::vector<void*> W, b, dW, db;  // per layer
  std::vector<void*> H;             // per layer input (H[0] = the U block), block columns
  std::vector<void*> Hall;          // per hidden layer, every point's activations (keep_all)
  bool keep_all = false;            // the forward keeps every activation for the next backward
  bool kept = false;                // Hall holds the activations of the last forward's weights
  void *Z = nullptr, *delta = nullptr, *back = nullptr, *ones = nullptr, *s = nullptr, *ds = nullptr;
  long long block = 0;
  int widest = 0;
  void* pinned = nullptr;  // host staging (page-locked): every W and b, or every dW and db, or s
  std::size_t pinned_bytes = 0;

  ~Impl() {
    if (handle) cublas().destroy(handle);
    if (stream) cudaStreamDestroy(stream);
    if (pinned) cudaFreeHost(pinned);
  }
  void* alloc(std::size_t bytes) {
    buffers.push_back(std::make_unique<DeviceBuffer>());
    buffers.back()->allocate(bytes);
    return buffers.back()->ptr;
  }
  std::size_t T() const { return precision == CudaPrecision::Float64 ? sizeof(double) : sizeof(float); }

  template <class S>
  void upload(void* dev, const double* host, std::size_t count) {
    std::vector<S> h(host, host + count);
    check(cudaMemcpyAsync(dev, h.data(), count * sizeof(S), cudaMemcpyHostToDevice, stream), "upload");
    check(cudaStreamSynchronize(stream), "upload");
  }

  template <class S>
  void setWeights(const std::vector<Eigen::MatrixXd>& Wh, const std::vector<Eigen::VectorXd>& bh) {
    const std::size_t layers = sizes.size() - 1;
    if (Wh.size() != layers || bh.size() != layers)
      throw TopoError("CUDA MLP",
                      std::to_string(Wh.size()) + " weight matrices for " + std::to_string(layers) + " layers",
                      "pass one W and one b per layer");
    for (std::size_t l = 0; l < layers; ++l) {
      if (Wh[l].rows() != sizes[l + 1] || Wh[l].cols() != sizes[l] || bh[l].size() != sizes[l + 1])
        throw TopoError("CUDA MLP", "layer " + std::to_string(l) + " has the wrong shape",
                        "W_l must be sizes[l+1] x sizes[l], b_l sizes[l+1]");
    }
    kept = false;
    // Every layer's W and b converted into the pinned buffer, copied asynchronously; the stream
    // orders the copies before the GEMMs that read them, and one synchronisation at the end of the
    // call (downloadPoints, downloadGradients) keeps the buffer alive until they are done.
    const std::vector<std::size_t> at = layerOffsets();
    S* h = static_cast<S*>(pinned);
#pragma omp parallel for schedule(dynamic)
    for (int l = 0; l < static_cast<int>(layers); ++l) {
      std::copy(Wh[l].data(), Wh[l].data() + Wh[l].size(), h + at[l]);
      std::copy(bh[l].data(), bh[l].data() + bh[l].size(), h + at[l] + Wh[l].size());
    }
    for (std::size_t l = 0; l < layers; ++l) {
      check(cudaMemcpyAsync(W[l], h + at[l], Wh[l].size() * sizeof(S), cudaMemcpyHostToDevice, stream),
            "weight upload");
      check(cudaMemcpyAsync(b[l], h + at[l] + Wh[l].size(), bh[l].size() * sizeof(S), cudaMemcpyHostToDevice, stream),
            "bias upload");
    }
  }

  /// Where layer l's W (then its b) starts in the pinned buffer, in values.
  std::vector<std::size_t> layerOffsets() const {
    std::vector<std::size_t> at(sizes.size(), 0);
    for (std::size_t l = 0; l + 1 < sizes.size(); ++l) at[l + 1] = at[l] + std::size_t(sizes[l + 1]) * (sizes[l] + 1);
    return at;
  }

  /// Every layer's dW and db into Eigen matrices: asynchronous copies into the pinned buffer, one
  /// synchronisation, then the conversion.
  template <class S>
  void downloadGradients(std::vector<Eigen::MatrixXd>* dWh, std::vector<Eigen::VectorXd>* dbh) {
    const std::size_t layers = sizes.size() - 1;
    dWh->resize(layers);
    dbh->resize(layers);
    const std::vector<std::size_t> at = layerOffsets();
    S* h = static_cast<S*>(pinned);
    for (std::size_t l = 0; l < layers; ++l) {
      const std::size_t nw = std::size_t(sizes[l + 1]) * sizes[l], nb = sizes[l + 1];
      check(cudaMemcpyAsync(h + at[l], dW[l], nw * sizeof(S), cudaMemcpyDeviceToHost, stream), "gradient download");
      check(cudaMemcpyAsync(h + at[l] + nw, db[l], nb * sizeof(S), cudaMemcpyDeviceToHost, stream),
            "gradient download");
    }
    check(cudaStreamSynchronize(stream), "gradient download");
#pragma omp parallel for schedule(dynamic)
    for (int l = 0; l < static_cast<int>(layers); ++l) {
      (*dWh)[l].resize(sizes[l + 1], sizes[l]);
      (*dbh)[l].resize(sizes[l + 1]);
      const S* hl = h + at[l];
      std::copy(hl, hl + (*dWh)[l].size(), (*dWh)[l].data());
      std::copy(hl + (*dWh)[l].size(), hl + (*dWh)[l].size() + (*dbh)[l].size(), (*dbh)[l].data());
    }
  }

  /// Values per point (s) or per point's dL/ds through the pinned buffer.
  template <class S>
  void uploadPoints(void* dev, const double* host) {
    S* h = static_cast<S*>(pinned);
    std::copy(host, host + n, h);
    check(cudaMemcpyAsync(dev, h, n * sizeof(S), cudaMemcpyHostToDevice, stream), "upload");
  }
  template <class S>
  void downloadPoints(const void* dev, double* host) {
    S* h = static_cast<S*>(pinned);
    check(cudaMemcpyAsync(h, dev, n * sizeof(S), cudaMemcpyDeviceToHost, stream), "download");
    check(cudaStreamSynchronize(stream), "download");
    std::copy(h, h + n, host);
  }

  /// The layer inputs of the block starting at point c0 (in Hall when every activation is kept).
  template <class S>
  void pointAt(long long c0) {
    H[0] = static_cast<S*>(U) + 3 * c0;
    if (keep_all)
      for (std::size_t l = 1; l < H.size(); ++l) H[l] = static_cast<S*>(Hall[l]) + c0 * sizes[l];
  }

  /// Forward over the block [c0, c0 + bs): H[l+1] = relu(W_l H[l] + b_l), the output into s + c0.
  template <class S>
  void forwardBlock(long long c0, int bs) {
    const int depth = static_cast<int>(sizes.size()) - 1;
    pointAt<S>(c0);
    for (int l = 0; l < depth; ++l) {
      const bool last = l + 1 == depth;
      S* out = last ? static_cast<S*>(s) + c0 : static_cast<S*>(H[l + 1]);
      checkBlas(gemm<S>(handle, CUBLAS_OP_N, CUBLAS_OP_N, sizes[l + 1], bs, sizes[l], S(1), static_cast<S*>(W[l]),
                        sizes[l + 1], static_cast<const S*>(H[l]), sizes[l], S(0), out, sizes[l + 1]),
                "GEMM (forward)");
      cuda_detail::launchBiasRelu<S>(out, static_cast<const S*>(b[l]), sizes[l + 1],
                                     static_cast<long long>(sizes[l + 1]) * bs, !last, stream);
    }
  }

  template <class S>
  void forwardAll() {
    for (long long c0 = 0; c0 < static_cast<long long>(n); c0 += block)
      forwardBlock<S>(c0, static_cast<int>(std::min<long long>(block, static_cast<long long>(n) - c0)));
    check(cudaGetLastError(), "kernel launch");
    kept = keep_all;
  }

  /// reuse: the activations of the last forward (kept), no forward here.
  template <class S>
  void backwardAll(bool reuse) {
    const int depth = static_cast<int>(sizes.size()) - 1;
    for (int l = 0; l < depth; ++l) {
      cuda_detail::launchFill<S>(static_cast<S*>(dW[l]), S(0), static_cast<long long>(sizes[l + 1]) * sizes[l], stream);
      cuda_detail::launchFill<S>(static_cast<S*>(db[l]), S(0), sizes[l + 1], stream);
    }
    for (long long c0 = 0; c0 < static_cast<long long>(n); c0 += block) {
      const int bs = static_cast<int>(std::min<long long>(block, static_cast<long long>(n) - c0));
      if (reuse)
        pointAt<S>(c0);
      else
        forwardBlock<S>(c0, bs);                    // the block's activations
      const S* d = static_cast<const S*>(ds) + c0;  // dL/dz of the linear output
      for (int l = depth - 1; l >= 0; --l) {
        // dL/dW_l += δ H_lᵀ, dL/db_l += δ 1.
        checkBlas(gemm<S>(handle, CUBLAS_OP_N, CUBLAS_OP_T, sizes[l + 1], sizes[l], bs, S(1), d, sizes[l + 1],
                          static_cast<const S*>(H[l]), sizes[l], S(1), static_cast<S*>(dW[l]), sizes[l + 1]),
                  "GEMM (weight gradient)");
        checkBlas(gemv<S>(handle, sizes[l + 1], bs, S(1), d, sizes[l + 1], static_cast<const S*>(ones), S(1),
                          static_cast<S*>(db[l])),
                  "GEMV (bias gradient)");
        if (l == 0) break;
        // δ ← (W_lᵀ δ) ⊙ [H_l > 0].
        checkBlas(
            gemm<S>(handle, CUBLAS_OP_T, CUBLAS_OP_N, sizes[l], bs, sizes[l + 1], S(1), static_cast<const S*>(W[l]),
                    sizes[l + 1], d, sizes[l + 1], S(0), static_cast<S*>(back), sizes[l]),
            "GEMM (backward)");
        S* nd = static_cast<S*>(d == delta ? Z : delta);  // ping-pong between two buffers
        cuda_detail::launchReluMask<S>(nd, static_cast<const S*>(back), static_cast<const S*>(H[l]),
                                       static_cast<long long>(sizes[l]) * bs, stream);
        d = nd;
      }
    }
    check(cudaGetLastError(), "kernel launch");
  }
};

MlpCuda::MlpCuda(const std::vector<int>& sizes, const Eigen::Matrix3Xd& U, CudaPrecision precision, MlpMath math)
    : impl_(std::make_unique<Impl>()) {
  if (math == MlpMath::Tf32 && precision == CudaPrecision::Float64)
    throw TopoError("CUDA MLP", "TF32 tensor-core math asked for with float64", "use Float32 with MlpMath::Tf32");
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) throw TopoError("CUDA MLP", info.reason, "use backend cpu (or auto) on this machine");
  if (!cublas().error.empty())
    throw TopoError("CUDA MLP", cublas().error, "install cuBLAS with the CUDA toolkit, or use backend cpu");
  if (sizes.size() < 2 || sizes.front() != 3 || sizes.back() != 1 ||
      std::any_of(sizes.begin(), sizes.end(), [](int s) { return s < 1; }))
    throw TopoError("CUDA MLP", "layer sizes must run from 3 to 1 with positive widths", "e.g. {3, 512, 512, 1}");
  if (U.cols() < 1) throw TopoError("CUDA MLP", "no input points", "pass the normalised particle coordinates");
  Impl& I = *impl_;
  I.sizes = sizes;
  I.n = static_cast<std::size_t>(U.cols());
  I.precision = precision;
  I.math = math;
  I.widest = *std::max_element(sizes.begin(), sizes.end());
  I.block = std::min<long long>(kBlockPoints, static_cast<long long>(I.n));
  const int depth = static_cast<int>(sizes.size()) - 1;
  double params = 0.0;
  for (int l = 0; l < depth; ++l) params += double(sizes[l + 1]) * (sizes[l] + 1);
  // U and s, ds; weights and gradients; per block: the activations and three work arrays.
  const double bytes =
      double(I.T()) * (5.0 * I.n + 2.0 * params + double(I.block) * (double(depth) * I.widest + 3.0 * I.widest + 1.0));
  requireDeviceMemory("CUDA MLP (" + std::to_string(I.n) + " points, " + std::to_string(depth) + " layers)", bytes,
                      bytes / double(I.n));
  check(cudaSetDevice(info.device), "cudaSetDevice");
  check(cudaStreamCreateWithFlags(&I.stream, cudaStreamNonBlocking), "stream creation");
  checkBlas(cublas().create(&I.handle), "cublasCreate");
  checkBlas(cublas().setStream(I.handle, I.stream), "cublasSetStream");
  checkBlas(cublas().setMathMode(I.handle, math == MlpMath::Tf32 ? CUBLAS_TF32_TENSOR_OP_MATH : CUBLAS_DEFAULT_MATH),
            "cublasSetMathMode");
  const std::size_t T = I.T();
  I.U = I.alloc(3 * I.n * T);
  if (precision == CudaPrecision::Float64)
    I.upload<double>(I.U, U.data(), 3 * I.n);
  else
    I.upload<float>(I.U, U.data(), 3 * I.n);
  I.s = I.alloc(I.n * T);
  I.ds = I.alloc(I.n * T);
  I.H.assign(depth, nullptr);
  for (int l = 0; l < depth; ++l) {
    I.W.push_back(I.alloc(std::size_t(sizes[l + 1]) * sizes[l] * T));
    I.b.push_back(I.alloc(std::size_t(sizes[l + 1]) * T));
    I.dW.push_back(I.alloc(std::size_t(sizes[l + 1]) * sizes[l] * T));
    I.db.push_back(I.alloc(std::size_t(sizes[l + 1]) * T));
    if (l > 0) I.H[l] = I.alloc(std::size_t(sizes[l]) * I.block * T);
  }
  I.Z = I.alloc(std::size_t(I.widest) * I.block * T);
  I.delta = I.alloc(std::size_t(I.widest) * I.block * T);
  I.back = I.alloc(std::size_t(I.widest) * I.block * T);
  I.ones = I.alloc(std::size_t(I.block) * T);
  I.pinned_bytes = T * std::max<std::size_t>(I.n, static_cast<std::size_t>(params));
  check(cudaMallocHost(&I.pinned, I.pinned_bytes), "cudaMallocHost (pinned staging)");
  // Every activation kept (for the backward after a forward at the same weights) when it takes less
  // than half of the free memory: one GEMM pass per layer fewer.
  {
    double hidden = 0.0;
    for (int l = 1; l < depth; ++l) hidden += sizes[l];
    const double act = double(T) * double(I.n) * hidden;
    std::size_t free_b = 0, total_b = 0;
    if (cudaMemGetInfo(&free_b, &total_b) == cudaSuccess && act < 0.5 * double(free_b)) {
      I.Hall.assign(depth, nullptr);
      for (int l = 1; l < depth; ++l) I.Hall[l] = I.alloc(std::size_t(sizes[l]) * I.n * T);
      I.keep_all = true;
    }
  }
  if (precision == CudaPrecision::Float64)
    cuda_detail::launchFill<double>(static_cast<double*>(I.ones), 1.0, I.block, I.stream);
  else
    cuda_detail::launchFill<float>(static_cast<float*>(I.ones), 1.0f, I.block, I.stream);
  check(cudaStreamSynchronize(I.stream), "setup");
}

MlpCuda::~MlpCuda() = default;
std::size_t MlpCuda::points() const { return impl_->n; }
CudaPrecision MlpCuda::precision() const { return impl_->precision; }
MlpMath MlpCuda::math() const { return impl_->math; }

void MlpCuda::forward(const std::vector<Eigen::MatrixXd>& W, const std::vector<Eigen::VectorXd>& b,
                      std::vector<double>* s) {
  Impl& I = *impl_;
  s->resize(I.n);
  if (I.precision == CudaPrecision::Float64) {
    I.setWeights<double>(W, b);
    I.forwardAll<double>();
    I.downloadPoints<double>(I.s, s->data());
  } else {
    I.setWeights<float>(W, b);
    I.forwardAll<float>();
    I.downloadPoints<float>(I.s, s->data());
  }
}

namespace {
/// dL/dW and dL/db for dL/ds: from the kept activations (reuse) or with a forward per block.
template <class S>
void gradients(MlpCuda::Impl& I, const std::vector<double>& dL_ds, bool reuse, std::vector<Eigen::MatrixXd>* dW,
               std::vector<Eigen::VectorXd>* db) {
  if (dL_ds.size() != I.n)
    throw TopoError("CUDA MLP",
                    std::to_string(dL_ds.size()) + " values of dL/ds for " + std::to_string(I.n) + " points",
                    "pass one per point");
  if (!reuse) check(cudaStreamSynchronize(I.stream), "weight upload");  // the pinned buffer is free again
  I.uploadPoints<S>(I.ds, dL_ds.data());
  I.backwardAll<S>(reuse);
  I.downloadGradients<S>(dW, db);
}
}  // namespace

void MlpCuda::backward(const std::vector<Eigen::MatrixXd>& W, const std::vector<Eigen::VectorXd>& b,
                       const std::vector<double>& dL_ds, std::vector<Eigen::MatrixXd>* dW,
                       std::vector<Eigen::VectorXd>* db) {
  Impl& I = *impl_;
  if (I.precision == CudaPrecision::Float64) {
    I.setWeights<double>(W, b);
    gradients<double>(I, dL_ds, false, dW, db);
  } else {
    I.setWeights<float>(W, b);
    gradients<float>(I, dL_ds, false, dW, db);
  }
}

bool MlpCuda::backwardAfterForward(const std::vector<double>& dL_ds, std::vector<Eigen::MatrixXd>* dW,
                                   std::vector<Eigen::VectorXd>* db) {
  Impl& I = *impl_;
  if (!I.kept) return false;
  if (I.precision == CudaPrecision::Float64)
    gradients<double>(I, dL_ds, true, dW, db);
  else
    gradients<float>(I, dL_ds, true, dW, db);
  return true;
}

#else  // no CUDA in this build

struct MlpCuda::Impl {};
MlpCuda::MlpCuda(const std::vector<int>&, const Eigen::Matrix3Xd&, CudaPrecision, MlpMath) {
  throw TopoError("CUDA MLP", cudaDeviceInfo().reason, "use backend cpu (or auto), or rebuild with nvcc");
}
MlpCuda::~MlpCuda() = default;
std::size_t MlpCuda::points() const { return 0; }
CudaPrecision MlpCuda::precision() const { return CudaPrecision::Float64; }
MlpMath MlpCuda::math() const { return MlpMath::Exact; }
void MlpCuda::forward(const std::vector<Eigen::MatrixXd>&, const std::vector<Eigen::VectorXd>&, std::vector<double>*) {}
void MlpCuda::backward(const std::vector<Eigen::MatrixXd>&, const std::vector<Eigen::VectorXd>&,
                       const std::vector<double>&, std::vector<Eigen::MatrixXd>*, std::vector<Eigen::VectorXd>*) {}
bool MlpCuda::backwardAfterForward(const std::vector<double>&, std::vector<Eigen::MatrixXd>*,
                                   std::vector<Eigen::VectorXd>*) {
  return false;
}

#endif

}  // namespace topo_gaussian
