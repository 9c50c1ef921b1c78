#include "core/memory/simd.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TSC_AVX2_KERNELS 1
#endif

// No Eigen here: this file's functions are compiled for AVX2 and FMA, or AVX-512, one by one
// (the target attribute) while the file, like the rest of the build, targets the baseline.

namespace tsc {

Simd FastestSimd() {
#ifdef TSC_AVX2_KERNELS
  static const Simd fastest = [] {
    __builtin_cpu_init();
    // libgcc also checks that the OS saves the AVX registers (XGETBV) before it reports avx2.
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") ? Simd::kAvx2Fma
                                                                           : Simd::kPortable;
  }();
  return fastest;
#else
  return Simd::kPortable;
#endif
}

Lanes WidestLanes() {
#ifdef TSC_AVX2_KERNELS
  static const Lanes widest = [] {
    __builtin_cpu_init();
    // As for AVX2, libgcc reports avx512f only where the OS saves the 512-bit registers.
    return FastestSimd() == Simd::kAvx2Fma && __builtin_cpu_supports("avx512f") &&
                   __builtin_cpu_supports("avx512vl")
               ? Lanes::k16
               : Lanes::k8;
  }();
  return widest;
#else
  return Lanes::k8;
#endif
}

namespace {

// LeastDistances' rows [from, rows), one at a time: the portable loop, and the 8-lane kernel's
// tail (q − 2·d is exact but for its one rounding, so an FMA cannot change it).
void LeastDistancesFrom(int from, const float* dots, int rows, int nq, const float* q_norms,
                        float* nearest) {
  for (int r = from; r < rows; ++r) {
    float least = std::numeric_limits<float>::infinity();
    for (int j = 0; j < nq; ++j) least = std::min(least, q_norms[j] - 2.0f * dots[r + j * rows]);
    nearest[r] = least;
  }
}

}  // namespace

void LeastDistances(Simd simd, const float* dots, int rows, int nq, const float* q_norms,
                    float* nearest) {
  if (simd == Simd::kAvx2Fma) return avx2::LeastDistances(dots, rows, nq, q_norms, nearest);
  LeastDistancesFrom(0, dots, rows, nq, q_norms, nearest);
}

namespace avx2 {

#ifdef TSC_AVX2_KERNELS
namespace {

#define TSC_AVX2 __attribute__((target("avx2,fma")))

TSC_AVX2 inline float Sum(__m256 v) {
  __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  s = _mm_add_ps(s, _mm_movehl_ps(s, s));
  s = _mm_add_ss(s, _mm_movehdup_ps(s));
  return _mm_cvtss_f32(s);
}

// The first n lanes (0 ≤ n ≤ 8).
TSC_AVX2 inline __m256i FirstLanes(int n) {
  return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}

// The Sums of eight accumulators in one register, lane k the Sum of v[k / 4 + 2·(k % 4)]: each
// lane makes Sum's additions on Sum's operands, ((v0+v4)+(v2+v6)) + ((v1+v5)+(v3+v7)), so the
// floats are Sum's bit for bit, in 21 shuffles and adds where eight Sums took about 50.
TSC_AVX2 inline __m256 Sums8(const __m256 (&v)[8]) {
  __m256 s[4];  // v_k + v_{k+4} of v[2q] (low half) and v[2q+1] (high half)
#pragma GCC unroll 4
  for (int q = 0; q < 4; ++q) {
    s[q] = _mm256_add_ps(_mm256_permute2f128_ps(v[2 * q], v[2 * q + 1], 0x20),
                         _mm256_permute2f128_ps(v[2 * q], v[2 * q + 1], 0x31));
  }
  // Lanes 0, 1 of each pair: s0 + s2, s1 + s3.
  const __m256 t01 = _mm256_add_ps(_mm256_shuffle_ps(s[0], s[1], _MM_SHUFFLE(1, 0, 1, 0)),
                                   _mm256_shuffle_ps(s[0], s[1], _MM_SHUFFLE(3, 2, 3, 2)));
  const __m256 t23 = _mm256_add_ps(_mm256_shuffle_ps(s[2], s[3], _MM_SHUFFLE(1, 0, 1, 0)),
                                   _mm256_shuffle_ps(s[2], s[3], _MM_SHUFFLE(3, 2, 3, 2)));
  return _mm256_add_ps(_mm256_shuffle_ps(t01, t23, _MM_SHUFFLE(2, 0, 2, 0)),
                       _mm256_shuffle_ps(t01, t23, _MM_SHUFFLE(3, 1, 3, 1)));
}

// A kA x kB block of ColumnDots: columns a_0..a_{kA−1} (stride dim) against b_0..b_{kB−1},
// 8 lanes at a time with a masked tail; every product read straight from the columns (no
// packing). 4 x 3 accumulators and 7 loads per 12 FMAs keep the FMA units busy.
template <int kA, int kB>
TSC_AVX2 void DotBlock(const float* a, const float* b, int dim, float* out, int ldo) {
  __m256 acc[kA][kB];
#pragma GCC unroll 4
  for (int i = 0; i < kA; ++i) {
#pragma GCC unroll 3
    for (int j = 0; j < kB; ++j) acc[i][j] = _mm256_setzero_ps();
  }
  const std::ptrdiff_t stride = dim;
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
    __m256 va[kA];
#pragma GCC unroll 4
    for (int i = 0; i < kA; ++i) va[i] = _mm256_loadu_ps(a + i * stride + d);
#pragma GCC unroll 3
    for (int j = 0; j < kB; ++j) {
      const __m256 vb = _mm256_loadu_ps(b + j * stride + d);
#pragma GCC unroll 4
      for (int i = 0; i < kA; ++i) acc[i][j] = _mm256_fmadd_ps(va[i], vb, acc[i][j]);
    }
  }
  if (d < dim) {
    const __m256i mask = FirstLanes(dim - d);
    __m256 va[kA];
#pragma GCC unroll 4
    for (int i = 0; i < kA; ++i) va[i] = _mm256_maskload_ps(a + i * stride + d, mask);
#pragma GCC unroll 3
    for (int j = 0; j < kB; ++j) {
      const __m256 vb = _mm256_maskload_ps(b + j * stride + d, mask);
#pragma GCC unroll 4
      for (int i = 0; i < kA; ++i) acc[i][j] = _mm256_fmadd_ps(va[i], vb, acc[i][j]);
    }
  }
  if constexpr (kA == 4) {  // two columns' four rows a register, Sums8's lanes in row order
#pragma GCC unroll 3
    for (int j = 0; j < kB; j += 2) {
      const int k = std::min(j + 1, kB - 1);  // a last lone column fills both halves
      const __m256 pair[8] = {acc[0][j], acc[0][k], acc[1][j], acc[1][k],
                              acc[2][j], acc[2][k], acc[3][j], acc[3][k]};
      const __m256 sums = Sums8(pair);
      _mm_storeu_ps(out + j * ldo, _mm256_castps256_ps128(sums));
      if (k != j) _mm_storeu_ps(out + k * ldo, _mm256_extractf128_ps(sums, 1));
    }
    return;
  }
#pragma GCC unroll 4
  for (int i = 0; i < kA; ++i) {
#pragma GCC unroll 3
    for (int j = 0; j < kB; ++j) out[i + j * ldo] = Sum(acc[i][j]);
  }
}

template <int kB>
TSC_AVX2 void DotRow(int ka, const float* a, const float* b, int dim, float* out, int ldo) {
  switch (ka) {
    case 1:
      return DotBlock<1, kB>(a, b, dim, out, ldo);
    case 2:
      return DotBlock<2, kB>(a, b, dim, out, ldo);
    case 3:
      return DotBlock<3, kB>(a, b, dim, out, ldo);
    default:
      return DotBlock<4, kB>(a, b, dim, out, ldo);
  }
}

// RowDots for kQ columns of q: 32 rows (4 x 8 lanes) at a time, then 8 with a masked tail.
// Each row's sum runs over k in order, one FMA per term, wherever the row falls.
template <int kQ>
TSC_AVX2 void RowDotsOf(const float* a, std::ptrdiff_t lda, int rows, int dim, const float* q,
                        float* out, std::ptrdiff_t ldo) {
  int r = 0;
  for (; r + 32 <= rows; r += 32) {
    __m256 acc[4][kQ];
#pragma GCC unroll 4
    for (int i = 0; i < 4; ++i) {
#pragma GCC unroll 3
      for (int j = 0; j < kQ; ++j) acc[i][j] = _mm256_setzero_ps();
    }
    for (int k = 0; k < dim; ++k) {
      const float* ak = a + k * lda + r;
      __m256 va[4];
#pragma GCC unroll 4
      for (int i = 0; i < 4; ++i) va[i] = _mm256_loadu_ps(ak + 8 * i);
#pragma GCC unroll 3
      for (int j = 0; j < kQ; ++j) {
        const __m256 vq = _mm256_broadcast_ss(q + k + j * static_cast<std::ptrdiff_t>(dim));
#pragma GCC unroll 4
        for (int i = 0; i < 4; ++i) acc[i][j] = _mm256_fmadd_ps(va[i], vq, acc[i][j]);
      }
    }
#pragma GCC unroll 4
    for (int i = 0; i < 4; ++i) {
#pragma GCC unroll 3
      for (int j = 0; j < kQ; ++j) _mm256_storeu_ps(out + j * ldo + r + 8 * i, acc[i][j]);
    }
  }
  for (; r < rows; r += 8) {
    const __m256i mask = FirstLanes(std::min(8, rows - r));
    __m256 acc[kQ];
#pragma GCC unroll 3
    for (int j = 0; j < kQ; ++j) acc[j] = _mm256_setzero_ps();
    for (int k = 0; k < dim; ++k) {
      const __m256 va = _mm256_maskload_ps(a + k * lda + r, mask);
#pragma GCC unroll 3
      for (int j = 0; j < kQ; ++j) {
        const __m256 vq = _mm256_broadcast_ss(q + k + j * static_cast<std::ptrdiff_t>(dim));
        acc[j] = _mm256_fmadd_ps(va, vq, acc[j]);
      }
    }
#pragma GCC unroll 3
    for (int j = 0; j < kQ; ++j) _mm256_maskstore_ps(out + j * ldo + r, mask, acc[j]);
  }
}

// ‖b_j‖² of column j < kB (stride dim), 8 lanes at a time with a masked tail.
template <int kB>
TSC_AVX2 void SquaredNorms(const float* b, int dim, float* out) {
  __m256 acc[kB];
#pragma GCC unroll 3
  for (int j = 0; j < kB; ++j) acc[j] = _mm256_setzero_ps();
  const std::ptrdiff_t stride = dim;
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
#pragma GCC unroll 3
    for (int j = 0; j < kB; ++j) {
      const __m256 vb = _mm256_loadu_ps(b + j * stride + d);
      acc[j] = _mm256_fmadd_ps(vb, vb, acc[j]);
    }
  }
  if (d < dim) {
    const __m256i mask = FirstLanes(dim - d);
#pragma GCC unroll 3
    for (int j = 0; j < kB; ++j) {
      const __m256 vb = _mm256_maskload_ps(b + j * stride + d, mask);
      acc[j] = _mm256_fmadd_ps(vb, vb, acc[j]);
    }
  }
#pragma GCC unroll 3
  for (int j = 0; j < kB; ++j) out[j] = Sum(acc[j]);
}

// SquaredNorms of `count` ≤ 3 columns.
TSC_AVX2 void SquaredNormsOf(const float* b, int count, int dim, float* out) {
  switch (count) {
    case 1:
      return SquaredNorms<1>(b, dim, out);
    case 2:
      return SquaredNorms<2>(b, dim, out);
    default:
      return SquaredNorms<3>(b, dim, out);
  }
}

// The next call's b fetched from memory while this one computes: its cache lines spread over
// the `blocks` blocks of products, Step() after each.
class Prefetch {
 public:
  Prefetch(const float* next, std::ptrdiff_t next_floats, std::ptrdiff_t blocks)
      : next_(next),
        lines_(next == nullptr ? 0 : (next_floats + 15) / 16),
        per_block_((lines_ + blocks - 1) / blocks) {}
  void Step() {
    for (std::ptrdiff_t l = 0; l < per_block_ && line_ < lines_; ++l, ++line_)
      _mm_prefetch(reinterpret_cast<const char*>(next_ + 16 * line_), _MM_HINT_T1);
  }

