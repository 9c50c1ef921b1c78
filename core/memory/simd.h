#pragma once
// Vector kernels of the memory's distances (issue 19: recognition ≤ 1 ms at 10⁴ places). The
// build targets any CPU (baseline x86-64: SSE2); on an x86-64 CPU with AVX2 and FMA the
// products of ViewDistances and the view index run the kernels below instead, chosen at run
// time. They take raw column-major arrays, so no Eigen code is compiled for two instruction
// sets (Eigen's inline templates would then differ between translation units).

#include <cstddef>
#include <cstdint>

namespace tsc {

/// The instruction set a distance computation runs on.
enum class Simd {
  kPortable,  ///< the build's own (Eigen's products)
  kAvx2Fma,   ///< the kernels of namespace avx2 (x86-64 CPUs with AVX2 and FMA)
};

/// kAvx2Fma where the CPU (and the OS) supports AVX2 and FMA, else kPortable.
Simd FastestSimd();

/// nearest[r] = the least of q_norms[j] − 2·dots[r + j·rows] over j < nq (+∞ when nq = 0), for
/// r < rows: each key's least ‖q‖² − 2kᵀq over the queries, from the products of the keys and
/// the queries (rows x nq, column-major). On `simd`'s kernel or the portable loop, the same
/// floats (values never NaN).
void LeastDistances(Simd simd, const float* dots, int rows, int nq, const float* q_norms,
                    float* nearest);

/// The width ColumnDots runs at. Each of its outputs is a sum over an 8-lane accumulator, each
/// lane a fixed sequence of FMAs; 16 lanes run two such accumulators side by side, so both
/// widths give the same results bit for bit and the width changes only the speed.
enum class Lanes {
  k8,   ///< AVX2 and FMA
  k16,  ///< AVX-512F and AVX-512VL, where the CPU has them
};

/// k16 where the CPU (and the OS) supports AVX-512F and AVX-512VL as well as AVX2 and FMA,
/// else k8.
Lanes WidestLanes();

namespace avx2 {

// Preconditions for every kernel: FastestSimd() == Simd::kAvx2Fma (they throw
// std::logic_error in a build without them); arrays column-major, no alignment needed.

/// out[i + j·na] = a_iᵀ b_j for the columns a_i (i < na) of `a` and b_j (j < nb) of `b`, all
/// of length `dim`: out is na x nb. With b_norms (else null), b_norms[j] = ‖b_j‖² too.
/// `next` (may be null): `next_floats` floats the caller reads next (the next place's views),
/// fetched into cache while the products run. Each sum runs over the dimensions in the same
/// order for every column, so results do not depend on na, nb or a column's position.
/// `lanes`: k16 only where WidestLanes() names it.
void ColumnDots(const float* a, int na, const float* b, int nb, int dim, float* out, float* b_norms,
                const float* next = nullptr, std::ptrdiff_t next_floats = 0,
                Lanes lanes = WidestLanes());

/// The element at n/2 of `values` once ordered (UpperMedianInPlace of core/median.h, the same
/// value), without reordering them. For the few dozen values of g_N's medians: it compares
/// every pair, O(n²). Preconditions: n ≥ 1, no value NaN (std::invalid_argument when no value
/// is found at n/2).
double UpperMedian(const double* values, int n);

/// out[j] = ‖b_j‖² for the columns b_j (j < nb) of `b`, of length `dim`: the b_norms ColumnDots
/// gives, bit for bit (each sum runs over the dimensions in the same order).
void ColumnSquaredNorms(const float* b, int nb, int dim, float* out);

/// out[r + j·rows] = Σ_k a[r + k·lda] · q[k + j·dim]: the rows x dim block `a` (leading
/// dimension lda ≥ rows) times the dim x nq matrix `q`; out is rows x nq. Each sum runs over
/// k in order, one FMA per term, at either width (`lanes`: k16 only where WidestLanes() names
/// it), so both give the same floats.
void RowDots(const float* a, std::ptrdiff_t lda, int rows, int dim, const float* q, int nq,
             float* out, Lanes lanes = WidestLanes());

/// out[r + c·rows] = codes[r + c·rows] · 2^(drop[r] − shift) for r < rows, c < cols: member
/// views in 8 bits decoded (core/memory/compact_views.h). Precondition: drop[r] − shift in
/// [−126, 127] for every row (each scale a normal float).
void ScaleInt8Rows(const int8_t* codes, const uint8_t* drop, std::ptrdiff_t rows,
                   std::ptrdiff_t cols, int shift, float* out);

/// row_most[r] = the largest |x[r + c·rows]| over c < cols; false (row_most unspecified) when
/// a coordinate is infinite or NaN. The encoding's first pass (CompactViews).
bool RowMagnitudes(const float* x, std::ptrdiff_t rows, std::ptrdiff_t cols, float* row_most);
/// codes[r + c·rows] = x[r + c·rows] · row_scale[r] rounded to the nearest integer, ties to
/// even, for r < rows, c < cols: the encoding's codes. Precondition: every product is exact in
/// double (row_scale[r] a power of two) and rounds into [−127, 127].
void RoundInt8Rows(const float* x, std::ptrdiff_t rows, std::ptrdiff_t cols,
                   const double* row_scale, int8_t* codes);
/// For each row j < n of the n x k products `dots` (column-major, k ≥ 1): nearest[j] = the
/// least of (−2·dots[j + v·n] + col_sq[v]) + row_sq[j] over v < k, and at[j] = the first v
/// giving it: the nearest column by ‖x‖² + ‖y‖² − 2xᵀy, computed as the scalar loop of
/// ViewDistances does, so the same floats come out.
void NearestColumns(const float* dots, int n, int k, const float* col_sq, const float* row_sq,
                    float* nearest, int* at);

/// The least of values[0..n) below +∞ (+∞ when there is none: n = 0, or every value +∞ or
/// NaN; a NaN is never the least), as a loop keeping `v < least` would give.
float Least(const float* values, int n);

/// The first index holding Least(values, n), or −1 when that is +∞: the index a loop keeping
/// the first `v < least` gives. For the nearest-view searches of ThinViews.
int FirstLeast(const float* values, int n);

/// tsc::LeastDistances on 8 lanes.
void LeastDistances(const float* dots, int rows, int nq, const float* q_norms, float* nearest);

}  // namespace avx2
}  // namespace tsc
