// Dense Cholesky on the GPU; see include/topo_gaussian/cuda/dense_cholesky_cuda.h.
#include "topo_gaussian/cuda/dense_cholesky_cuda.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"

#if TOPO_HAVE_CUDA
#include <cublas_v2.h>
#include <cuda_runtime_api.h>
#include <cusolverDn.h>
#include "cuda_library.h"
#include "dense_cholesky_kernels.h"
#include "soft_body_cuda_impl.h"  // check, DeviceBuffer
#endif

namespace topo_gaussian {

double denseCholeskyBytes(std::size_t unknowns) {
  const double n = static_cast<double>(unknowns);
  return 8.0 * n * n;
}

long denseCholeskyInverseFactorBreakEven(std::size_t unknowns) {
  return static_cast<long>(std::ceil(48.0 * static_cast<double>(unknowns) / 27636.0));
}

std::size_t denseCholeskyParticlesFitting(double bytes) {
  return bytes > 0.0 ? static_cast<std::size_t>(std::sqrt(bytes / 8.0) / 3.0) : 0;
}

long denseCholeskyInverseBreakEven(std::size_t unknowns) {
  return static_cast<long>(std::ceil(180.0 * static_cast<double>(unknowns) / 27636.0));
}

#if TOPO_HAVE_CUDA

std::string denseCholeskyRefusal(std::size_t unknowns, double lower_nonzeros, double max_bytes) {
  const CudaDeviceInfo& dev = cudaDeviceInfo();
  if (!dev.available) return "no CUDA device: " + dev.reason;
  // the factor, the sparse triangle while it is scattered (12 bytes an entry), 64 MiB of workspace
  const double need = denseCholeskyBytes(unknowns) + 12.0 * lower_nonzeros + double(64 << 20);
  std::size_t free_b = 0, total_b = 0;
  if (cudaMemGetInfo(&free_b, &total_b) != cudaSuccess) {
    cudaGetLastError();
    return "the CUDA runtime could not report the GPU's free memory";
  }
  double usable = 0.9 * static_cast<double>(free_b);
  if (max_bytes > 0.0) usable = std::min(usable, max_bytes);
  if (need <= usable) return "";
  std::ostringstream s;
  s << "a dense factor of " << unknowns << " unknowns (" << unknowns / 3 << " particles) needs "
    << static_cast<long long>(need / (1024.0 * 1024.0)) << " MiB on " << dev.name << " but "
    << static_cast<long long>(usable / (1024.0 * 1024.0)) << " MiB are usable ("
    << static_cast<long long>(free_b / (1024.0 * 1024.0)) << " MiB free): about "
    << denseCholeskyParticlesFitting(usable) << " particles would fit";
  return s.str();
}

namespace {

/// The cuSOLVER functions used here, resolved once from libcusolver.
struct Cusolver {
  cusolverStatus_t (*create)(cusolverDnHandle_t*) = nullptr;
  cusolverStatus_t (*destroy)(cusolverDnHandle_t) = nullptr;
  cusolverStatus_t (*setStream)(cusolverDnHandle_t, cudaStream_t) = nullptr;
  cusolverStatus_t (*createParams)(cusolverDnParams_t*) = nullptr;
  cusolverStatus_t (*destroyParams)(cusolverDnParams_t) = nullptr;
  cusolverStatus_t (*potrfBufferSize)(cusolverDnHandle_t, cusolverDnParams_t, cublasFillMode_t, int64_t, cudaDataType,
                                      const void*, int64_t, cudaDataType, size_t*, size_t*) = nullptr;
  cusolverStatus_t (*potrf)(cusolverDnHandle_t, cusolverDnParams_t, cublasFillMode_t, int64_t, cudaDataType, void*,
                            int64_t, cudaDataType, void*, size_t, void*, size_t, int*) = nullptr;
  cusolverStatus_t (*potrs)(cusolverDnHandle_t, cusolverDnParams_t, cublasFillMode_t, int64_t, int64_t, cudaDataType,
                            const void*, int64_t, cudaDataType, void*, int64_t, int*) = nullptr;
  cusolverStatus_t (*potriBufferSize)(cusolverDnHandle_t, cublasFillMode_t, int, double*, int, int*) = nullptr;
  cusolverStatus_t (*potri)(cusolverDnHandle_t, cublasFillMode_t, int, double*, int, double*, int, int*) = nullptr;
  cusolverStatus_t (*trtriBufferSize)(cusolverDnHandle_t, cublasFillMode_t, cublasDiagType_t, int64_t, cudaDataType,
                                      void*, int64_t, size_t*, size_t*) = nullptr;
  cusolverStatus_t (*trtri)(cusolverDnHandle_t, cublasFillMode_t, cublasDiagType_t, int64_t, cudaDataType, void*,
                            int64_t, void*, size_t, void*, size_t, int*) = nullptr;
  std::string error;
};

/// The cuBLAS products of the explicit inverse (DenseCholeskyApply::Inverse*), resolved once.
struct CublasMv {
  cublasStatus_t (*create)(cublasHandle_t*) = nullptr;
  cublasStatus_t (*destroy)(cublasHandle_t) = nullptr;
  cublasStatus_t (*setStream)(cublasHandle_t, cudaStream_t) = nullptr;
  cublasStatus_t (*dsymv)(cublasHandle_t, cublasFillMode_t, int, const double*, const double*, int, const double*, int,
                          const double*, double*, int) = nullptr;
  cublasStatus_t (*dgemv)(cublasHandle_t, cublasOperation_t, int, int, const double*, const double*, int, const double*,
                          int, const double*, double*, int) = nullptr;
  cublasStatus_t (*dtrmm)(cublasHandle_t, cublasSideMode_t, cublasFillMode_t, cublasOperation_t, cublasDiagType_t, int,
                          int, const double*, const double*, int, const double*, int, double*, int) = nullptr;
  std::string error;
};

using cuda_detail::resolveSymbol;

const Cusolver& cusolver() {
  static const Cusolver c = [] {
    Cusolver c;
    void* lib = cuda_detail::openCudaLibrary({"libcusolver.so.12", "libcusolver.so.11", "libcusolver.so"}, &c.error);
    if (!lib) return c;
    const bool ok =
        resolveSymbol(lib, "cusolverDnCreate", &c.create) && resolveSymbol(lib, "cusolverDnDestroy", &c.destroy) &&
        resolveSymbol(lib, "cusolverDnSetStream", &c.setStream) &&
        resolveSymbol(lib, "cusolverDnCreateParams", &c.createParams) &&
        resolveSymbol(lib, "cusolverDnDestroyParams", &c.destroyParams) &&
        resolveSymbol(lib, "cusolverDnXpotrf_bufferSize", &c.potrfBufferSize) &&
        resolveSymbol(lib, "cusolverDnXpotrf", &c.potrf) && resolveSymbol(lib, "cusolverDnXpotrs", &c.potrs);
    if (!ok) c.error = "libcusolver lacks the 64-bit potrf/potrs API (a cuSOLVER older than CUDA 11.1?)";
    resolveSymbol(lib, "cusolverDnDpotri_bufferSize", &c.potriBufferSize);
    resolveSymbol(lib, "cusolverDnDpotri", &c.potri);
    resolveSymbol(lib, "cusolverDnXtrtri_bufferSize", &c.trtriBufferSize);
    resolveSymbol(lib, "cusolverDnXtrtri", &c.trtri);
    return c;
  }();
  return c;
}

const CublasMv& cublasMv() {
  static const CublasMv c = [] {
    CublasMv c;
    void* lib = cuda_detail::openCudaLibrary({"libcublas.so.13", "libcublas.so.12", "libcublas.so"}, &c.error);
    if (!lib) return c;
    const bool ok = resolveSymbol(lib, "cublasCreate_v2", &c.create) &&
                    resolveSymbol(lib, "cublasDestroy_v2", &c.destroy) &&
                    resolveSymbol(lib, "cublasSetStream_v2", &c.setStream) &&
                    resolveSymbol(lib, "cublasDsymv_v2", &c.dsymv) && resolveSymbol(lib, "cublasDgemv_v2", &c.dgemv);
    if (!ok) c.error = "libcublas lacks cublasDsymv_v2 or cublasDgemv_v2";
    resolveSymbol(lib, "cublasDtrmm_v2", &c.dtrmm);  // the float32 inverse factor's blocks (optional)
    return c;
  }();
  return c;
}

constexpr const char* kInput = "GPU dense Cholesky";
constexpr long long kTrtriLeaf = 1024;  // the float32 inverse factor's diagonal blocks inverted by cusolverDnXtrtri
// invertLowerBlocks' cublasDtrmm blocks reach n²/2 elements from their start: within 32 bits up to here
constexpr long long kInverseFactorMaxUnknowns = 65535;

const char* const kMemoryFix =
    "use a coarser particle spacing, free the GPU, or use backend cpu (backend auto factorises on the host)";

void checkSolver(cusolverStatus_t s, const char* what) {
  if (s != CUSOLVER_STATUS_SUCCESS)
    throw TopoError("GPU dense Cholesky",
                    std::string(what) + " failed with cuSOLVER status " + std::to_string(static_cast<int>(s)),
                    "check the GPU's free memory; backend cpu factorises on the host");
}

class DenseCholeskyCuda : public CholeskySolver {
 public:
  DenseCholeskyCuda(double max_bytes, DenseCholeskyApply apply, long inverse_after, DenseCholeskyApply inverse_as)
      : max_bytes_(max_bytes),
        apply_(apply),
        inverse_after_(apply == DenseCholeskyApply::Triangular ? inverse_after : 0),
        inverse_as_(inverse_as == DenseCholeskyApply::Triangular ? DenseCholeskyApply::InverseGemv : inverse_as) {}
  ~DenseCholeskyCuda() override {
    if (blas_) cublasMv().destroy(blas_);
    if (params_) cusolver().destroyParams(params_);
    if (handle_) cusolver().destroy(handle_);
    if (stream_) cudaStreamDestroy(stream_);
    if (pinned_) cudaFreeHost(pinned_);
  }