 private:
  const float* next_;
  std::ptrdiff_t lines_, per_block_, line_ = 0;
};

// Columns of a taken at a time by ColumnDots (a multiple of the blocks' 4): as many as stay in
// L2 (~128 KB) while every column of b passes. Long columns (a basis' 128 axes of 1200 floats,
// 600 KB) were read whole for each few columns of b, from L3. Each product is still one
// DotBlock over all of dim, so the band changes no result.
int BandOf(int dim) { return std::max(4, 32768 / std::max(1, dim) / 4 * 4); }

TSC_AVX2 void ColumnDots8(const float* a, int na, const float* b, int nb, int dim, float* out,
                          float* b_norms, const float* next, std::ptrdiff_t next_floats) {
  const std::ptrdiff_t stride = dim;
  Prefetch prefetch(next, next_floats, static_cast<std::ptrdiff_t>((nb + 2) / 3) * ((na + 3) / 4));
  const int band = BandOf(dim);
  for (int i0 = 0; i0 < na; i0 += band) {
    const int i_end = std::min(na, i0 + band);
    // Three columns of b at a time, each against every four of the band: the three stay in L1.
    for (int j = 0; j < nb; j += 3) {
      const int kb = std::min(3, nb - j);
      if (b_norms != nullptr && i0 == 0) SquaredNormsOf(b + j * stride, kb, dim, b_norms + j);
      for (int i = i0; i < i_end; i += 4) {
        const float* ai = a + i * stride;
        const float* bj = b + j * stride;
        float* o = out + i + static_cast<std::ptrdiff_t>(j) * na;
        const int ka = std::min(4, i_end - i);
        switch (kb) {
          case 1:
            DotRow<1>(ka, ai, bj, dim, o, na);
            break;
          case 2:
            DotRow<2>(ka, ai, bj, dim, o, na);
            break;
          default:
            DotRow<3>(ka, ai, bj, dim, o, na);
        }
        prefetch.Step();
      }
    }
  }
}

// ColumnDots on 16 lanes: AVX-512F, and VL for the 8-lane masked loads of a tail. Each
// register holds two 8-lane accumulators that run ColumnDots8's FMAs lane for lane, so the
// results are the same bit for bit (a 10⁵ + 10⁵ merge spends a fifth of its CPU here).
#define TSC_AVX512 __attribute__((target("avx2,fma,avx512f,avx512vl")))
// GCC 12's avx512fintrin.h builds the broadcast, insert and extract intrinsics on a
// self-initialised "undefined" register, which -Wuninitialized reports (GCC bug 105593).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// Two 8-lane registers as the halves of one 16-lane register.
TSC_AVX512 inline __m512 Halves(__m256 low, __m256 high) {
  return _mm512_castpd_ps(
      _mm512_insertf64x4(_mm512_castpd256_pd512(_mm256_castps_pd(low)), _mm256_castps_pd(high), 1));
}

TSC_AVX512 inline __m256 HighHalf(__m512 v) {
  return _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1));
}

