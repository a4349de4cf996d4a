// Dense Cholesky on the GPU (cuSOLVER): the soft body's rest-stiffness preconditioner under
// backend cuda (the implicit/static path).
//
//   A = L Lᵀ  (cusolverDnXpotrf, float64, lower),   z = A⁻¹ r = L⁻ᵀ (L⁻¹ r)  (cusolverDnXpotrs)
//
// A is the matrix of rest_stiffness.h: K0 + diag(shift), fixed particles' rows and columns the
// identity, 3N × 3N, given as its sparse lower triangle; it is scattered into a dense column-major
// matrix on the device and factorised there. The factor is exact (the same matrix as the host's
// sparse Cholesky, other round-off), so the Newton–PCG iterations match the CPU path's.
//
// Why dense: the GPU machine has no sparse direct solver (CHOLMOD is the host's), and a dense
// float64 factorisation runs near the GPU's float64 peak: ~(3N)³/3 flops, a fraction of a second for
// the 9212-particle finger (27 636 unknowns; bench/gpu/README.md). Its memory is (3N)² × 8 bytes (6.1 GB
// for that finger): about 32 000 particles fit in 80 GB and 43 000 in 141 GB (90 % of the free memory). Above
// what the GPU has free the factory's factorize() throws GpuMemoryError naming the particles that would fit; the
// simulator then factorises on the host (backend auto, with a note) or stops (backend cuda).
//
// cuSOLVER is loaded with dlopen at the first factorisation (libcusolver.so.12/.11): programs that
// never factorise on the GPU do not pay its load time.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "topo_gaussian/physics/rest_stiffness.h"

namespace topo_gaussian {

/// Device bytes of a dense factor of n unknowns (n² float64 values; the workspace comes on top).
double denseCholeskyBytes(std::size_t unknowns);

/// The particles (3 unknowns each) whose dense factor fits in `bytes`.
std::size_t denseCholeskyParticlesFitting(double bytes);

/// Why a dense factor of `unknowns` (its lower triangle `lower_nonzeros` sparse entries, for the
/// upload) cannot be made on the first CUDA device now: no backend or device, or more memory than 90 %
/// of the free memory (or max_bytes > 0), naming the MiB and the particles that would fit. Empty when
/// it fits.
std::string denseCholeskyRefusal(std::size_t unknowns, double lower_nonzeros = 0.0, double max_bytes = 0.0);

/// Loads cuSOLVER (and cuBLAS) now, as the first factorisation would: a task calls it when it is built,
/// so that a missing library is said then and its load time is not the first evaluation's. Empty when
/// cuSOLVER loads, else why not.
std::string denseCholeskyLibraryError();

/// How a solve applies the factor:
/// - Triangular: two triangular solves (cusolverDnXpotrs: exact to round-off, but a solve with one
///   right-hand side is a chain of n/block dependent steps);
/// - InverseSymv / InverseGemv: the explicit inverse A⁻¹ (cusolverDnDpotri after the factor, about
///   twice the factor's flops once) times r, cuBLAS dsymv on its lower triangle or dgemv on the
///   mirrored full matrix, which read the matrix at the memory's speed; the inverse carries
///   cond(A) × ε of relative error (a preconditioner's worth) and takes at most 46 340 unknowns;
/// - InverseFactorFloat32: the inverse factor L⁻¹ (by halves: cublasDtrmm on the off-diagonal blocks,
///   cusolverDnXtrtri on diagonal blocks of ≤ 1024; about three times faster than one whole-matrix
///   cusolverDnXtrtri call) rounded once to float32, z = L̃⁻ᵀ (L̃⁻¹ r) with float64 sums:
///   half the bytes an application of InverseGemv reads. Whatever the rounding, the operator applied
///   is the Gram form of an invertible triangle, so it is symmetric positive definite, as a CG
///   preconditioner must be (a float32 copy of A⁻¹ itself need not be: its rounding, ~ε₃₂ ‖A⁻¹‖,
///   exceeds A⁻¹'s smallest eigenvalue once cond(A) passes ~1e7). Its relative distance from A⁻¹ r is
///   bounded by ~ε₃₂ √cond(A) (3e-8 on random SPD matrices of cond ~1e2 in a CPU emulation, 3-5e-10 on the test
///   cantilever's K0, whose products are dominated by its softest modes): a few more CG iterations at
///   most (the finger: 179 applications for a static solve instead of 169). Memory: (3N)² × 4 bytes
///   once made (the float64 factor is freed), but about (3N)² × 12 while it is made. Made after
///   inverse_after applications: where the GPU lacks that memory, or above 65 535 unknowns, the
///   triangular solves go on and name() says why; asked for at factorize() (apply), it throws.
enum class DenseCholeskyApply { Triangular, InverseSymv, InverseGemv, InverseFactorFloat32 };

/// A CholeskySolver on the first CUDA device. max_bytes > 0: refuse a factor above it too (tests;
/// the device's free memory always bounds it). Without the CUDA backend or a device, factorize()
/// throws TopoError with the reason. inverse_after > 0 with the triangular solves: once the factor has
/// been applied that many times it is inverted (`inverse_as`: InverseGemv in place by potri, or
/// InverseFactorFloat32) and applied so from then on (a factor kept for many solves:
/// rest_factor_reuse.h); where the inverse cannot be made (InverseGemv above 46 340 unknowns, no
/// potri/trtri or cuBLAS, no memory for its workspace or float32 copy) the triangular solves go on; a
/// failure of potri/trtri itself (the factor overwritten) makes that solve and every later one throw.
std::unique_ptr<CholeskySolver> makeDenseCholeskyCuda(double max_bytes = 0.0,
                                                      DenseCholeskyApply apply = DenseCholeskyApply::Triangular,
                                                      long inverse_after = 0,
                                                      DenseCholeskyApply inverse_as = DenseCholeskyApply::InverseGemv);

/// Applications of one factor from which its explicit float64 inverse (InverseGemv) pays: it costs about one more
/// factorisation (potri) and saves about two thirds of an application's time; calibrated at 27 636
/// unknowns to ~180 applications (bench/gpu/README.md); the first cost grows as the unknowns cubed, the
/// saving as their square, so the break-even grows in proportion to the unknowns.
long denseCholeskyInverseBreakEven(std::size_t unknowns);

/// The same for the float32 inverse factor (DenseCholeskyApply::InverseFactorFloat32): the inversion
/// and the float32 copy cost about one factorisation and save about three quarters of an
/// application's time; calibrated at 27 636 unknowns to ~48 applications (bench_gpu_static and
/// bench_infer, bench/gpu/README.md), in proportion elsewhere (cost ∝ unknowns³, saving ∝ unknowns²): a design's static solve alone (~170
/// applications for the finger) pays for it.
long denseCholeskyInverseFactorBreakEven(std::size_t unknowns);

}  // namespace topo_gaussian