  bool factorize(const Eigen::SparseMatrix<double>& lower) override {
    factored_ = false;
    release();  // an earlier factor's memory is not counted against this one
    if (inverse_after_ > 0) apply_ = DenseCholeskyApply::Triangular;
    applications_ = 0;
    extra_seconds_ = 0.0;
    const CudaDeviceInfo& dev = cudaDeviceInfo();
    if (!dev.available)
      throw TopoError("GPU dense Cholesky", "no CUDA device: " + dev.reason,
                      "use backend cpu or auto (the host's sparse Cholesky)");
    if (!cusolver().error.empty())
      throw TopoError("GPU dense Cholesky", cusolver().error,
                      "install the CUDA toolkit's cuSOLVER (it comes with CUDA), or use backend cpu or auto");
    const std::string refused =
        denseCholeskyRefusal(static_cast<std::size_t>(lower.rows()), static_cast<double>(lower.nonZeros()), max_bytes_);
    if (!refused.empty()) throw GpuMemoryError("GPU dense Cholesky", refused, kMemoryFix);
    n_ = lower.rows();
    const Cusolver& cs = cusolver();
    if (!stream_) {
      check(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate", kInput);
      checkSolver(cs.create(&handle_), "cusolverDnCreate");
      checkSolver(cs.setStream(handle_, stream_), "cusolverDnSetStream");
      checkSolver(cs.createParams(&params_), "cusolverDnCreateParams");
    }
    A_.allocate(static_cast<std::size_t>(denseCholeskyBytes(static_cast<std::size_t>(n_))), kInput);
    check(cudaMemsetAsync(A_.ptr, 0, A_.bytes, stream_), "cudaMemset", kInput);
    {
      Eigen::SparseMatrix<double> copy;  // only an uncompressed matrix is copied (rest_stiffness.cpp's is compressed)
      if (!lower.isCompressed()) {
        copy = lower;
        copy.makeCompressed();
      }
      const Eigen::SparseMatrix<double>& L = lower.isCompressed() ? lower : copy;
      const long long nnz = L.nonZeros();
      cuda_detail::DeviceBuffer outer, inner, values;
      outer.allocate(sizeof(int) * static_cast<std::size_t>(n_ + 1), kInput);
      inner.allocate(sizeof(int) * static_cast<std::size_t>(nnz), kInput);
      values.allocate(sizeof(double) * static_cast<std::size_t>(nnz), kInput);
      check(cudaMemcpyAsync(outer.ptr, L.outerIndexPtr(), outer.bytes, cudaMemcpyHostToDevice, stream_), "upload",
            kInput);
      check(cudaMemcpyAsync(inner.ptr, L.innerIndexPtr(), inner.bytes, cudaMemcpyHostToDevice, stream_), "upload",
            kInput);
      check(cudaMemcpyAsync(values.ptr, L.valuePtr(), values.bytes, cudaMemcpyHostToDevice, stream_), "upload", kInput);
      cuda_detail::launchScatterLowerCsc(n_, static_cast<const int*>(outer.ptr), static_cast<const int*>(inner.ptr),
                                         static_cast<const double*>(values.ptr), static_cast<double*>(A_.ptr), stream_);
      check(cudaGetLastError(), "scatter kernel", kInput);
      check(cudaStreamSynchronize(stream_), "scatter", kInput);
    }
    std::size_t dev_ws = 0, host_ws = 0;
    checkSolver(cs.potrfBufferSize(handle_, params_, CUBLAS_FILL_MODE_LOWER, n_, CUDA_R_64F, A_.ptr, n_, CUDA_R_64F,
                                   &dev_ws, &host_ws),
                "cusolverDnXpotrf_bufferSize");
    cuda_detail::DeviceBuffer work;
    work.allocate(std::max<std::size_t>(dev_ws, 8), kInput);
    std::vector<char> host_work(std::max<std::size_t>(host_ws, 8));
    if (!info_.ptr) info_.allocate(sizeof(int), kInput);
    checkSolver(cs.potrf(handle_, params_, CUBLAS_FILL_MODE_LOWER, n_, CUDA_R_64F, A_.ptr, n_, CUDA_R_64F, work.ptr,
                         dev_ws, host_work.data(), host_ws, static_cast<int*>(info_.ptr)),
                "cusolverDnXpotrf");
    const int info = infoAfter("cusolverDnXpotrf");
    if (info < 0)
      throw TopoError("GPU dense Cholesky", "cusolverDnXpotrf rejected its argument " + std::to_string(-info),
                      "report this: the matrix of " + std::to_string(n_) + " unknowns was passed wrongly");
    if (info > 0) return false;  // not positive definite (leading minor `info`): the caller refuses it
    if (apply_ != DenseCholeskyApply::Triangular) {
      prepareInverse(cs, &work, apply_);
      invertInPlace(cs, work, apply_);
    }
    if (!pinned_)
      check(cudaMallocHost(&pinned_, sizeof(double) * static_cast<std::size_t>(n_)), "cudaMallocHost", kInput);
    if (!rhs_.ptr) rhs_.allocate(sizeof(double) * static_cast<std::size_t>(n_), kInput);
    if (!out_.ptr) out_.allocate(sizeof(double) * static_cast<std::size_t>(n_), kInput);
    nameFactor();
    factored_ = true;
    return true;
  }

  void nameFactor() {
    name_ = std::string("dense Cholesky (cuSOLVER, float64") +
            (apply_ == DenseCholeskyApply::Triangular             ? ""
             : apply_ == DenseCholeskyApply::InverseFactorFloat32 ? ", explicit inverse factor in float32"
                                                                  : ", explicit inverse") +
            (inverse_after_ > 0 && apply_ != DenseCholeskyApply::Triangular
                 ? " after " + std::to_string(inverse_after_) + " triangular solves"
                 : "") +
            (not_inverted_.empty() ? "" : "; its inverse was not made: " + not_inverted_) + ") on " +
            cudaDeviceInfo().name;
  }

  /// The triangular solves' factor inverted in place, the inverse applied from now on (inverse_after).
  void takeTheInverse() {
    const auto t0 = std::chrono::steady_clock::now();
    cuda_detail::DeviceBuffer work;
    try {
      prepareInverse(cusolver(), &work, inverse_as_);  // nothing is changed yet: on failure the triangular solves go on
    } catch (const TopoError& e) {
      releaseInverse();
      inverse_after_ = 0;
      not_inverted_ = e.what();
      nameFactor();
      return;
    }
    try {
      invertInPlace(cusolver(), work, inverse_as_);
    } catch (...) {
      factored_ = false;  // the factor is overwritten: no further solve with it
      releaseInverse();
      throw;
    }
    apply_ = inverse_as_;
    extra_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    nameFactor();
  }

  /// What the explicit inverse needs before the factor is overwritten: potri (or trtri) and cuBLAS, at
  /// most 46 340 unknowns for potri, the cuBLAS handle, the workspace, and for the float32 inverse factor
  /// its matrix and the products' work space. Throws TopoError with the reason.
  void prepareInverse(const Cusolver& cs, cuda_detail::DeviceBuffer* work, DenseCholeskyApply mode) {
    if (mode == DenseCholeskyApply::InverseFactorFloat32) {
      if (!cs.trtri || !cs.trtriBufferSize || !cublasMv().error.empty() || !cublasMv().dtrmm)
        throw TopoError("GPU dense Cholesky",
                        "this CUDA lacks cusolverDnXtrtri (a cuSOLVER older than CUDA 11.4?) or cublasDtrmm" +
                            (cublasMv().error.empty() ? std::string() : ": " + cublasMv().error),
                        "use the triangular solves (DenseCholeskyApply::Triangular)");
      if (n_ > kInverseFactorMaxUnknowns)
        throw TopoError("GPU dense Cholesky",
                        "the float32 inverse factor takes at most " + std::to_string(kInverseFactorMaxUnknowns) +
                            " unknowns (cuBLAS's 32-bit dimensions), not " + std::to_string(n_),
                        "use the triangular solves (DenseCholeskyApply::Triangular)");
      const auto ld = static_cast<std::size_t>(cuda_detail::inverseFactorLeadingDimension(n_));
      const std::size_t f_bytes = sizeof(float) * static_cast<std::size_t>(n_) * ld;
      const std::size_t p_bytes = sizeof(double) * static_cast<std::size_t>(cuda_detail::inverseFactorChunks(n_)) * ld;
      const std::size_t y_bytes = sizeof(double) * ld;
      const double need = static_cast<double>(f_bytes + p_bytes + y_bytes);
      std::size_t free_b = 0, total_b = 0;
      if (cudaMemGetInfo(&free_b, &total_b) != cudaSuccess) {
        cudaGetLastError();
        throw TopoError("GPU dense Cholesky", "the CUDA runtime could not report the GPU's free memory",
                        "check the GPU (the triangular solves go on meanwhile)");
      }
      if (need > 0.95 * static_cast<double>(free_b))
        throw GpuMemoryError("GPU dense Cholesky",
                             "the float32 inverse factor needs " +
                                 std::to_string(static_cast<long long>(need / 1048576.0)) +
                                 " MiB beside the float64 factor while it is made, and " +
                                 std::to_string(static_cast<long long>(free_b / 1048576)) + " MiB are free",
                             "free the GPU or use a coarser particle spacing (the triangular solves go on meanwhile)");
      makeBlasHandle();
      std::size_t dev_ws = 0, host_ws = 0;
      checkSolver(cs.trtriBufferSize(handle_, CUBLAS_FILL_MODE_LOWER, CUBLAS_DIAG_NON_UNIT,
                                     std::min<long long>(n_, kTrtriLeaf), CUDA_R_64F, A_.ptr, n_, &dev_ws, &host_ws),
                  "cusolverDnXtrtri_bufferSize");
      if (work->bytes < std::max<std::size_t>(dev_ws, 8)) work->allocate(std::max<std::size_t>(dev_ws, 8), kInput);
      trtri_host_.assign(std::max<std::size_t>(host_ws, 8), 0);
      F_.allocate(f_bytes, kInput);
      P_.allocate(p_bytes, kInput);
      y_.allocate(y_bytes, kInput);
      return;
    }
    if (!cs.potri || !cs.potriBufferSize || !cublasMv().error.empty())
      throw TopoError("GPU dense Cholesky", "this CUDA lacks cusolverDnDpotri or cuBLAS: " + cublasMv().error,
                      "use the triangular solves (DenseCholeskyApply::Triangular)");
    if (n_ > 46340)
      throw TopoError("GPU dense Cholesky", "the explicit inverse takes at most 46340 unknowns (32-bit potri)",
                      "use the triangular solves (DenseCholeskyApply::Triangular)");
    makeBlasHandle();
    const int n = static_cast<int>(n_);
    int lwork = 0;
    checkSolver(cs.potriBufferSize(handle_, CUBLAS_FILL_MODE_LOWER, n, static_cast<double*>(A_.ptr), n, &lwork),
                "cusolverDnDpotri_bufferSize");
    lwork_ = std::max(lwork, 1);
    if (work->bytes < sizeof(double) * static_cast<std::size_t>(lwork_))
      work->allocate(sizeof(double) * static_cast<std::size_t>(lwork_), kInput);
  }

  /// The solver's info once the stream has finished `what` (which named it on a failed synchronisation).
  int infoAfter(const char* what) const {
    int info = 0;
    check(cudaMemcpyAsync(&info, info_.ptr, sizeof(int), cudaMemcpyDeviceToHost, stream_), "download", kInput);
    check(cudaStreamSynchronize(stream_), what, kInput);
    return info;
  }

  /// Throws TopoError when the inversion `what` (potri, trtri) reported a nonzero info.
  void requireInverted(const char* what) const {
    const int info = infoAfter(what);
    if (info != 0)
      throw TopoError("GPU dense Cholesky",
                      std::string("the inverse failed (") + what + " info " + std::to_string(info) + ")",
                      "use the triangular solves (DenseCholeskyApply::Triangular)");
  }

  void makeBlasHandle() {
    if (blas_) return;
    if (cublasMv().create(&blas_) != CUBLAS_STATUS_SUCCESS)
      throw TopoError("GPU dense Cholesky", "cublasCreate failed", "check the GPU's free memory");
    if (cublasMv().setStream(blas_, stream_) != CUBLAS_STATUS_SUCCESS)
      throw TopoError("GPU dense Cholesky", "cublasSetStream failed", "check the GPU's free memory");
  }

  /// L⁻¹ in place of the lower triangle's diagonal block [off, off + m) (column-major, lda n_), by halves:
  /// L = [A 0; B C] has L⁻¹ = [A⁻¹ 0; −C⁻¹ B A⁻¹ C⁻¹], so A and C are inverted (recursively) and B is
  /// multiplied by the inverted triangles (cublasDtrmm in place, ~(m/2)³ flops each: the FP64 tensor
  /// cores' GEMM); blocks of at most kTrtriLeaf by cusolverDnXtrtri, whose whole-matrix call is about three
  /// times slower (bench/gpu/README.md). Its info is checked after every block.
  void invertLowerBlocks(const cuda_detail::DeviceBuffer& work, long long off, long long m) {
    double* A = static_cast<double*>(A_.ptr);
    const long long n = n_;
    if (m <= kTrtriLeaf) {
      checkSolver(
          cusolver().trtri(handle_, CUBLAS_FILL_MODE_LOWER, CUBLAS_DIAG_NON_UNIT, m, CUDA_R_64F, A + off + off * n, n,
                           work.ptr, work.bytes, trtri_host_.data(), trtri_host_.size(), static_cast<int*>(info_.ptr)),
          "cusolverDnXtrtri");
      requireInverted("cusolverDnXtrtri");
      return;
    }
    const long long k = (m / 2 + 63) / 64 * 64;
    double* B = A + (off + k) + off * n;  // (m − k) × k
    const double one = 1.0, minus_one = -1.0;
    const int rows = static_cast<int>(m - k), cols = static_cast<int>(k), ld = static_cast<int>(n);
    invertLowerBlocks(work, off, k);
    checkBlas(cublasMv().dtrmm(blas_, CUBLAS_SIDE_RIGHT, CUBLAS_FILL_MODE_LOWER, CUBLAS_OP_N, CUBLAS_DIAG_NON_UNIT,
                               rows, cols, &one, A + off + off * n, ld, B, ld, B, ld),
              "cublasDtrmm");
    invertLowerBlocks(work, off + k, m - k);
    checkBlas(cublasMv().dtrmm(blas_, CUBLAS_SIDE_LEFT, CUBLAS_FILL_MODE_LOWER, CUBLAS_OP_N, CUBLAS_DIAG_NON_UNIT, rows,
                               cols, &minus_one, A + (off + k) + (off + k) * n, ld, B, ld, B, ld),
              "cublasDtrmm");
  }

  static void checkBlas(cublasStatus_t st, const char* what) {
    if (st != CUBLAS_STATUS_SUCCESS)
      throw TopoError("GPU dense Cholesky", std::string(what) + " failed with cuBLAS status " + std::to_string(st),
                      "check the GPU's free memory; use the triangular solves (DenseCholeskyApply::Triangular)");
  }

  /// A⁻¹ from the factor in place (potri: its lower triangle), the upper mirrored for InverseGemv; or
  /// L⁻¹ in place (invertLowerBlocks), rounded into F_ as L̃⁻ᵀ's rows, and the float64 matrix freed.
  void invertInPlace(const Cusolver& cs, const cuda_detail::DeviceBuffer& work, DenseCholeskyApply mode) {
    const int n = static_cast<int>(n_);
    const char* what = "cusolverDnDpotri";
    if (mode == DenseCholeskyApply::InverseFactorFloat32) {
      what = "cusolverDnXtrtri";
      invertLowerBlocks(work, 0, n_);
      cuda_detail::launchInverseFactorToFloat(n_, static_cast<const double*>(A_.ptr), static_cast<float*>(F_.ptr),
                                              stream_);
      check(cudaGetLastError(), "float32 copy kernel", kInput);
    } else {
      checkSolver(cs.potri(handle_, CUBLAS_FILL_MODE_LOWER, n, static_cast<double*>(A_.ptr), n,
                           static_cast<double*>(work.ptr), lwork_, static_cast<int*>(info_.ptr)),
                  what);
      if (mode == DenseCholeskyApply::InverseGemv) {
        cuda_detail::launchMirrorLower(n_, static_cast<double*>(A_.ptr), stream_);
        check(cudaGetLastError(), "mirror kernel", kInput);
      }
    }
    requireInverted(what);
    if (mode == DenseCholeskyApply::InverseFactorFloat32) A_.free();  // F_ holds all that is applied now
  }

  /// The float32 inverse factor and its work space.
  void releaseInverse() {
    F_.free();
    P_.free();
    y_.free();
    trtri_host_.clear();
  }

  /// The device and pinned memory of an earlier factorisation.
  void release() {
    A_.free();
    releaseInverse();
    rhs_.free();
    out_.free();
    if (pinned_) cudaFreeHost(pinned_);
    pinned_ = nullptr;
  }

  void solve(const Eigen::VectorXd& r, Eigen::VectorXd* z) const override {
    if (!factored_)
      throw TopoError("GPU dense Cholesky", "solve() without a factor (the last factorize() failed or was not called)",
                      "factorise first");
    if (r.size() != n_)
      throw TopoError(
          "GPU dense Cholesky",
          "right-hand side of " + std::to_string(r.size()) + " entries for " + std::to_string(n_) + " unknowns",
          "factorise the matching matrix first");
    // Logically const: the inverse replaces the factor in place and applies the same A⁻¹.
    if (inverse_after_ > 0 && apply_ == DenseCholeskyApply::Triangular && ++applications_ > inverse_after_)
      const_cast<DenseCholeskyCuda*>(this)->takeTheInverse();
    const std::size_t bytes = sizeof(double) * static_cast<std::size_t>(n_);
    std::copy(r.data(), r.data() + n_, static_cast<double*>(pinned_));
    check(cudaMemcpyAsync(rhs_.ptr, pinned_, bytes, cudaMemcpyHostToDevice, stream_), "upload", kInput);
    void* result = rhs_.ptr;
    const double one = 1.0, zero = 0.0;
    const int n = static_cast<int>(n_);
    if (apply_ == DenseCholeskyApply::InverseFactorFloat32) {
      cuda_detail::launchInverseFactorApply(n_, static_cast<const float*>(F_.ptr), static_cast<const double*>(rhs_.ptr),
                                            static_cast<double*>(P_.ptr), static_cast<double*>(y_.ptr),
                                            static_cast<double*>(out_.ptr), stream_);
      check(cudaGetLastError(), "the inverse factor's product kernels", kInput);
      result = out_.ptr;
    } else if (apply_ == DenseCholeskyApply::Triangular) {
      checkSolver(cusolver().potrs(handle_, params_, CUBLAS_FILL_MODE_LOWER, n_, 1, CUDA_R_64F, A_.ptr, n_, CUDA_R_64F,
                                   rhs_.ptr, n_, static_cast<int*>(info_.ptr)),
                  "cusolverDnXpotrs");
    } else {
      const cublasStatus_t st =
          apply_ == DenseCholeskyApply::InverseSymv
              ? cublasMv().dsymv(blas_, CUBLAS_FILL_MODE_LOWER, n, &one, static_cast<const double*>(A_.ptr), n,
                                 static_cast<const double*>(rhs_.ptr), 1, &zero, static_cast<double*>(out_.ptr), 1)
              : cublasMv().dgemv(blas_, CUBLAS_OP_N, n, n, &one, static_cast<const double*>(A_.ptr), n,
                                 static_cast<const double*>(rhs_.ptr), 1, &zero, static_cast<double*>(out_.ptr), 1);
      if (st != CUBLAS_STATUS_SUCCESS)
        throw TopoError("GPU dense Cholesky", "the inverse's product failed with cuBLAS status " + std::to_string(st),
                        "check the GPU's free memory");
      result = out_.ptr;
    }
    check(cudaMemcpyAsync(pinned_, result, bytes, cudaMemcpyDeviceToHost, stream_), "download", kInput);
    check(cudaStreamSynchronize(stream_), "the factor's application", kInput);
    z->resize(n_);
    std::copy(static_cast<const double*>(pinned_), static_cast<const double*>(pinned_) + n_, z->data());
  }

  std::string name() const override { return name_; }
  double bytes() const override { return static_cast<double>(A_.bytes + F_.bytes + P_.bytes + y_.bytes); }
  double extraSeconds() const override { return extra_seconds_; }

 private:
  double max_bytes_ = 0.0;
  DenseCholeskyApply apply_ = DenseCholeskyApply::Triangular;
  long inverse_after_ = 0;
  DenseCholeskyApply inverse_as_ = DenseCholeskyApply::InverseGemv;
  int lwork_ = 1;
  double extra_seconds_ = 0.0;
  mutable long applications_ = 0;
  cublasHandle_t blas_ = nullptr;
  long long n_ = 0;
  bool factored_ = false;
  cudaStream_t stream_ = nullptr;
  cusolverDnHandle_t handle_ = nullptr;
  cusolverDnParams_t params_ = nullptr;
  cuda_detail::DeviceBuffer A_, info_;
  cuda_detail::DeviceBuffer F_, P_, y_;  // InverseFactorFloat32: L̃⁻ᵀ's rows, the products' work space
  std::vector<char> trtri_host_;
  std::string not_inverted_;  // why the inverse after inverse_after_ applications was not made
  mutable cuda_detail::DeviceBuffer rhs_, out_;
  void* pinned_ = nullptr;
  std::string name_;
};

}  // namespace

std::string denseCholeskyLibraryError() {
  if (!cusolver().error.empty()) return cusolver().error;
  cublasMv();  // the inverse's products: loaded now too (it is optional: its absence keeps the triangular solves)
  return "";
}

std::unique_ptr<CholeskySolver> makeDenseCholeskyCuda(double max_bytes, DenseCholeskyApply apply, long inverse_after,
                                                      DenseCholeskyApply inverse_as) {
  return std::make_unique<DenseCholeskyCuda>(max_bytes, apply, inverse_after, inverse_as);
}

#else  // no CUDA backend in this build

std::string denseCholeskyRefusal(std::size_t, double, double) {
  return "this build has no CUDA backend (nvcc was not found when it was configured)";
}

std::string denseCholeskyLibraryError() {
  return "this build has no CUDA backend (nvcc was not found when it was configured)";
}

namespace {
class NoCudaCholesky : public CholeskySolver {
 public:
  bool factorize(const Eigen::SparseMatrix<double>&) override {
    throw TopoError("GPU dense Cholesky", "this build has no CUDA backend (nvcc was not found when it was configured)",
                    "use backend cpu or auto, or rebuild with the CUDA toolkit");
  }
  void solve(const Eigen::VectorXd&, Eigen::VectorXd*) const override {
    throw TopoError("GPU dense Cholesky", "nothing was factorised", "call factorize first");
  }
  std::string name() const override { return "none (no CUDA backend)"; }
  double bytes() const override { return 0.0; }
};
}  // namespace

std::unique_ptr<CholeskySolver> makeDenseCholeskyCuda(double, DenseCholeskyApply, long, DenseCholeskyApply) {
  return std::make_unique<NoCudaCholesky>();
}

#endif

}  // namespace topo_gaussian