// The Sums of four rows' accumulators of one column pair (low half: column 2p, high half:
// column 2p+1), all eight at once: each lane makes Sum's additions on Sum's operands,
// ((v0+v4)+(v2+v6)) + ((v1+v5)+(v3+v7)), so the floats are Sum's bit for bit, in 11 shuffles
// and adds where eight Sums took about 50 (the sums were a third of a 4 x 8 block's work).
TSC_AVX512 inline void StoreSums4(const __m512 (&acc)[4], float* low, float* high) {
  // 128-bit blocks of acc[i]: [v0..3 | v4..7] of column 2p, then of column 2p+1.
  const __m512 s01 = _mm512_add_ps(_mm512_shuffle_f32x4(acc[0], acc[1], _MM_SHUFFLE(2, 0, 2, 0)),
                                   _mm512_shuffle_f32x4(acc[0], acc[1], _MM_SHUFFLE(3, 1, 3, 1)));
  const __m512 s23 = _mm512_add_ps(_mm512_shuffle_f32x4(acc[2], acc[3], _MM_SHUFFLE(2, 0, 2, 0)),
                                   _mm512_shuffle_f32x4(acc[2], acc[3], _MM_SHUFFLE(3, 1, 3, 1)));
  // Blocks: (row 0 low, row 0 high, row 1 low, row 1 high) of s01, rows 2 and 3 of s23, each
  // v_k + v_{k+4}; then lanes 0, 1 of each block's pair are s0 + s2, s1 + s3.
  const __m512 t = _mm512_add_ps(_mm512_shuffle_ps(s01, s23, _MM_SHUFFLE(1, 0, 1, 0)),
                                 _mm512_shuffle_ps(s01, s23, _MM_SHUFFLE(3, 2, 3, 2)));
  const __m512 u = _mm512_add_ps(t, _mm512_movehdup_ps(t));  // lanes 0 and 2 of each block
  const __m512 rows = _mm512_permutexvar_ps(
      _mm512_setr_epi32(0, 8, 2, 10, 4, 12, 6, 14, 0, 0, 0, 0, 0, 0, 0, 0), u);
  _mm_storeu_ps(low, _mm512_castps512_ps128(rows));
  if (high != nullptr) _mm_storeu_ps(high, _mm512_extractf32x4_ps(rows, 1));
}

// DotBlock with two columns of b to a register, one per half: a kA x (2·kP) block. With `odd`,
// the last register's high half repeats its low column and is not stored.
template <int kA, int kP>
TSC_AVX512 void DotBlock16(const float* a, const float* b, bool odd, int dim, float* out, int ldo) {
  const std::ptrdiff_t stride = dim;
  const float* column[2 * kP];
#pragma GCC unroll 4
  for (int p = 0; p < kP; ++p) {
    column[2 * p] = b + 2 * p * stride;
    column[2 * p + 1] = odd && p == kP - 1 ? column[2 * p] : b + (2 * p + 1) * stride;
  }
  __m512 acc[kA][kP];
#pragma GCC unroll 4
  for (int i = 0; i < kA; ++i) {
#pragma GCC unroll 4
    for (int p = 0; p < kP; ++p) acc[i][p] = _mm512_setzero_ps();
  }
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
    __m512 va[kA];
#pragma GCC unroll 4
    for (int i = 0; i < kA; ++i) {
      va[i] = _mm512_castpd_ps(
          _mm512_broadcast_f64x4(_mm256_castps_pd(_mm256_loadu_ps(a + i * stride + d))));
    }
#pragma GCC unroll 4
    for (int p = 0; p < kP; ++p) {
      const __m512 vb =
          Halves(_mm256_loadu_ps(column[2 * p] + d), _mm256_loadu_ps(column[2 * p + 1] + d));
#pragma GCC unroll 4
      for (int i = 0; i < kA; ++i) acc[i][p] = _mm512_fmadd_ps(va[i], vb, acc[i][p]);
    }
  }
  if (d < dim) {  // masked lanes load 0, as DotBlock's do
    const __m256i mask = FirstLanes(dim - d);
    __m512 va[kA];
#pragma GCC unroll 4
    for (int i = 0; i < kA; ++i) {
      const __m256 x = _mm256_maskload_ps(a + i * stride + d, mask);
      va[i] = Halves(x, x);
    }
#pragma GCC unroll 4
    for (int p = 0; p < kP; ++p) {
      const __m512 vb = Halves(_mm256_maskload_ps(column[2 * p] + d, mask),
                               _mm256_maskload_ps(column[2 * p + 1] + d, mask));
#pragma GCC unroll 4
      for (int i = 0; i < kA; ++i) acc[i][p] = _mm512_fmadd_ps(va[i], vb, acc[i][p]);
    }
  }
  if constexpr (kA == 4) {
#pragma GCC unroll 4
    for (int p = 0; p < kP; ++p) {
      const __m512 column_pair[4] = {acc[0][p], acc[1][p], acc[2][p], acc[3][p]};
      StoreSums4(column_pair, out + 2 * p * ldo,
                 odd && p == kP - 1 ? nullptr : out + (2 * p + 1) * ldo);
    }
    return;
  }
#pragma GCC unroll 4
  for (int i = 0; i < kA; ++i) {
#pragma GCC unroll 4
    for (int p = 0; p < kP; ++p) {
      out[i + 2 * p * ldo] = Sum(_mm512_castps512_ps256(acc[i][p]));
      if (!(odd && p == kP - 1)) out[i + (2 * p + 1) * ldo] = Sum(HighHalf(acc[i][p]));
    }
  }
}

template <int kP>
TSC_AVX512 void DotRow16(int ka, const float* a, const float* b, bool odd, int dim, float* out,
                         int ldo) {
  switch (ka) {
    case 1:
      return DotBlock16<1, kP>(a, b, odd, dim, out, ldo);
    case 2:
      return DotBlock16<2, kP>(a, b, odd, dim, out, ldo);
    case 3:
      return DotBlock16<3, kP>(a, b, odd, dim, out, ldo);
    default:
      return DotBlock16<4, kP>(a, b, odd, dim, out, ldo);
  }
}

// ColumnDots8 with eight columns of b at a time (four registers of two): 16 accumulators, 4
// broadcast columns of a and a column pair of b take 21-24 of AVX-512's 32 registers, and a
// place's 32 views fall in whole blocks (with six, 5 blocks and a 2-column tail that ran at
// two thirds of the speed).
TSC_AVX512 void ColumnDots16(const float* a, int na, const float* b, int nb, int dim, float* out,
                             float* b_norms, const float* next, std::ptrdiff_t next_floats) {
  const std::ptrdiff_t stride = dim;
  Prefetch prefetch(next, next_floats, static_cast<std::ptrdiff_t>((nb + 7) / 8) * ((na + 3) / 4));
  const int band = BandOf(dim);  // as ColumnDots8
  for (int i0 = 0; i0 < na; i0 += band) {
    const int i_end = std::min(na, i0 + band);
    for (int j = 0; j < nb; j += 8) {
      const int kb = std::min(8, nb - j);
      if (b_norms != nullptr && i0 == 0) {  // 8-lane norms: the same sums, and cheap
        for (int n = 0; n < kb; n += 3)
          SquaredNormsOf(b + (j + n) * stride, std::min(3, kb - n), dim, b_norms + j + n);
      }
      const bool odd = kb % 2 != 0;
      for (int i = i0; i < i_end; i += 4) {
        const float* ai = a + i * stride;
        const float* bj = b + j * stride;
        float* o = out + i + static_cast<std::ptrdiff_t>(j) * na;
        const int ka = std::min(4, i_end - i);
        switch ((kb + 1) / 2) {
          case 1:
            DotRow16<1>(ka, ai, bj, odd, dim, o, na);
            break;
          case 2:
            DotRow16<2>(ka, ai, bj, odd, dim, o, na);
            break;
          case 3:
            DotRow16<3>(ka, ai, bj, odd, dim, o, na);
            break;
          default:
            DotRow16<4>(ka, ai, bj, odd, dim, o, na);
        }
        prefetch.Step();
      }
    }
  }
}

// RowDotsOf on 16 lanes: 64 rows (4 x 16 lanes) by kQ columns of q at a time, then 16 with a
// masked tail. A lane is one row's sum, one FMA per term over k in order, as on 8 lanes, so
// both widths give the same floats (the view index's products were a ninth of a 10⁵ + 10⁵
// merge).
template <int kQ>
TSC_AVX512 void RowDotsOf16(const float* a, std::ptrdiff_t lda, int rows, int dim, const float* q,
                            float* out, std::ptrdiff_t ldo) {
  int r = 0;
  for (; r + 64 <= rows; r += 64) {
    __m512 acc[4][kQ];
#pragma GCC unroll 4
    for (int i = 0; i < 4; ++i) {
#pragma GCC unroll 4
      for (int j = 0; j < kQ; ++j) acc[i][j] = _mm512_setzero_ps();
    }
    for (int k = 0; k < dim; ++k) {
      const float* ak = a + k * lda + r;
      __m512 va[4];
#pragma GCC unroll 4
      for (int i = 0; i < 4; ++i) va[i] = _mm512_loadu_ps(ak + 16 * i);
#pragma GCC unroll 4
      for (int j = 0; j < kQ; ++j) {
        const __m512 vq = _mm512_set1_ps(q[k + j * static_cast<std::ptrdiff_t>(dim)]);
#pragma GCC unroll 4
        for (int i = 0; i < 4; ++i) acc[i][j] = _mm512_fmadd_ps(va[i], vq, acc[i][j]);
      }
    }
#pragma GCC unroll 4
    for (int i = 0; i < 4; ++i) {
#pragma GCC unroll 4
      for (int j = 0; j < kQ; ++j) _mm512_storeu_ps(out + j * ldo + r + 16 * i, acc[i][j]);
    }
  }
  for (; r < rows; r += 16) {
    const __mmask16 mask = static_cast<__mmask16>((1u << std::min(16, rows - r)) - 1u);
    __m512 acc[kQ];
#pragma GCC unroll 4
    for (int j = 0; j < kQ; ++j) acc[j] = _mm512_setzero_ps();
    for (int k = 0; k < dim; ++k) {
      const __m512 va = _mm512_maskz_loadu_ps(mask, a + k * lda + r);
#pragma GCC unroll 4
      for (int j = 0; j < kQ; ++j) {
        const __m512 vq = _mm512_set1_ps(q[k + j * static_cast<std::ptrdiff_t>(dim)]);
        acc[j] = _mm512_fmadd_ps(va, vq, acc[j]);
      }
    }
#pragma GCC unroll 4
    for (int j = 0; j < kQ; ++j) _mm512_mask_storeu_ps(out + j * ldo + r, mask, acc[j]);
  }
}

TSC_AVX512 void RowDots16(const float* a, std::ptrdiff_t lda, int rows, int dim, const float* q,
                          int nq, float* out) {
  const std::ptrdiff_t ldo = rows;
  for (int j = 0; j < nq; j += 4) {
    const float* qj = q + j * static_cast<std::ptrdiff_t>(dim);
    float* o = out + j * ldo;
    switch (std::min(4, nq - j)) {
      case 1:
        RowDotsOf16<1>(a, lda, rows, dim, qj, o, ldo);
        break;
      case 2:
        RowDotsOf16<2>(a, lda, rows, dim, qj, o, ldo);
        break;
      case 3:
        RowDotsOf16<3>(a, lda, rows, dim, qj, o, ldo);
        break;
      default:
        RowDotsOf16<4>(a, lda, rows, dim, qj, o, ldo);
    }
  }
}

#pragma GCC diagnostic pop
#undef TSC_AVX512

}  // namespace

void ColumnDots(const float* a, int na, const float* b, int nb, int dim, float* out, float* b_norms,
                const float* next, std::ptrdiff_t next_floats, Lanes lanes) {
  if (lanes == Lanes::k16) {
    ColumnDots16(a, na, b, nb, dim, out, b_norms, next, next_floats);
  } else {
    ColumnDots8(a, na, b, nb, dim, out, b_norms, next, next_floats);
  }
}

TSC_AVX2 double UpperMedian(const double* values, int n) {
  // The element whose rank brackets n/2: fewer than n/2 + 1 values lie below it, more than n/2
  // at or below it. Counting ranks has no branch to mispredict, where std::nth_element's
  // partitions of a few dozen values mispredict about every other comparison.
  const int half = n / 2;
  for (int i = 0; i < n; ++i) {
    const __m256d x = _mm256_set1_pd(values[i]);
    int below = 0, at_most = 0;
    int j = 0;
    for (; j + 4 <= n; j += 4) {
      const __m256d y = _mm256_loadu_pd(values + j);
      below += __builtin_popcount(
          static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(y, x, _CMP_LT_OQ))));
      at_most += __builtin_popcount(
          static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(y, x, _CMP_LE_OQ))));
    }
    for (; j < n; ++j) {
      below += values[j] < values[i];
      at_most += values[j] <= values[i];
    }
    if (below <= half && half < at_most) return values[i];
  }
  throw std::invalid_argument("avx2::UpperMedian: no median (empty, or not ordered: NaN)");
}

TSC_AVX2 void ColumnSquaredNorms(const float* b, int nb, int dim, float* out) {
  const std::ptrdiff_t stride = dim;
  for (int j = 0; j < nb; j += 3) SquaredNormsOf(b + j * stride, std::min(3, nb - j), dim, out + j);
}

TSC_AVX2 void RowDots(const float* a, std::ptrdiff_t lda, int rows, int dim, const float* q, int nq,
                      float* out, Lanes lanes) {
  if (lanes == Lanes::k16) return RowDots16(a, lda, rows, dim, q, nq, out);
  const std::ptrdiff_t ldo = rows;
  for (int j = 0; j < nq; j += 3) {
    const float* qj = q + j * static_cast<std::ptrdiff_t>(dim);
    float* o = out + j * ldo;
    switch (std::min(3, nq - j)) {
      case 1:
        RowDotsOf<1>(a, lda, rows, dim, qj, o, ldo);
        break;
      case 2:
        RowDotsOf<2>(a, lda, rows, dim, qj, o, ldo);
        break;
      default:
        RowDotsOf<3>(a, lda, rows, dim, qj, o, ldo);
    }
  }
}

TSC_AVX2 void ScaleInt8Rows(const int8_t* codes, const uint8_t* drop, std::ptrdiff_t rows,
                            std::ptrdiff_t cols, int shift, float* out) {
  // A row's scale built from its bits, exponent drop − shift + 127, eight rows at a time.
  const __m256i bias = _mm256_set1_epi32(127 - shift);
  for (std::ptrdiff_t c = 0; c < cols; ++c) {
    const int8_t* v = codes + c * rows;
    float* o = out + c * rows;
    std::ptrdiff_t r = 0;
    for (; r + 8 <= rows; r += 8) {
      const __m256i code =
          _mm256_cvtepi8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(v + r)));
      const __m256i exponent = _mm256_add_epi32(
          _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(drop + r))), bias);
      const __m256 scale = _mm256_castsi256_ps(_mm256_slli_epi32(exponent, 23));
      _mm256_storeu_ps(o + r, _mm256_mul_ps(_mm256_cvtepi32_ps(code), scale));
    }
    for (; r < rows; ++r) {
      o[r] = static_cast<float>(v[r]) *
             std::bit_cast<float>(static_cast<uint32_t>(drop[r] - shift + 127) << 23);
    }
  }
}

TSC_AVX2 bool RowMagnitudes(const float* x, std::ptrdiff_t rows, std::ptrdiff_t cols,
                            float* row_most) {
  const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 largest = _mm256_set1_ps(std::numeric_limits<float>::max());
  __m256 beyond = _mm256_setzero_ps();  // lanes that met a |x| not ≤ the largest float
  bool finite = true;
  std::ptrdiff_t r = 0;
  for (; r + 8 <= rows; r += 8) {
    __m256 most = _mm256_setzero_ps();
    for (std::ptrdiff_t c = 0; c < cols; ++c) {
      const __m256 a = _mm256_and_ps(_mm256_loadu_ps(x + r + c * rows), magnitude);
      beyond = _mm256_or_ps(beyond, _mm256_cmp_ps(a, largest, _CMP_NLE_UQ));
      most = _mm256_max_ps(most, a);
    }
    _mm256_storeu_ps(row_most + r, most);
  }
  for (; r < rows; ++r) {
    float most = 0.0f;
    for (std::ptrdiff_t c = 0; c < cols; ++c) {
      const float a = std::abs(x[r + c * rows]);
      finite = finite && a <= std::numeric_limits<float>::max();
      most = std::max(most, a);
    }
    row_most[r] = most;
  }
  return finite && _mm256_movemask_ps(beyond) == 0;
}

TSC_AVX2 void RoundInt8Rows(const float* x, std::ptrdiff_t rows, std::ptrdiff_t cols,
                            const double* row_scale, int8_t* codes) {
  for (std::ptrdiff_t c = 0; c < cols; ++c) {
    const float* v = x + c * rows;
    int8_t* code = codes + c * rows;
    std::ptrdiff_t r = 0;
    for (; r + 4 <= rows; r += 4) {
      // Exact products rounded as RoundToInteger does (nearest, ties to even), packed to bytes.
      const __m256d scaled =
          _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(v + r)), _mm256_loadu_pd(row_scale + r));
      const __m128i whole = _mm256_cvtpd_epi32(
          _mm256_round_pd(scaled, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
      const __m128i bytes = _mm_packs_epi16(_mm_packs_epi32(whole, whole), whole);
      const int32_t four = _mm_cvtsi128_si32(bytes);
      std::memcpy(code + r, &four, 4);
    }
    for (; r < rows; ++r) {
      code[r] = static_cast<int8_t>(std::nearbyint(static_cast<double>(v[r]) * row_scale[r]));
    }
  }
}

// The squared distances (−2·x + col_sq[v]) + rows for the masked lanes of column v of `dots`
// (leading dimension n). −2·x is exact, so a fused −2·x + ‖y‖² rounds as the scalar product then
// sum do.
TSC_AVX2 inline __m256 DistancesTo(const float* dots, int n, int v, const float* col_sq,
                                   __m256 rows, __m256i mask) {
  const __m256 x = _mm256_maskload_ps(dots + static_cast<std::ptrdiff_t>(v) * n, mask);
  return _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(-2.0f), x), _mm256_set1_ps(col_sq[v])), rows);
}

TSC_AVX2 void NearestColumns(const float* dots, int n, int k, const float* col_sq,
                             const float* row_sq, float* nearest, int* at) {
  for (int j = 0; j < n; j += 8) {
    const __m256i mask = FirstLanes(std::min(8, n - j));
    const __m256 rows = _mm256_maskload_ps(row_sq + j, mask);
    __m256 best = DistancesTo(dots + j, n, 0, col_sq, rows, mask);
    __m256i best_at = _mm256_setzero_si256();
    for (int v = 1; v < k; ++v) {
      const __m256 d = DistancesTo(dots + j, n, v, col_sq, rows, mask);
      // Strictly less: the first nearest column on ties, and a NaN neither replaces nor is
      // replaced, as in the scalar loop.
      const __m256 nearer = _mm256_cmp_ps(d, best, _CMP_LT_OQ);
      best = _mm256_blendv_ps(best, d, nearer);
      best_at = _mm256_blendv_epi8(best_at, _mm256_set1_epi32(v), _mm256_castps_si256(nearer));
    }
    _mm256_maskstore_ps(nearest + j, mask, best);
    _mm256_maskstore_epi32(at + j, mask, best_at);
  }
}

namespace {

// values[0..n) in 8 lanes, each lane keeping its least (+∞ for lanes past n); NaN is skipped:
// _mm256_min_ps gives its second operand when either is NaN.
TSC_AVX2 inline __m256 LeastLanes(const float* values, int n) {
  const __m256 none = _mm256_set1_ps(std::numeric_limits<float>::infinity());
  __m256 least = none;
  int i = 0;
  for (; i + 8 <= n; i += 8) least = _mm256_min_ps(_mm256_loadu_ps(values + i), least);
  if (i < n) {
    const __m256i mask = FirstLanes(n - i);
    const __m256 x =
        _mm256_blendv_ps(none, _mm256_maskload_ps(values + i, mask), _mm256_castsi256_ps(mask));
    least = _mm256_min_ps(x, least);
  }
  return least;
}

}  // namespace

TSC_AVX2 float Least(const float* values, int n) {
  const __m256 lanes = LeastLanes(values, n);
  __m128 m = _mm_min_ps(_mm256_castps256_ps128(lanes), _mm256_extractf128_ps(lanes, 1));
  m = _mm_min_ps(m, _mm_movehl_ps(m, m));
  m = _mm_min_ss(m, _mm_movehdup_ps(m));
  return _mm_cvtss_f32(m);
}

TSC_AVX2 int FirstLeast(const float* values, int n) {
  const float least = Least(values, n);
  if (!(least < std::numeric_limits<float>::infinity())) return -1;
  const __m256 target = _mm256_set1_ps(least);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const int at =
        _mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(values + i), target, _CMP_EQ_OQ));
    if (at != 0) return i + std::countr_zero(static_cast<unsigned>(at));
  }
  for (; i < n; ++i) {
    if (values[i] == least) return i;
  }
  return -1;  // not reached: `least` is one of the values
}

TSC_AVX2 void LeastDistances(const float* dots, int rows, int nq, const float* q_norms,
                             float* nearest) {
  const __m256 two = _mm256_set1_ps(2.0f);
  const float none = std::numeric_limits<float>::infinity();
  int r = 0;
  for (; r + 8 <= rows; r += 8) {
    __m256 least = _mm256_set1_ps(none);
    for (int j = 0; j < nq; ++j) {
      const __m256 d = _mm256_sub_ps(_mm256_set1_ps(q_norms[j]),
                                     _mm256_mul_ps(two, _mm256_loadu_ps(dots + r + j * rows)));
      least = _mm256_min_ps(d, least);  // d where d < least, as std::min(least, d)
    }
    _mm256_storeu_ps(nearest + r, least);
  }
  LeastDistancesFrom(r, dots, rows, nq, q_norms, nearest);
}

#undef TSC_AVX2

#else  // no AVX2 kernels in this build: FastestSimd() never names them

void ColumnDots(const float*, int, const float*, int, int, float*, float*, const float*,
                std::ptrdiff_t, Lanes) {
  throw std::logic_error("avx2::ColumnDots: not in this build");
}

void RowDots(const float*, std::ptrdiff_t, int, int, const float*, int, float*, Lanes) {
  throw std::logic_error("avx2::RowDots: not in this build");
}

double UpperMedian(const double*, int) {
  throw std::logic_error("avx2::UpperMedian: not in this build");
}

void ColumnSquaredNorms(const float*, int, int, float*) {
  throw std::logic_error("avx2::ColumnSquaredNorms: not in this build");
}

void ScaleInt8Rows(const int8_t*, const uint8_t*, std::ptrdiff_t, std::ptrdiff_t, int, float*) {
  throw std::logic_error("avx2::ScaleInt8Rows: not in this build");
}

bool RowMagnitudes(const float*, std::ptrdiff_t, std::ptrdiff_t, float*) {
  throw std::logic_error("avx2::RowMagnitudes: not in this build");
}

void RoundInt8Rows(const float*, std::ptrdiff_t, std::ptrdiff_t, const double*, int8_t*) {
  throw std::logic_error("avx2::RoundInt8Rows: not in this build");
}

void NearestColumns(const float*, int, int, const float*, const float*, float*, int*) {
  throw std::logic_error("avx2::NearestColumns: not in this build");
}

float Least(const float*, int) { throw std::logic_error("avx2::Least: not in this build"); }

int FirstLeast(const float*, int) { throw std::logic_error("avx2::FirstLeast: not in this build"); }

void LeastDistances(const float*, int, int, const float*, float*) {
  throw std::logic_error("avx2::LeastDistances: not in this build");
}

#endif

}  // namespace avx2
}  // namespace tsc
